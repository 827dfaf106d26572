#include "server/server.h"

#include <spdlog/spdlog.h>

#include <utility>  // before Boost.Asio 1.74: its awaitable.hpp uses std::exchange

#include <boost/asio.hpp>
#include <chrono>
#include <csignal>
#include <deque>
#include <fstream>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>
#include <unordered_map>
#include <vector>

#include "protocol/framing.h"
#include "protocol/json_rpc.h"
#include "protocol/request.h"
#include "server/compute_pool.h"
#include "server/metrics.h"
#include "server/registry.h"
#include "server/service.h"

namespace geoprox::server {

namespace asio = boost::asio;
using asio::ip::tcp;
using protocol::ErrorReason;
using protocol::ProtocolError;
using Clock = std::chrono::steady_clock;

class Connection;
class HttpSession;

struct Server::Impl {
  Impl(Config c, ServerOptions o);
  ~Impl();

  void start();
  void do_accept();
  void do_admin_accept();
  void refuse_connection(tcp::socket socket, const std::string& why);
  void begin_drain();
  void drain_tick();
  void finish();
  void wait_signal();
  void add(const std::shared_ptr<Connection>& c);
  void remove(Connection* c);
  std::vector<std::shared_ptr<Connection>> connection_list();
  void write_port_file();
  void run_io();

  Config config;
  ServerOptions options;
  Metrics metrics;
  ServerState state;
  std::unique_ptr<Registry> registry;
  std::unique_ptr<Service> service;
  asio::io_context io;
  std::unique_ptr<ComputePool> pool;
  tcp::acceptor acceptor;
  tcp::acceptor admin_acceptor;
  asio::steady_timer accept_retry;
  asio::steady_timer drain_timer;
  asio::signal_set signals;
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work;
  std::vector<std::thread> io_threads;
  std::uint16_t bound_port = 0;
  std::uint16_t bound_admin_port = 0;

  std::mutex connections_mutex;
  std::unordered_map<Connection*, std::weak_ptr<Connection>> connections;

  bool started = false;
  bool finished = false;
  bool drain_closing = false;
  Clock::time_point drain_deadline;
  Clock::time_point drain_started;
  Clock::time_point last_accept_warning;
  std::mutex wait_mutex;
};

// ---------------------------------------------------------------------------------------------
// A client connection. Every member is used on the connection's strand only, but for the
// finished-query inbox that compute threads fill (deliver()).

class Connection : public std::enable_shared_from_this<Connection> {
 public:
  Connection(Server::Impl& server, tcp::socket socket)
      : server_(server),
        socket_(std::move(socket)),
        timer_(socket_.get_executor()),
        framer_(server.config.limits.max_line_bytes),
        buffer_(64 * 1024),
        authenticated_(!server.service->query_token_required()) {
    boost::system::error_code ec;
    const auto endpoint = socket_.remote_endpoint(ec);
    peer_ = ec ? std::string("?") : endpoint.address().to_string() + ":" +
                                         std::to_string(endpoint.port());
  }

  void start() {
    asio::dispatch(socket_.get_executor(), [self = shared_from_this()] {
      self->last_activity_ = Clock::now();
      self->arm_timer();
      self->do_read();
    });
  }

  /// Shutdown: close once the replies queued so far are written.
  void drain_close() {
    asio::dispatch(socket_.get_executor(), [self = shared_from_this()] {
      self->closing_ = true;
      self->maybe_finish();
    });
  }

  /// Shutdown deadline: cancel what is in flight and close now.
  void force_close() {
    asio::dispatch(socket_.get_executor(),
                   [self = shared_from_this()] { self->close("server shutdown deadline"); });
  }

 private:
  struct Active {
    std::shared_ptr<std::atomic<bool>> cancelled;
  };
  struct Finished {
    std::uint64_t key;
    std::shared_ptr<protocol::Call> call;
    protocol::Method method;
    std::string mesh;
    Clock::time_point received;
    Answer answer;
  };

  const ServerLimits& limits() const { return server_.config.server_limits; }

  void do_read() {
    if (closed_ || reading_ || eof_ || closing_) return;
    reading_ = true;
    socket_.async_read_some(asio::buffer(buffer_),
                            [self = shared_from_this()](boost::system::error_code ec,
                                                        std::size_t n) { self->on_read(ec, n); });
  }

