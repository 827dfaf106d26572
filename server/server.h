// geoproxd as a library: the server that listens on the query port (and the HTTP and admin ports),
// answers requests through server/service.h, reloads on SIGHUP and shuts down gracefully.
// docs/daemon.md describes the behaviour. Inside, in the layout of Asio's HTTP server example:
// acceptor.h (listening sockets), connection.h (one client of the query port), http_session.h
// and http_handler.h (one client of the HTTP port, and what it answers), connection_manager.h
// (the open connections), admin_http.h (/metrics, /healthz, /readyz).
//
// Threads: `io_threads` threads run the io_context (accept, read, frame, decode, write, and the
// cheap methods: mesh.list, mesh.info, server.*); `compute_threads` threads run every query,
// batch and admin call; one builder thread (server/registry.h) loads and builds graphs. Each
// connection's handlers run on its own strand. start() is called once; the other methods may
// be called from any thread.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>

#include "server/config.h"

namespace geoprox::server {

class Registry;
class Service;
class Metrics;

struct ServerOptions {
  /// Install SIGTERM/SIGINT (graceful shutdown; a second one stops at once) and SIGHUP
  /// (reload) handlers. Only the daemon's main() wants this; in-process tests do not.
  bool handle_signals = false;
  /// If set, {"port": N, "admin_port": M, "http_port": H} is written there (atomically) once
  /// listening.
  std::filesystem::path port_file;
};

class Server {
 public:
  explicit Server(Config config, ServerOptions options = {});
  /// Shuts down (gracefully, within shutdown_timeout_ms) if still running, then waits.
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// Binds the ports (throws std::runtime_error naming the address if it cannot), queues the
  /// configured meshes' loads and starts the threads. Returns at once.
  void start();
  /// The bound ports (useful with port 0). admin_port() and http_port() are 0 when off.
  std::uint16_t port() const;
  std::uint16_t admin_port() const;
  std::uint16_t http_port() const;

  /// Graceful shutdown: stop accepting, report not ready, answer new requests ShuttingDown,
  /// finish those in flight (at most shutdown_timeout_ms, then cancel them), close. Thread-safe,
  /// returns at once; wait() returns once it is done.
  void shutdown();
  /// Reloads every graph file in the background (what SIGHUP does).
  void reload_async();
  /// Blocks until the server has stopped (after shutdown()).
  void wait();

  const Config& config() const;
  Registry& registry();
  Service& service();
  Metrics& metrics();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace geoprox::server
