#include "server/connection.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "server/connection_manager.h"
#include "server/logging.h"

namespace geoprox::server {

namespace asio = boost::asio;
using asio::ip::tcp;
using protocol::ErrorReason;
using protocol::ProtocolError;

namespace {

/// Replies gathered into one write: at most this many lines and (about) this many bytes.
constexpr std::size_t kMaxLinesPerWrite = 64;
constexpr std::size_t kMaxBytesPerWrite = std::size_t{1} << 20;
/// Client-chosen text in log lines is cut to these lengths.
constexpr std::size_t kMaxLoggedIdBytes = 64;
constexpr std::size_t kMaxLoggedMethodBytes = 64;
constexpr std::size_t kMaxLoggedReplyBytes = 512;

std::string clip(std::string_view text, std::size_t max_bytes) {
  if (text.size() <= max_bytes) return std::string(text);
  std::string out(text.substr(0, max_bytes));
  out += "...";
  return out;
}

ProtocolError shutting_down_error() {
  return ProtocolError(ErrorReason::ShuttingDown,
                       "the server is shutting down; retry on another instance");
}

/// The request id as logged: its JSON value, or its clipped text when it is long.
nlohmann::ordered_json logged_id(const protocol::RequestId* id) {
  if (id == nullptr) return nullptr;
  if (id->json_text().size() > kMaxLoggedIdBytes) return clip(id->json_text(), kMaxLoggedIdBytes);
  return id->value();
}

}  // namespace

Connection::Connection(const ConnectionEnv& env, tcp::socket socket)
    : env_(env),
      socket_(std::move(socket)),
      timer_(socket_.get_executor()),
      framer_(env.config.limits.max_line_bytes),
      buffer_(64 * 1024),
      authenticated_(!env.service.query_token_required()) {
  boost::system::error_code ec;
  const auto endpoint = socket_.remote_endpoint(ec);
  if (ec) {
    peer_ = "?";
  } else {
    peer_ = endpoint.address().to_string();
    peer_ += ':';
    peer_ += std::to_string(endpoint.port());
  }
}

void Connection::start() {
  asio::dispatch(socket_.get_executor(), [self = shared_from_this()] {
    self->last_activity_ = Clock::now();
    self->arm_timer();
    self->do_read();
  });
}

void Connection::drain_close() {
  asio::dispatch(socket_.get_executor(), [self = shared_from_this()] {
    self->closing_ = true;
    self->maybe_finish();
  });
}

void Connection::force_close() {
  asio::dispatch(socket_.get_executor(),
                 [self = shared_from_this()] { self->close("server shutdown deadline"); });
}

// ---- reading and dispatching ----

void Connection::do_read() {
  if (closed_ || reading_ || eof_ || closing_) return;
  reading_ = true;
  socket_.async_read_some(asio::buffer(buffer_),
                          [self = shared_from_this()](boost::system::error_code ec,
                                                      std::size_t n) { self->on_read(ec, n); });
}

void Connection::on_read(boost::system::error_code ec, std::size_t n) {
  reading_ = false;
  if (closed_) return;
  if (n > 0) {
    env_.metrics.bytes_read.fetch_add(n, std::memory_order_relaxed);
    const std::size_t frames_before = framer_.pending_frames();
    framer_.feed(std::string_view(buffer_.data(), n));
    // Only a completed line (a blank keep-alive too) restarts the read timeout: restarting it
    // on every byte would let a client trickling one byte at a time hold a connection forever.
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

void Connection::process_frames() {
  const std::size_t max_inflight = limits().max_inflight_per_connection;
  while (!closed_ && !locked_out_ && inflight_ < max_inflight) {
    std::optional<protocol::Frame> frame = framer_.next();
    if (!frame) break;
    if (frame->kind == protocol::Frame::Kind::TooLarge) {
      const ProtocolError error = protocol::line_too_large_error(framer_.max_line_bytes());
      env_.metrics.record_request(Transport::Tcp, std::nullopt, error.reason(), 0);
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

void Connection::handle_line(const std::string& line) {
  const auto received = Clock::now();
  auto decoded = protocol::decode_message(line, env_.config.limits);
  if (auto* batch = std::get_if<protocol::BatchCall>(&decoded)) {
    dispatch_batch(std::move(*batch), received);
    return;
  }
  if (auto* rejection = std::get_if<protocol::Rejection>(&decoded)) {
    const auto method = protocol::method_from_name(rejection->method_name);
    if (!authenticated_ && method && !protocol::allowed_before_auth(*method)) {
      // Before server.auth, even a malformed query learns nothing but Unauthorized.
      rejection->error = Service::unauthenticated_error(*method);
    }
    env_.metrics.record_request(Transport::Tcp, method, rejection->error.reason(), 0);
    log_request(rejection->id ? &*rejection->id : nullptr, rejection->method_name, "", received,
                rejection->error.reason(), rejection->error.what());
    if (auto reply = rejection->reply_line()) enqueue_write(std::move(*reply));
    return;
  }
  dispatch(std::move(std::get<protocol::Call>(decoded)), received);
}

void Connection::dispatch(protocol::Call call, Clock::time_point received) {
  const protocol::Method method = call.method();
  // The one access check of the hot path: a per-connection flag. server.auth is answered
  // here, in line order, so a request pipelined after it sees its outcome.
  if (!authenticated_ && !protocol::allowed_before_auth(method)) {
    finish_request(call, method, "", received,
                   Service::refuse(call, Service::unauthenticated_error(method)));
    return;
  }
  if (Service::answered_inline(method)) {
    RequestContext context;
    Answer answer = env_.service.answer(call, context);
    const bool auth = method == protocol::Method::ServerAuth;
    if (auth) note_auth(answer);
    finish_request(call, method, context.mesh, received, std::move(answer));
    if (auth && locked_out_) maybe_finish();  // closes once the refusal is written
    return;
  }
  if (env_.state.draining.load()) {
    finish_request(call, method, "", received, Service::refuse(call, shutting_down_error()));
    return;
  }
  submit_to_pool(std::move(call), method, received);
}

void Connection::submit_to_pool(protocol::Call call, protocol::Method method,
                                Clock::time_point received) {
  auto cancelled = std::make_shared<std::atomic<bool>>(false);
  const std::uint64_t key = begin_pool_work(cancelled);
  const auto deadline =
      received +
      std::chrono::milliseconds(env_.config.limits.effective_timeout_ms(call.timeout_ms));
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
      answer = self->env_.service.answer(*shared_call, context);
    }
    self->deliver(Finished{key, shared_call, method, std::move(context.mesh), received,
                           std::move(answer), nullptr});
  };
  const bool queued =
      env_.pool.submit_request(std::move(task), protocol::is_admin_method(method));
  if (!queued) {
    end_pool_work(key);
    finish_request(*shared_call, method, "", received,
                   Service::refuse(*shared_call, overloaded_error()));
  }
}

/// A batch array: answered inline when every call in it is an inline method (or the connection
/// is not authenticated: its calls are then refused), else one compute-pool task running its
/// calls in order under the longest of their deadlines. All of it counts as one in flight.
void Connection::dispatch_batch(protocol::BatchCall batch, Clock::time_point received) {
  bool all_inline = true;
  bool has_admin_call = false;
  for (const auto& element : batch.elements) {
    if (const auto* call = std::get_if<protocol::Call>(&element)) {
      all_inline = all_inline && Service::answered_inline(call->method());
      has_admin_call = has_admin_call || protocol::is_admin_method(call->method());
    }
  }
  if (all_inline || !authenticated_) {
    RequestContext context;
    Answer answer = env_.service.answer_batch(batch, context, authenticated_, Transport::Tcp);
    finish_batch(batch, context.mesh, received, std::move(answer));
    return;
  }
  if (env_.state.draining.load()) {
    finish_batch(batch, "", received,
                 env_.service.refuse_batch(batch, shutting_down_error(), authenticated_,
                                           Transport::Tcp));
    return;
  }
  // Admin calls are never refused Overloaded, alone or in an array.
  submit_batch_to_pool(std::move(batch), received, has_admin_call);
}

void Connection::submit_batch_to_pool(protocol::BatchCall batch, Clock::time_point received,
                                      bool never_refused) {
  auto cancelled = std::make_shared<std::atomic<bool>>(false);
  const std::uint64_t key = begin_pool_work(cancelled);
  std::int64_t longest_timeout_ms = 0;
  for (const auto& element : batch.elements) {
    if (const auto* call = std::get_if<protocol::Call>(&element)) {
      longest_timeout_ms = std::max(longest_timeout_ms,
                                    env_.config.limits.effective_timeout_ms(call->timeout_ms));
    }
  }
  const auto deadline = received + std::chrono::milliseconds(longest_timeout_ms);
  auto shared_batch = std::make_shared<protocol::BatchCall>(std::move(batch));
  // Once cancelled (the client is gone, or the shutdown deadline passed), each remaining call
  // fails fast with DeadlineExceeded or ShuttingDown, and nothing is sent.
  auto task = [self = shared_from_this(), key, cancelled, shared_batch, deadline, received] {
    RequestContext context;
    context.interrupt.deadline = deadline;
    context.interrupt.cancelled = cancelled.get();
    Answer answer =
        self->env_.service.answer_batch(*shared_batch, context, true, Transport::Tcp);
    self->deliver(Finished{key, nullptr, protocol::Method::Batch, std::move(context.mesh),
                           received, std::move(answer), shared_batch});
  };
  const bool queued = env_.pool.submit_request(std::move(task), never_refused);
  if (!queued) {
    end_pool_work(key);
    finish_batch(*shared_batch, "", received,
                 env_.service.refuse_batch(*shared_batch, overloaded_error(), authenticated_,
                                            Transport::Tcp));
  }
}

std::uint64_t Connection::begin_pool_work(std::shared_ptr<std::atomic<bool>> cancelled) {
  const std::uint64_t key = next_key_++;
  active_.emplace(key, Active{std::move(cancelled)});
  ++inflight_;
  env_.metrics.in_flight.fetch_add(1, std::memory_order_relaxed);
  return key;
}

void Connection::end_pool_work(std::uint64_t key) {
  active_.erase(key);
  --inflight_;
  env_.metrics.in_flight.fetch_sub(1, std::memory_order_relaxed);
}

ProtocolError Connection::overloaded_error() const {
  const std::size_t waiting = env_.pool.waiting();
  ProtocolError error(ErrorReason::Overloaded,
                      "compute queue full (" + std::to_string(waiting) + " waiting)");
  error.set_retry_after_ms(env_.pool.retry_after_ms());
  return error;
}

/// Keeps the outcome of a server.auth: right token, authenticated; wrong token (or any
/// failure), not, and after Service::kMaxAuthFailures failures the connection is closed.
void Connection::note_auth(const Answer& answer) {
  if (!env_.service.query_token_required()) return;  // open: nothing to lose or count
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

// ---- completing ----

/// From a compute thread: hands a finished query to the strand. Only the first of the queries
/// finishing before the strand runs posts to it, so one wake-up of the I/O thread (a syscall and
/// a context switch) serves them all and their replies leave in one write.
void Connection::deliver(Finished done) {
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

void Connection::complete() {
  {
    std::lock_guard lock(finished_mutex_);
    completing_.swap(finished_);
    finished_posted_ = false;
  }
  batching_writes_ = true;
  for (Finished& done : completing_) {
    end_pool_work(done.key);
    if (done.batch) {
      finish_batch(*done.batch, done.mesh, done.received, std::move(done.answer));
    } else {
      finish_request(*done.call, done.method, done.mesh, done.received, std::move(done.answer));
    }
  }
  completing_.clear();
  batching_writes_ = false;
  if (!closed_ && !writing_ && !queue_.empty()) do_write();
  if (!closed_) process_frames();
}

void Connection::finish_request(const protocol::Call& call, protocol::Method method,
                                const std::string& mesh, Clock::time_point received,
                                Answer answer) {
  const double seconds = std::chrono::duration<double>(Clock::now() - received).count();
  env_.metrics.record_request(Transport::Tcp, method, answer.error, seconds);
  log_request(call.id ? &*call.id : nullptr, call.method_name, mesh, received, answer.error,
              answer.error ? std::string_view(answer.line) : std::string_view());
  if (!answer.line.empty() && !closed_) enqueue_write(std::move(answer.line));
}

/// The metrics have each element already (Service::answer_batch); the log has one line for the
/// array.
void Connection::finish_batch(const protocol::BatchCall& batch, const std::string& mesh,
                              Clock::time_point received, Answer answer) {
  log_request(nullptr, "batch array of " + std::to_string(batch.elements.size()), mesh, received,
              answer.error, answer.error ? std::string_view(answer.line) : std::string_view());
  if (!answer.line.empty() && !closed_) enqueue_write(std::move(answer.line));
}

/// One log line per request: at debug, or at error with the reply when it failed Internal
/// (a bug). Never the params: they may carry tokens.
void Connection::log_request(const protocol::RequestId* id, std::string_view method,
                             std::string_view mesh, Clock::time_point received,
                             std::optional<ErrorReason> error, std::string_view reply) {
  const bool internal = error && *error == ErrorReason::Internal;
  const auto level = internal ? spdlog::level::err : spdlog::level::debug;
  if (!spdlog::should_log(level)) return;
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - received).count();
  nlohmann::ordered_json fields;
  fields["peer"] = peer_;
  fields["id"] = logged_id(id);
  fields["method"] = clip(method, kMaxLoggedMethodBytes);
  fields["mesh"] = nullptr;  // unknown: the request failed before naming one
  if (!mesh.empty()) fields["mesh"] = std::string(mesh);
  fields["duration_ms"] = std::round(ms * 1000) / 1000;
  fields["outcome"] = error ? std::string(protocol::reason_name(*error)) : "ok";
  if (internal) fields["reply"] = clip(reply, kMaxLoggedReplyBytes);
  log_fields(level, "request", fields);
}

// ---- writing and closing ----

void Connection::enqueue_write(std::string line) {
  if (closed_) return;
  if (queued_bytes_ > 0 && queued_bytes_ + line.size() > limits().max_write_buffer_bytes) {
    env_.metrics.slow_reader_disconnects.fetch_add(1, std::memory_order_relaxed);
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

void Connection::do_write() {
  writing_ = true;
  in_write_.clear();
  buffers_.clear();
  std::size_t bytes = 0;
  while (!queue_.empty() && in_write_.size() < kMaxLinesPerWrite && bytes < kMaxBytesPerWrite) {
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

void Connection::on_write(boost::system::error_code ec, std::size_t n, std::size_t bytes) {
  writing_ = false;
  in_write_.clear();
  env_.metrics.bytes_written.fetch_add(n, std::memory_order_relaxed);
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
void Connection::maybe_finish() {
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

void Connection::arm_timer() {
  const auto timeout = std::chrono::milliseconds(limits().read_timeout_ms);
  timer_.expires_at(last_activity_ + timeout);
  timer_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
    if (ec || self->closed_) return;
    const auto timeout_at =
        self->last_activity_ + std::chrono::milliseconds(self->limits().read_timeout_ms);
    const bool idle = self->inflight_ == 0 && !self->writing_ && self->queue_.empty();
    if (idle && Clock::now() >= timeout_at) {
      self->env_.metrics.read_timeouts.fetch_add(1, std::memory_order_relaxed);
      self->close("read timeout");
      return;
    }
    if (!idle) self->last_activity_ = Clock::now();
    self->arm_timer();
  });
}

void Connection::close(const char* why) {
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
  env_.manager.remove(this);
}

}  // namespace geoprox::server