  void on_read(boost::system::error_code ec, std::size_t n) {
    reading_ = false;
    if (closed_) return;
    if (n > 0) {
      server_.metrics.bytes_read.fetch_add(n, std::memory_order_relaxed);
      const std::size_t frames_before = framer_.pending_frames();
      framer_.feed(std::string_view(buffer_.data(), n));
      // Only a completed line (a blank keep-alive too) restarts the read timeout: restarting it
      // on every byte let a client trickling one byte per second hold a connection forever.
      if (framer_.pending_frames() > frames_before || framer_.partial_bytes() == 0) {
        last_activity_ = Clock::now();
      }
    }
    if (ec) {
      if (ec == asio::error::eof) {
        eof_ = true;  // half-close: answer what was sent, then close
        framer_.finish();
      } else {
        if (ec != asio::error::operation_aborted) {
          spdlog::debug("connection {}: read error: {}", peer_, ec.message());
        }
        close("read error");
        return;
      }
    }
    process_frames();
  }

  void process_frames() {
    const std::size_t max_inflight = limits().max_inflight_per_connection;
    while (!closed_ && !locked_out_ && inflight_ < max_inflight) {
      std::optional<protocol::Frame> frame = framer_.next();
      if (!frame) break;
      if (frame->kind == protocol::Frame::Kind::TooLarge) {
        const ProtocolError error = protocol::line_too_large_error(framer_.max_line_bytes());
        server_.metrics.record_request(std::nullopt, error.reason(), 0);
        spdlog::debug("request from {}: line over {} bytes refused", peer_,
                      framer_.max_line_bytes());
        enqueue_write(protocol::serialize_error(protocol::RequestId(), error));
        continue;
      }
      handle_line(frame->line);
    }
    if (closed_) return;
    if (eof_ || closing_) {
      maybe_finish();
      return;
    }
    // Too many in flight: stop reading until replies drain (complete() resumes).
    if (inflight_ < max_inflight) do_read();
  }

  void handle_line(const std::string& line) {
    const auto received = Clock::now();
    auto decoded = protocol::decode_request(line, server_.config.limits);
    if (auto* rejection = std::get_if<protocol::Rejection>(&decoded)) {
      const auto method = protocol::method_from_name(rejection->method_name);
      if (!authenticated_ && method && !protocol::allowed_before_auth(*method)) {
        // Before server.auth, even a malformed query learns nothing but Unauthorized.
        rejection->error = unauthenticated_error(*method);
      }
      server_.metrics.record_request(method, rejection->error.reason(), 0);
      log_request(rejection->id ? rejection->id->json_text() : "null", rejection->method_name,
                  "", received, rejection->error.reason(), rejection->error.what());
      if (auto reply = rejection->reply_line()) enqueue_write(std::move(*reply));
      return;
    }
    dispatch(std::move(std::get<protocol::Call>(decoded)), received);
  }

