#include "server/server.h"

#include <spdlog/spdlog.h>

#include <utility>  // before Boost.Asio 1.74: its awaitable.hpp uses std::exchange

#include <boost/asio.hpp>
#include <chrono>
#include <csignal>
#include <fstream>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "protocol/json_rpc.h"
#include "server/acceptor.h"
#include "server/admin_http.h"
#include "server/compute_pool.h"
#include "server/connection.h"
#include "server/connection_manager.h"
#include "server/http_handler.h"
#include "server/http_session.h"
#include "server/metrics.h"
#include "server/registry.h"
#include "server/service.h"
#include "server/thread_slice.h"

namespace geoprox::server {

namespace asio = boost::asio;
using asio::ip::tcp;
using protocol::ErrorReason;
using protocol::ProtocolError;
using Clock = std::chrono::steady_clock;

namespace {

/// How often the drain checks whether the requests in flight have finished.
constexpr auto kDrainPollInterval = std::chrono::milliseconds(10);
/// After the drain deadline: time for the forced closes to run before the io_context stops.
constexpr auto kForceCloseGrace = std::chrono::milliseconds(50);
/// What a connection refused for max_connections is told to wait before retrying.
constexpr std::int64_t kRefusedConnectionRetryAfterMs = 1000;

}  // namespace

// The server's state: what it owns, in construction order. Used on the io_context, but for the
// fields the Server methods read (ports, threads) and the thread-safe parts (registry, service,
// pool, connections).
struct Server::Impl {
  Impl(Config c, ServerOptions o);
  ~Impl();

  void start();
  void start_io_threads();
  void run_io();
  void on_query_socket(tcp::socket socket);
  void on_http_socket(tcp::socket socket);
  /// Why a new connection is turned away (draining, max_connections), or nullopt.
  std::optional<ProtocolError> refusal();
  void refuse_connection(tcp::socket socket, const ProtocolError& error);
  void wait_signal();
  void begin_drain();
  void drain_tick();
  void finish();
  void write_port_file();

  Config config;
  ServerOptions options;
  Metrics metrics;
  ServerState state;
  std::unique_ptr<Registry> registry;
  std::unique_ptr<Service> service;
  std::unique_ptr<HttpHandler> http_handler;
  asio::io_context io;
  std::unique_ptr<ComputePool> pool;
  ConnectionManager connections{metrics};
  Acceptor acceptor;
  Acceptor admin_acceptor;
  Acceptor http_acceptor;
  asio::steady_timer drain_timer;
  asio::signal_set signals;
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work;
  std::vector<std::thread> io_threads;

  bool started = false;
  bool finished = false;
  bool drain_closing = false;
  Clock::time_point drain_deadline;
  Clock::time_point drain_started;
  std::mutex wait_mutex;
};

Server::Impl::Impl(Config c, ServerOptions o)
    : config(std::move(c)),
      options(std::move(o)),
      io(static_cast<int>(config.io_threads)),
      acceptor(io, metrics, "the query port"),
      admin_acceptor(io, metrics, "the admin port"),
      http_acceptor(io, metrics, "the HTTP port"),
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
  http_handler = std::make_unique<HttpHandler>(config, *service);
}

Server::Impl::~Impl() {
  if (pool) pool->stop();
}

void Server::Impl::start() {
  acceptor.listen(config.bind, config.port);
  if (config.admin_port != 0) admin_acceptor.listen(config.admin_bind, config.admin_port);
  if (config.http_port != 0) http_acceptor.listen(config.http_bind, config.http_port);
  work.emplace(io.get_executor());
  if (options.handle_signals) {
    signals.add(SIGTERM);
    signals.add(SIGINT);
    signals.add(SIGHUP);
    wait_signal();
  }
  registry->add_configured(config.meshes);
  acceptor.start([this](tcp::socket socket) { on_query_socket(std::move(socket)); });
  if (admin_acceptor.is_open()) {
    admin_acceptor.start([this](tcp::socket socket) {
      std::make_shared<AdminSession>(*service, std::move(socket))->start();
    });
  }
  if (http_acceptor.is_open()) {
    http_acceptor.start([this](tcp::socket socket) { on_http_socket(std::move(socket)); });
  }
  start_io_threads();
  started = true;
  const auto address = [](const std::string& bind, std::uint16_t port) {
    return port ? bind + ":" + std::to_string(port) : std::string("off");
  };
  spdlog::info("geoproxd listening on {}:{} (HTTP {}, admin {}), {} compute threads, {} I/O "
               "threads, {} meshes configured",
               config.bind, acceptor.port(), address(config.http_bind, http_acceptor.port()),
               address(config.admin_bind, admin_acceptor.port()),
               pool->threads(), config.io_threads, config.meshes.size());
  if (http_acceptor.is_open()) {
    if (http_handler->static_dir().empty()) {
      spdlog::info("no web viewer: no http_static_dir and no built clients/web/dist found");
    } else {
      spdlog::info("web viewer at http://{}:{}/ (files from {})", config.http_bind,
                   http_acceptor.port(), http_handler->static_dir().string());
    }
  }
  if (!options.port_file.empty()) write_port_file();
}

