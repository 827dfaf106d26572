// A listening socket and its accept loop (private to server/), for the query port and the
// admin port alike. Each accepted socket gets its own strand. A failed accept (out of file
// descriptors, say) is counted in geoprox_accept_errors_total, warned about at most once a
// second and retried after 100 ms, so the loop never stops while the socket is open.
//
// Threads: listen() before the io_context runs; the loop and close() on the io_context.
#pragma once

#include <utility>  // before Boost.Asio 1.74: its awaitable.hpp uses std::exchange

#include <boost/asio.hpp>
#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

#include "server/metrics.h"

namespace geoprox::server {

class Acceptor {
 public:
  using Handler = std::function<void(boost::asio::ip::tcp::socket)>;

  /// `what` names the port in errors and logs ("the query port").
  Acceptor(boost::asio::io_context& io, Metrics& metrics, std::string what);

  /// Binds `host`:`port` (0: an ephemeral port) and listens. Throws std::runtime_error naming
  /// the port and the address when it cannot.
  void listen(const std::string& host, std::uint16_t port);
  /// Accepts until close(), handing each socket to `on_accept`.
  void start(Handler on_accept);
  /// Stops accepting; connections already accepted are not affected.
  void close();

  bool is_open() const { return acceptor_.is_open(); }
  /// The bound port (0 before listen()).
  std::uint16_t port() const { return port_; }

 private:
  void accept();
  void retry_later(const boost::system::error_code& ec);

  boost::asio::io_context& io_;
  Metrics& metrics_;
  std::string what_;
  boost::asio::ip::tcp::acceptor acceptor_;
  boost::asio::steady_timer retry_timer_;
  Handler on_accept_;
  std::uint16_t port_ = 0;
  std::chrono::steady_clock::time_point last_warning_;
};

}  // namespace geoprox::server