  void dispatch(protocol::Call call, Clock::time_point received) {
    const protocol::Method method = call.method();
    // The one access check of the hot path: a per-connection flag. server.auth is answered
    // here, in line order, so a request pipelined after it sees its outcome.
    if (!authenticated_ && !protocol::allowed_before_auth(method)) {
      finish_request(call, method, "", received,
                     Service::refuse(call, unauthenticated_error(method)));
      return;
    }
    Service& service = *server_.service;
    if (Service::answered_inline(method)) {
      RequestContext context;
      Answer answer = service.answer(call, context);
      const bool auth = method == protocol::Method::ServerAuth;
      if (auth) note_auth(answer);
      finish_request(call, method, context.mesh, received, std::move(answer));
      if (auth && locked_out_) maybe_finish();  // closes once the refusal is written
      return;
    }
    if (server_.state.draining.load()) {
      finish_request(call, method, "", received,
                     Service::refuse(call, ProtocolError(ErrorReason::ShuttingDown,
                                                         "the server is shutting down; retry "
                                                         "on another instance")));
      return;
    }
    const std::uint64_t key = next_key_++;
    auto cancelled = std::make_shared<std::atomic<bool>>(false);
    const auto deadline =
        received + std::chrono::milliseconds(server_.config.limits.effective_timeout_ms(
                       call.timeout_ms));
    auto shared_call = std::make_shared<protocol::Call>(std::move(call));
    auto task = [self = shared_from_this(), key, cancelled, shared_call, deadline, received,
                 method] {
      RequestContext context;
      Answer answer;
      if (cancelled->load()) {
        answer.error = ErrorReason::DeadlineExceeded;  // the client is gone: nothing is sent
      } else {
        context.interrupt.deadline = deadline;
        context.interrupt.cancelled = cancelled.get();
        answer = self->server_.service->answer(*shared_call, context);
      }
      self->deliver(Finished{key, shared_call, method, std::move(context.mesh), received,
                             std::move(answer)});
    };
    active_.emplace(key, Active{cancelled});
    ++inflight_;
    server_.metrics.in_flight.fetch_add(1, std::memory_order_relaxed);
    bool queued = true;
    if (protocol::is_admin_method(method)) {
      server_.pool->submit(std::move(task));
    } else {
      queued = server_.pool->try_submit(std::move(task));
    }
    if (!queued) {
      active_.erase(key);
      --inflight_;
      server_.metrics.in_flight.fetch_sub(1, std::memory_order_relaxed);
      const std::size_t waiting = server_.pool->waiting();
      ProtocolError error(ErrorReason::Overloaded,
                          "compute queue full (" + std::to_string(waiting) + " waiting)");
      error.set_retry_after_ms(server_.pool->retry_after_ms());
      finish_request(*shared_call, method, "", received, Service::refuse(*shared_call, error));
    }
  }

  static ProtocolError unauthenticated_error(protocol::Method method) {
    return ProtocolError(ErrorReason::Unauthorized,
                         "this server needs server.auth with its query token before " +
                             std::string(protocol::method_name(method)) +
                             " (server.health says auth_required)");
  }

  /// Keeps the outcome of a server.auth: right token, authenticated; wrong token (or any
  /// failure), not, and after Service::kMaxAuthFailures failures the connection is closed.
  void note_auth(const Answer& answer) {
    if (!server_.service->query_token_required()) return;  // open: nothing to lose or count
    authenticated_ = !answer.error;
    if (authenticated_) return;
    ++auth_failures_;
    spdlog::warn("connection {}: server.auth refused ({} of {} attempts)", peer_, auth_failures_,
                 Service::kMaxAuthFailures);
    if (auth_failures_ >= Service::kMaxAuthFailures) {
      spdlog::warn("connection {}: closed after {} failed server.auth attempts", peer_,
                   auth_failures_);
      locked_out_ = true;
      closing_ = true;  // no more reading; maybe_finish() closes once the replies are out
    }
  }

  /// From a compute thread: hands a finished query to the strand. Only the first of the
  /// queries finishing before the strand runs posts to it, so one wake-up of the I/O thread
  /// (a syscall and a context switch, ~10 us on a VM) serves them all and their replies leave
  /// in one write.
  void deliver(Finished done) {
    bool post = false;
    {
      std::lock_guard lock(finished_mutex_);
      finished_.push_back(std::move(done));
      post = !std::exchange(finished_posted_, true);
    }
    if (post) {
      asio::post(socket_.get_executor(), [self = shared_from_this()] { self->complete(); });
    }
  }

  void complete() {
    {
      std::lock_guard lock(finished_mutex_);
      completing_.swap(finished_);
      finished_posted_ = false;
    }
    batching_writes_ = true;
    for (Finished& done : completing_) {
      active_.erase(done.key);
      --inflight_;
      server_.metrics.in_flight.fetch_sub(1, std::memory_order_relaxed);
      finish_request(*done.call, done.method, done.mesh, done.received, std::move(done.answer));
    }
    completing_.clear();
    batching_writes_ = false;
    if (!closed_ && !writing_ && !queue_.empty()) do_write();
    if (!closed_) process_frames();
  }

  void finish_request(const protocol::Call& call, protocol::Method method, const std::string& mesh,
                      Clock::time_point received, Answer answer) {
    const double seconds = std::chrono::duration<double>(Clock::now() - received).count();
    server_.metrics.record_request(method, answer.error, seconds);
    log_request(call.id ? call.id->json_text() : "none", call.method_name, mesh, received,
                answer.error, answer.error ? std::string_view(answer.line) : std::string_view());
    if (!answer.line.empty() && !closed_) enqueue_write(std::move(answer.line));
  }