void Server::Impl::start_io_threads() {
  for (unsigned i = 0; i < config.io_threads; ++i) {
    io_threads.emplace_back([this, i] {
      name_this_thread("gp-io-" + std::to_string(i));
      if (config.io_slice_us > 0) {
        const auto refused = request_thread_slice(std::chrono::microseconds(config.io_slice_us));
        if (refused && i == 0) {
          spdlog::info("io_slice_us: {}; the I/O threads keep the kernel's time slice", *refused);
        }
      }
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
}

void Server::Impl::run_io() {
  // Interrupt coalescing, as network cards do it: while requests wait for the compute threads,
  // a reply written or a request read a little later costs no throughput, whereas every wake-up
  // of this thread (an epoll wait, a read or write, two context switches) takes a core from a
  // query. Pausing between rounds of events under load lets replies and requests gather.
  // Without a backlog nothing waits.
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

std::optional<ProtocolError> Server::Impl::refusal() {
  if (state.draining.load()) {
    return ProtocolError(ErrorReason::ShuttingDown, "the server is shutting down");
  }
  const std::size_t max_connections = config.server_limits.max_connections;
  if (static_cast<std::size_t>(metrics.connections.load()) >= max_connections) {
    metrics.connections_refused.fetch_add(1, std::memory_order_relaxed);
    return ProtocolError(ErrorReason::Overloaded, "too many connections (max_connections " +
                                                      std::to_string(max_connections) + ")")
        .set_retry_after_ms(kRefusedConnectionRetryAfterMs);
  }
  return std::nullopt;
}

void Server::Impl::on_query_socket(tcp::socket socket) {
  if (auto error = refusal()) {
    refuse_connection(std::move(socket), *error);
    return;
  }
  boost::system::error_code ignored;
  socket.set_option(tcp::no_delay(true), ignored);
  const ConnectionEnv env{config, *service, metrics, *pool, state, connections};
  auto connection = std::make_shared<Connection>(env, std::move(socket));
  connections.add(connection);
  connection->start();
}

void Server::Impl::on_http_socket(tcp::socket socket) {
  if (auto error = refusal()) {
    // Answered before reading the request: a 503 or 429 that says why, then closed.
    auto s = std::make_shared<tcp::socket>(std::move(socket));
    HttpRequest request;
    request.keep_alive(false);
    auto response = std::make_shared<HttpResponse>(
        http_handler->refuse(request, protocol::Method::ServerHealth, *error).response);
    spdlog::debug("HTTP connection refused: {}", error->what());
    boost::beast::http::async_write(
        *s, *response, [s, response](boost::system::error_code, std::size_t) {
          boost::system::error_code ignored;
          s->shutdown(tcp::socket::shutdown_both, ignored);
          s->close(ignored);
        });
    return;
  }
  boost::system::error_code ignored;
  socket.set_option(tcp::no_delay(true), ignored);
  const HttpSessionEnv env{config, *http_handler, metrics, *pool, state, connections};
  auto session = std::make_shared<HttpSession>(env, std::move(socket));
  connections.add(session);
  session->start();
}

/// Writes one error line (ShuttingDown, or Overloaded with a retry delay) and closes.
void Server::Impl::refuse_connection(tcp::socket socket, const ProtocolError& error) {
  auto s = std::make_shared<tcp::socket>(std::move(socket));
  auto line =
      std::make_shared<std::string>(protocol::serialize_error(protocol::RequestId(), error));
  spdlog::debug("connection refused: {}", error.what());
  asio::async_write(*s, asio::buffer(*line), [s, line](boost::system::error_code, std::size_t) {
    boost::system::error_code ignored;
    s->shutdown(tcp::socket::shutdown_both, ignored);
    s->close(ignored);
  });
}

void Server::Impl::write_port_file() {
  const auto tmp = options.port_file.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << "{\"port\": " << acceptor.port() << ", \"admin_port\": " << admin_acceptor.port()
        << ", \"http_port\": " << http_acceptor.port() << "}\n";
  }
  std::error_code ec;
  std::filesystem::rename(tmp, options.port_file, ec);
  if (ec) {
    spdlog::error("cannot write the port file {}: {}", options.port_file.string(), ec.message());
  }
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

void Server::Impl::begin_drain() {
  if (state.draining.exchange(true)) return;
  drain_started = Clock::now();
  drain_deadline = drain_started + std::chrono::milliseconds(config.shutdown_timeout_ms);
  acceptor.close();
  http_acceptor.close();
  spdlog::info("draining: not accepting, {} requests in flight, {} connections",
               metrics.in_flight.load(), metrics.connections.load());
  drain_tick();
}

void Server::Impl::drain_tick() {
  const auto now = Clock::now();
  if (!drain_closing && metrics.in_flight.load() == 0) {
    drain_closing = true;
    connections.drain_close_all();
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
    connections.force_close_all();
    drain_timer.expires_after(kForceCloseGrace);
    drain_timer.async_wait([this](boost::system::error_code) { finish(); });
    return;
  }
  drain_timer.expires_after(kDrainPollInterval);
  drain_timer.async_wait([this](boost::system::error_code ec) {
    if (!ec) drain_tick();
  });
}

void Server::Impl::finish() {
  if (finished) return;
  finished = true;
  boost::system::error_code ec;
  admin_acceptor.close();
  signals.cancel(ec);
  work.reset();
  io.stop();
}

// ---- Server ----

Server::Server(Config config, ServerOptions options)
    : impl_(std::make_unique<Impl>(std::move(config), std::move(options))) {}

Server::~Server() {
  if (impl_->started) {
    shutdown();
    wait();
  }
}

void Server::start() { impl_->start(); }
std::uint16_t Server::port() const { return impl_->acceptor.port(); }
std::uint16_t Server::admin_port() const { return impl_->admin_acceptor.port(); }
std::uint16_t Server::http_port() const { return impl_->http_acceptor.port(); }
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
