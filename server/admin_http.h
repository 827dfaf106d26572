// The admin HTTP endpoint (private to server/): GET or HEAD /metrics (Prometheus text),
// /healthz (the process is up) and /readyz (200 once a mesh is ready, 503 while starting or
// draining). One request per connection, read with Boost.Beast and answered with
// Connection: close, within a 5 s timeout.
#pragma once

#include <utility>  // before Boost.Asio 1.74: its awaitable.hpp uses std::exchange

#include <boost/asio.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/http.hpp>
#include <memory>
#include <optional>
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
  void route(std::string_view path, bool with_body);
  void respond(boost::beast::http::status status, const char* type, std::string body,
               bool with_body);
  void close();

  const Service& service_;
  boost::asio::ip::tcp::socket socket_;
  boost::asio::steady_timer timer_;
  boost::beast::flat_buffer buffer_;
  std::optional<boost::beast::http::request_parser<boost::beast::http::empty_body>> parser_;
  boost::beast::http::response<boost::beast::http::string_body> response_;
};

}  // namespace geoprox::server