  void log_request(const std::string& id, std::string_view method, std::string_view mesh,
                   Clock::time_point received, std::optional<ErrorReason> error,
                   std::string_view detail) {
    const bool internal = error && *error == ErrorReason::Internal;
    const auto level = internal ? spdlog::level::err : spdlog::level::debug;
    if (!spdlog::should_log(level)) return;
    const double ms =
        std::chrono::duration<double, std::milli>(Clock::now() - received).count();
    auto clip = [](std::string_view s, std::size_t n) {
      return s.size() <= n ? std::string(s) : std::string(s.substr(0, n)) + "...";
    };
    const std::string outcome = error ? std::string(protocol::reason_name(*error)) : "ok";
    if (internal) {
      spdlog::error("request peer={} id={} method={} mesh={} duration_ms={:.3f} outcome={} "
                    "reply={}",
                    peer_, clip(id, 64), clip(method, 64), mesh, ms, outcome, clip(detail, 512));
    } else {
      spdlog::debug("request peer={} id={} method={} mesh={} duration_ms={:.3f} outcome={}",
                    peer_, clip(id, 64), clip(method, 64), mesh.empty() ? "-" : mesh, ms,
                    outcome);
    }
  }

  void enqueue_write(std::string line) {
    if (closed_) return;
    if (queued_bytes_ > 0 && queued_bytes_ + line.size() > limits().max_write_buffer_bytes) {
      server_.metrics.slow_reader_disconnects.fetch_add(1, std::memory_order_relaxed);
      spdlog::warn("connection {}: {} bytes of replies not read by the client (limit {}); "
                   "disconnecting it",
                   peer_, queued_bytes_ + line.size(), limits().max_write_buffer_bytes);
      close("slow reader");
      return;
    }
    queued_bytes_ += line.size();
    queue_.push_back(std::move(line));
    if (!writing_ && !batching_writes_) do_write();
  }

  void do_write() {
    writing_ = true;
    in_write_.clear();
    buffers_.clear();
    std::size_t bytes = 0;
    while (!queue_.empty() && in_write_.size() < 64 && bytes < (1u << 20)) {
      bytes += queue_.front().size();
      in_write_.push_back(std::move(queue_.front()));
      queue_.pop_front();
    }
    for (const std::string& s : in_write_) buffers_.emplace_back(s.data(), s.size());
    asio::async_write(socket_, buffers_,
                      [self = shared_from_this(), bytes](boost::system::error_code ec,
                                                         std::size_t n) {
                        self->on_write(ec, n, bytes);
                      });
  }

  void on_write(boost::system::error_code ec, std::size_t n, std::size_t bytes) {
    writing_ = false;
    in_write_.clear();
    server_.metrics.bytes_written.fetch_add(n, std::memory_order_relaxed);
    queued_bytes_ -= std::min(queued_bytes_, bytes);
    if (closed_) return;
    if (ec) {
      spdlog::debug("connection {}: write error: {}", peer_, ec.message());
      close("write error");
      return;
    }
    last_activity_ = Clock::now();
    if (!queue_.empty()) {
      do_write();
      return;
    }
    maybe_finish();
  }

  /// After the client half-closed (or the server drains): close once everything is answered.
  void maybe_finish() {
    if (closed_) return;
    if (!(eof_ || closing_)) return;
    if (closing_ && !writing_ && queue_.empty()) {
      close(eof_ ? "client closed"
                 : locked_out_ ? "too many failed server.auth attempts"
                               : "server shutdown");
      return;
    }
    if (eof_ && inflight_ == 0 && framer_.pending_frames() == 0 && !writing_ && queue_.empty()) {
      close("client closed");
    }
  }

