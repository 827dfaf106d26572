// One client of the HTTP port (private to server/; docs/http.md): reads requests with
// Boost.Beast, one at a time (keep-alive and pipelined requests are answered in order), hands
// them to the HttpHandler, runs their work on the compute pool and writes the responses.
//
// Bounds: headers up to http_max_header_bytes (431), bodies up to limits.max_line_bytes (413),
// a request must arrive within http_request_timeout_ms of its first byte (408), an idle
// keep-alive connection is closed after read_timeout_ms, and a response that the client does
// not read within read_timeout_ms closes the connection.
//
// Threads: every member is used on the connection's strand; compute threads only post back.
#pragma once

#include <utility>  // before Boost.Asio 1.74: its awaitable.hpp uses std::exchange

#include <atomic>
#include <boost/asio.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/http.hpp>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "server/compute_pool.h"
#include "server/config.h"
#include "server/connection_manager.h"
#include "server/http_handler.h"
#include "server/metrics.h"
#include "server/service.h"

namespace geoprox::server {

/// What an HTTP session uses of its server; all of it outlives every session.
struct HttpSessionEnv {
  const Config& config;
  const HttpHandler& handler;
  Metrics& metrics;
  ComputePool& pool;
  const ServerState& state;
  ConnectionManager& manager;
};

class HttpSession : public Session, public std::enable_shared_from_this<HttpSession> {
 public:
  using Clock = std::chrono::steady_clock;

  HttpSession(const HttpSessionEnv& env, boost::asio::ip::tcp::socket socket);

  /// Starts reading (on the session's strand).
  void start();
  void drain_close() override;
  void force_close() override;

 private:
  enum class Phase : std::uint8_t { Idle, Reading, Working, Writing };

  void wait_for_request();
  void read_header();
  void on_header(boost::system::error_code ec);
  void on_body(boost::system::error_code ec);
  void on_read_error(boost::system::error_code ec);
  void dispatch();
  void run(HttpWork work);
  void send(HttpReply reply);
  void on_write(boost::system::error_code ec, std::size_t bytes, bool keep_alive);
  void arm_timer(std::chrono::milliseconds timeout);
  void close(const char* why);

  HttpSessionEnv env_;
  boost::asio::ip::tcp::socket socket_;
  boost::asio::steady_timer timer_;
  boost::beast::flat_buffer buffer_;
  std::optional<boost::beast::http::request_parser<boost::beast::http::string_body>> parser_;
  std::shared_ptr<HttpResponse> response_;  ///< the one being written
  std::string peer_;
  Phase phase_ = Phase::Idle;
  Clock::time_point received_;
  bool draining_ = false;
  bool timed_out_ = false;
  std::uint64_t timer_generation_ = 0;  ///< the phase the pending timer wait belongs to
  bool closed_ = false;
  std::shared_ptr<std::atomic<bool>> cancelled_;  ///< of the request in the compute pool
};

}  // namespace geoprox::server
