#include "server/admin_http.h"

#include <chrono>
#include <istream>

namespace geoprox::server {

namespace asio = boost::asio;
using asio::ip::tcp;

namespace {

/// A request whose headers do not end within this many bytes is refused (431).
constexpr std::size_t kMaxRequestBytes = 16 * 1024;
/// The whole exchange must end within this time; the socket is closed after it.
constexpr auto kSessionTimeout = std::chrono::seconds(5);

}  // namespace

AdminSession::AdminSession(const Service& service, tcp::socket socket)
    : service_(service),
      socket_(std::move(socket)),
      timer_(socket_.get_executor()),
      buffer_(kMaxRequestBytes) {}

void AdminSession::start() {
  timer_.expires_after(kSessionTimeout);
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

void AdminSession::on_request(boost::system::error_code ec) {
  if (ec) {
    if (ec == asio::error::not_found) {
      respond(431, "Request Header Fields Too Large", "text/plain", "request too large\n", true);
    } else {
      close();
    }
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
  route(target, !head);
}

void AdminSession::route(const std::string& target, bool with_body) {
  if (target == "/metrics") {
    respond(200, "OK", "text/plain; version=0.0.4; charset=utf-8", service_.metrics_text(),
            with_body);
  } else if (target == "/healthz") {
    respond(200, "OK", "text/plain", "ok\n", with_body);
  } else if (target == "/readyz") {
    const protocol::HealthResult health = service_.health();
    if (health.status == protocol::HealthStatus::Ok) {
      respond(200, "OK", "text/plain", "ready\n", with_body);
    } else {
      std::string body = "not ready: ";
      body += protocol::health_status_name(health.status);
      body += "\n";
      respond(503, "Service Unavailable", "text/plain", body, with_body);
    }
  } else {
    respond(404, "Not Found", "text/plain", "unknown path (try /metrics, /healthz, /readyz)\n",
            with_body);
  }
}

void AdminSession::respond(int code, const char* reason, const char* type,
                           const std::string& body, bool with_body) {
  response_ = "HTTP/1.1 " + std::to_string(code) + " " + reason;
  response_ += "\r\nContent-Type: ";
  response_ += type;
  response_ += "\r\nContent-Length: " + std::to_string(body.size());
  response_ += "\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n";
  if (with_body) response_ += body;
  asio::async_write(socket_, asio::buffer(response_),
                    [self = shared_from_this()](boost::system::error_code, std::size_t) {
                      self->close();
                    });
}

void AdminSession::close() {
  boost::system::error_code ec;
  timer_.cancel();
  socket_.shutdown(tcp::socket::shutdown_both, ec);
  socket_.close(ec);
}

}  // namespace geoprox::server