  void arm_timer() {
    const auto timeout = std::chrono::milliseconds(limits().read_timeout_ms);
    timer_.expires_at(last_activity_ + timeout);
    timer_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
      if (ec || self->closed_) return;
      const auto timeout_at =
          self->last_activity_ + std::chrono::milliseconds(self->limits().read_timeout_ms);
      const bool idle = self->inflight_ == 0 && !self->writing_ && self->queue_.empty();
      if (idle && Clock::now() >= timeout_at) {
        self->server_.metrics.read_timeouts.fetch_add(1, std::memory_order_relaxed);
        self->close("read timeout");
        return;
      }
      if (!idle) self->last_activity_ = Clock::now();
      self->arm_timer();
    });
  }

  void close(const char* why) {
    if (closed_) return;
    closed_ = true;
    for (auto& [key, active] : active_) active.cancelled->store(true);
    boost::system::error_code ec;
    timer_.cancel();
    socket_.shutdown(tcp::socket::shutdown_both, ec);
    socket_.close(ec);
    queue_.clear();
    queued_bytes_ = 0;
    spdlog::debug("connection {}: closed ({}; {} requests in flight cancelled)", peer_, why,
                  active_.size());
    server_.remove(this);
  }

  Server::Impl& server_;
  tcp::socket socket_;
  asio::steady_timer timer_;
  protocol::LineFramer framer_;
  std::vector<char> buffer_;
  std::string peer_;
  bool reading_ = false;
  bool eof_ = false;
  bool closing_ = false;
  bool closed_ = false;
  bool writing_ = false;
  /// server.auth succeeded last, or the server has no query token.
  bool authenticated_;
  bool locked_out_ = false;  ///< too many failed server.auth: nothing more is read or answered
  unsigned auth_failures_ = 0;
  std::size_t inflight_ = 0;
  std::uint64_t next_key_ = 0;
  std::unordered_map<std::uint64_t, Active> active_;
  std::deque<std::string> queue_;
  std::size_t queued_bytes_ = 0;
  std::vector<std::string> in_write_;
  std::vector<asio::const_buffer> buffers_;
  Clock::time_point last_activity_ = Clock::now();
  bool batching_writes_ = false;  ///< inside complete(): replies are written once at its end
  std::vector<Finished> completing_;
  // The only members compute threads touch (deliver()): queries finished, not yet completed.
  std::mutex finished_mutex_;
  std::vector<Finished> finished_;
  bool finished_posted_ = false;  ///< a complete() is posted and has not taken finished_ yet
};

// ---------------------------------------------------------------------------------------------
// Admin HTTP: one request per connection (HTTP/1.0 style, Connection: close).

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(Server::Impl& server, tcp::socket socket)
      : server_(server), socket_(std::move(socket)), timer_(socket_.get_executor()),
        buffer_(16 * 1024) {}

  void start() {
    timer_.expires_after(std::chrono::seconds(5));
    timer_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
      if (!ec) {
        boost::system::error_code ignored;
        self->socket_.close(ignored);
      }
    });
    asio::async_read_until(socket_, buffer_, "\r\n\r\n",
                           [self = shared_from_this()](boost::system::error_code ec,
                                                       std::size_t) { self->on_request(ec); });
  }

 private:
  void on_request(boost::system::error_code ec) {
    if (ec) {
      if (ec == asio::error::not_found) respond(431, "Request Header Fields Too Large", "text/plain", "request too large\n", true);
      else close();
      return;
    }
    std::istream in(&buffer_);
    std::string method, target, version;
    in >> method >> target >> version;
    const bool head = method == "HEAD";
    if (method != "GET" && !head) {
      respond(405, "Method Not Allowed", "text/plain", "only GET and HEAD\n", !head);
      return;
    }
    const auto query = target.find('?');
    if (query != std::string::npos) target.resize(query);
    if (target == "/metrics") {
      respond(200, "OK", "text/plain; version=0.0.4; charset=utf-8",
              server_.service->metrics_text(), !head);
    } else if (target == "/healthz") {
      respond(200, "OK", "text/plain", "ok\n", !head);
    } else if (target == "/readyz") {
      const protocol::HealthResult h = server_.service->health();
      const std::string status(protocol::health_status_name(h.status));
      if (h.status == protocol::HealthStatus::Ok) {
        respond(200, "OK", "text/plain", "ready\n", !head);
      } else {
        respond(503, "Service Unavailable", "text/plain", "not ready: " + status + "\n", !head);
      }
    } else {
      respond(404, "Not Found", "text/plain", "unknown path (try /metrics, /healthz, /readyz)\n",
              !head);
    }
  }

  void respond(int code, const char* reason, const char* type, std::string body,
               bool with_body) {
    response_ = "HTTP/1.1 " + std::to_string(code) + " " + reason + "\r\nContent-Type: " + type +
                "\r\nContent-Length: " + std::to_string(body.size()) +
                "\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n";
    if (with_body) response_ += body;
    asio::async_write(socket_, asio::buffer(response_),
                      [self = shared_from_this()](boost::system::error_code, std::size_t) {
                        self->close();
                      });
  }

  void close() {
    boost::system::error_code ec;
    timer_.cancel();
    socket_.shutdown(tcp::socket::shutdown_both, ec);
    socket_.close(ec);
  }

  Server::Impl& server_;
  tcp::socket socket_;
  asio::steady_timer timer_;
  asio::streambuf buffer_;
  std::string response_;
};

