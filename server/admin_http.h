// The admin HTTP endpoint (private to server/): GET or HEAD /metrics (Prometheus text),
// /healthz (the process is up) and /readyz (200 once a mesh is ready, 503 while starting or
// draining). One request per connection, answered with Connection: close, within a 5 s
// timeout. The request line is read by hand: only the method and the path matter.
#pragma once

#include <utility>  // before Boost.Asio 1.74: its awaitable.hpp uses std::exchange

#include <boost/asio.hpp>
#include <memory>
#include <string>

#include "server/service.h"

namespace geoprox::server {

class AdminSession : public std::enable_shared_from_this<AdminSession> {
 public:
  AdminSession(const Service& service, boost::asio::ip::tcp::socket socket);

  /// Reads the request, answers it and closes (keeps itself alive meanwhile).
  void start();

 private:
  void on_request(boost::system::error_code ec);
  void route(const std::string& target, bool with_body);
  void respond(int code, const char* reason, const char* type, const std::string& body,
               bool with_body);
  void close();

  const Service& service_;
  boost::asio::ip::tcp::socket socket_;
  boost::asio::steady_timer timer_;
  boost::asio::streambuf buffer_;
  std::string response_;
};

}  // namespace geoprox::server
