#include "server/admin_http.h"

#include "server/http_handler.h"

#include <chrono>

namespace geoprox::server {

namespace asio = boost::asio;
namespace http = boost::beast::http;
using asio::ip::tcp;

namespace {

/// Request line and header fields beyond this many bytes are refused (431).
constexpr std::uint32_t kMaxRequestBytes = 16 * 1024;
/// The whole exchange must end within this time; the socket is closed after it.
constexpr auto kSessionTimeout = std::chrono::seconds(5);

}  // namespace

AdminSession::AdminSession(const Service& service, tcp::socket socket)
    : service_(service), socket_(std::move(socket)), timer_(socket_.get_executor()) {}

void AdminSession::start() {
  timer_.expires_after(kSessionTimeout);
  timer_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
    if (!ec) {
      boost::system::error_code ignored;
      self->socket_.close(ignored);
    }
  });
  parser_.emplace();
  parser_->header_limit(kMaxRequestBytes);
  http::async_read(socket_, buffer_, *parser_,
                   [self = shared_from_this()](boost::system::error_code ec, std::size_t) {
                     self->on_request(ec);
                   });
}

void AdminSession::on_request(boost::system::error_code ec) {
  if (ec == http::error::header_limit) {
    respond(http::status::request_header_fields_too_large, "text/plain", "request too large\n",
            true);
    return;
  }
  if (ec == http::error::unexpected_body) {
    respond(http::status::payload_too_large, "text/plain", "no body expected\n", true);
    return;
  }
  if (ec) {
    if (ec.category() == http::make_error_code(http::error::bad_method).category()) {
      respond(http::status::bad_request, "text/plain", "malformed HTTP request\n", true);
    } else {
      close();
    }
    return;
  }
  const auto& request = parser_->get();
  const bool head = request.method() == http::verb::head;
  if (request.method() != http::verb::get && !head) {
    respond(http::status::method_not_allowed, "text/plain", "only GET and HEAD\n", true);
    return;
  }
  const std::string_view target = as_std(request.target());
  route(target.substr(0, target.find('?')), !head);
}

void AdminSession::route(std::string_view path, bool with_body) {
  if (path == "/metrics") {
    respond(http::status::ok, "text/plain; version=0.0.4; charset=utf-8", service_.metrics_text(),
            with_body);
  } else if (path == "/healthz") {
    respond(http::status::ok, "text/plain", "ok\n", with_body);
  } else if (path == "/readyz") {
    auto [ready, body] = service_.readiness();
    respond(ready ? http::status::ok : http::status::service_unavailable, "text/plain",
            std::move(body), with_body);
  } else {
    respond(http::status::not_found, "text/plain",
            "unknown path (try /metrics, /healthz, /readyz)\n", with_body);
  }
}

void AdminSession::respond(http::status status, const char* type, std::string body,
                           bool with_body) {
  response_.result(status);
  response_.version(11);
  response_.set(http::field::content_type, type);
  response_.set(http::field::cache_control, "no-store");
  response_.keep_alive(false);
  response_.body() = std::move(body);
  response_.prepare_payload();
  if (!with_body) {
    const std::size_t length = response_.body().size();
    response_.body().clear();
    response_.content_length(length);
  }
  http::async_write(socket_, response_,
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