// ---------------------------------------------------------------------------------------------

Server::Impl::Impl(Config c, ServerOptions o)
    : config(std::move(c)),
      options(std::move(o)),
      io(static_cast<int>(config.io_threads)),
      acceptor(io),
      admin_acceptor(io),
      accept_retry(io),
      drain_timer(io),
      signals(io) {
  const unsigned threads = config.effective_compute_threads();
  RegistryOptions registry_options;
  registry_options.data_dir = config.data_dir;
  registry_options.graph_dir = config.graph_dir;
  registry_options.max_scratch_per_mesh = threads;
  registry_options.build_threads = static_cast<int>(config.build_threads);
  pool = std::make_unique<ComputePool>(threads, config.server_limits.max_queue, &metrics);
  if (config.split_near_pairs) {
    registry_options.run_both = std::bind_front(&ComputePool::run_both, pool.get());
  }
  registry = std::make_unique<Registry>(registry_options);
  service = std::make_unique<Service>(config, *registry, metrics, state);
}

Server::Impl::~Impl() {
  if (pool) pool->stop();
}

namespace {

tcp::endpoint make_endpoint(const std::string& host, std::uint16_t port) {
  boost::system::error_code ec;
  const auto address = asio::ip::make_address(host, ec);
  if (ec) throw std::runtime_error("bind address \"" + host + "\" is not an IP address");
  return {address, port};
}

void open_acceptor(tcp::acceptor& acceptor, const tcp::endpoint& endpoint, const char* what) {
  boost::system::error_code ec;
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    throw std::runtime_error(std::string("cannot listen on ") + what + " " +
                             endpoint.address().to_string() + ":" +
                             std::to_string(endpoint.port()) + ": " + ec.message());
  }
}

}  // namespace

void Server::Impl::run_io() {
  // Interrupt coalescing, as network cards do it: with requests queued for the compute threads,
  // answering a reply or reading a request a few hundred microseconds later costs no
  // throughput, while every wake-up of this thread is an epoll wait, a read or write and two
  // context switches that take a core from a query (~10 us each on a VM). Pausing between
  // rounds of events under load lets replies and requests gather: +6% closed-loop throughput
  // on lucy with 2 compute threads. Without a backlog nothing waits.
  const auto pause = std::chrono::microseconds(config.io_coalesce_us);
  const std::size_t backlog = 4 * static_cast<std::size_t>(pool->threads());
  if (pause.count() == 0) {
    io.run();
    return;
  }
  while (!io.stopped()) {
    if (io.run_one() == 0) return;
    io.poll();
    if (pool->waiting() >= backlog) std::this_thread::sleep_for(pause);
  }
}

void Server::Impl::start() {
  open_acceptor(acceptor, make_endpoint(config.bind, config.port), "the query port");
  bound_port = acceptor.local_endpoint().port();
  if (config.admin_port != 0 || options.port_file.empty() == false) {
    // admin_port 0 means "off"; tests that want an ephemeral admin port use the port file.
  }
  if (config.admin_port != 0) {
    open_acceptor(admin_acceptor, make_endpoint(config.admin_bind, config.admin_port),
                  "the admin port");
    bound_admin_port = admin_acceptor.local_endpoint().port();
  }
  work.emplace(io.get_executor());
  if (options.handle_signals) {
    signals.add(SIGTERM);
    signals.add(SIGINT);
    signals.add(SIGHUP);
    wait_signal();
  }
  registry->add_configured(config.meshes);
  do_accept();
  if (admin_acceptor.is_open()) do_admin_accept();
  for (unsigned i = 0; i < config.io_threads; ++i) {
    io_threads.emplace_back([this, i] {
      name_this_thread("gp-io-" + std::to_string(i));
      for (;;) {
        try {
          run_io();
          return;
        } catch (const std::exception& e) {
          spdlog::critical("I/O handler threw (a bug): {}; continuing", e.what());
        }
      }
    });
  }
  started = true;
  spdlog::info("geoproxd listening on {}:{} (admin {}), {} compute threads, {} I/O threads, "
               "{} meshes configured",
               config.bind, bound_port,
               bound_admin_port ? config.admin_bind + ":" + std::to_string(bound_admin_port)
                                : std::string("off"),
               pool->threads(), config.io_threads, config.meshes.size());
  if (!options.port_file.empty()) write_port_file();
}

void Server::Impl::write_port_file() {
  const auto tmp = options.port_file.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << "{\"port\": " << bound_port << ", \"admin_port\": " << bound_admin_port << "}\n";
  }
  std::error_code ec;
  std::filesystem::rename(tmp, options.port_file, ec);
  if (ec) spdlog::error("cannot write the port file {}: {}", options.port_file.string(), ec.message());
}

void Server::Impl::wait_signal() {
  signals.async_wait([this](boost::system::error_code ec, int signal) {
    if (ec) return;
    if (signal == SIGHUP) {
      spdlog::info("SIGHUP: reloading graph files");
      pool->submit([this] { service->reload(std::nullopt); });
    } else if (state.draining.load()) {
      spdlog::warn("signal {} during shutdown: stopping now", signal);
      drain_deadline = Clock::now();
    } else {
      spdlog::info("signal {}: shutting down gracefully (deadline {} ms)", signal,
                   config.shutdown_timeout_ms);
      begin_drain();
    }
    wait_signal();
  });
}

void Server::Impl::do_accept() {
  acceptor.async_accept(asio::make_strand(io), [this](boost::system::error_code ec,
                                                       tcp::socket socket) {
    if (ec) {
      if (!acceptor.is_open() || ec == asio::error::operation_aborted) return;
      metrics.accept_errors.fetch_add(1, std::memory_order_relaxed);
      const auto now = Clock::now();
      if (now - last_accept_warning > std::chrono::seconds(1)) {
        last_accept_warning = now;
        spdlog::warn("accept failed: {} (retrying in 100 ms)", ec.message());
      }
      accept_retry.expires_after(std::chrono::milliseconds(100));
      accept_retry.async_wait([this](boost::system::error_code timer_ec) {
        if (!timer_ec && acceptor.is_open()) do_accept();
      });
      return;
    }
    if (state.draining.load()) {
      refuse_connection(std::move(socket), "the server is shutting down");
    } else if (static_cast<std::size_t>(metrics.connections.load()) >=
               config.server_limits.max_connections) {
      metrics.connections_refused.fetch_add(1, std::memory_order_relaxed);
      refuse_connection(std::move(socket), "too many connections (max_connections " +
                                               std::to_string(config.server_limits.max_connections) +
                                               ")");
    } else {
      boost::system::error_code ignored;
      socket.set_option(tcp::no_delay(true), ignored);
      auto connection = std::make_shared<Connection>(*this, std::move(socket));
      add(connection);
      connection->start();
    }
    do_accept();
  });
}

void Server::Impl::refuse_connection(tcp::socket socket, const std::string& why) {
  auto s = std::make_shared<tcp::socket>(std::move(socket));
  ProtocolError error(state.draining.load() ? ErrorReason::ShuttingDown : ErrorReason::Overloaded,
                      why);
  if (error.reason() == ErrorReason::Overloaded) error.set_retry_after_ms(1000);
  auto line = std::make_shared<std::string>(protocol::serialize_error(protocol::RequestId(), error));
  spdlog::debug("connection refused: {}", why);
  asio::async_write(*s, asio::buffer(*line), [s, line](boost::system::error_code, std::size_t) {
    boost::system::error_code ignored;
    s->shutdown(tcp::socket::shutdown_both, ignored);
    s->close(ignored);
  });
}

void Server::Impl::do_admin_accept() {
  admin_acceptor.async_accept(asio::make_strand(io), [this](boost::system::error_code ec,
                                                             tcp::socket socket) {
    if (ec) {
      if (!admin_acceptor.is_open() || ec == asio::error::operation_aborted) return;
      metrics.accept_errors.fetch_add(1, std::memory_order_relaxed);
      auto timer = std::make_shared<asio::steady_timer>(io, std::chrono::milliseconds(100));
      timer->async_wait([this, timer](boost::system::error_code timer_ec) {
        if (!timer_ec && admin_acceptor.is_open()) do_admin_accept();
      });
      return;
    }
    std::make_shared<HttpSession>(*this, std::move(socket))->start();
    do_admin_accept();
  });
}

void Server::Impl::add(const std::shared_ptr<Connection>& c) {
  std::lock_guard lock(connections_mutex);
  connections.emplace(c.get(), c);
  metrics.connections.fetch_add(1);
  metrics.connections_total.fetch_add(1);
}

void Server::Impl::remove(Connection* c) {
  std::lock_guard lock(connections_mutex);
  if (connections.erase(c)) metrics.connections.fetch_sub(1);
}

std::vector<std::shared_ptr<Connection>> Server::Impl::connection_list() {
  std::lock_guard lock(connections_mutex);
  std::vector<std::shared_ptr<Connection>> out;
  for (auto& [raw, weak] : connections) {
    if (auto c = weak.lock()) out.push_back(std::move(c));
  }
  return out;
}

void Server::Impl::begin_drain() {
  if (state.draining.exchange(true)) return;
  drain_started = Clock::now();
  drain_deadline = drain_started + std::chrono::milliseconds(config.shutdown_timeout_ms);
  boost::system::error_code ec;
  acceptor.close(ec);
  accept_retry.cancel();
  spdlog::info("draining: not accepting, {} requests in flight, {} connections",
               metrics.in_flight.load(), metrics.connections.load());
  drain_tick();
}

void Server::Impl::drain_tick() {
  const auto now = Clock::now();
  if (!drain_closing && metrics.in_flight.load() == 0) {
    drain_closing = true;
    for (auto& c : connection_list()) c->drain_close();
  }
  if (drain_closing && metrics.connections.load() == 0) {
    spdlog::info("drained in {:.0f} ms",
                 std::chrono::duration<double, std::milli>(now - drain_started).count());
    finish();
    return;
  }
  if (now >= drain_deadline) {
    spdlog::warn("shutdown deadline reached with {} requests in flight: cancelling them",
                 metrics.in_flight.load());
    for (auto& c : connection_list()) c->force_close();
    drain_timer.expires_after(std::chrono::milliseconds(50));
    drain_timer.async_wait([this](boost::system::error_code) { finish(); });
    return;
  }
  drain_timer.expires_after(std::chrono::milliseconds(10));
  drain_timer.async_wait([this](boost::system::error_code ec) {
    if (!ec) drain_tick();
  });
}

void Server::Impl::finish() {
  if (finished) return;
  finished = true;
  boost::system::error_code ec;
  admin_acceptor.close(ec);
  signals.cancel(ec);
  work.reset();
  io.stop();
}

// ---------------------------------------------------------------------------------------------

Server::Server(Config config, ServerOptions options)
    : impl_(std::make_unique<Impl>(std::move(config), std::move(options))) {}

Server::~Server() {
  if (impl_->started) {
    shutdown();
    wait();
  }
}

void Server::start() { impl_->start(); }
std::uint16_t Server::port() const { return impl_->bound_port; }
std::uint16_t Server::admin_port() const { return impl_->bound_admin_port; }
const Config& Server::config() const { return impl_->config; }
Registry& Server::registry() { return *impl_->registry; }
Service& Server::service() { return *impl_->service; }
Metrics& Server::metrics() { return impl_->metrics; }

void Server::shutdown() {
  asio::post(impl_->io, [impl = impl_.get()] { impl->begin_drain(); });
}

void Server::reload_async() {
  impl_->pool->submit([impl = impl_.get()] { impl->service->reload(std::nullopt); });
}

void Server::wait() {
  std::lock_guard lock(impl_->wait_mutex);
  for (auto& t : impl_->io_threads) {
    if (t.joinable()) t.join();
  }
  impl_->io_threads.clear();
  impl_->pool->stop();
  impl_->started = false;
}

}  // namespace geoprox::server
