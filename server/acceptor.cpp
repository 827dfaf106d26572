#include "server/acceptor.h"

#include <spdlog/spdlog.h>

#include <stdexcept>

namespace geoprox::server {

namespace asio = boost::asio;
using asio::ip::tcp;

namespace {

constexpr auto kAcceptRetryDelay = std::chrono::milliseconds(100);
constexpr auto kAcceptWarningInterval = std::chrono::seconds(1);

tcp::endpoint make_endpoint(const std::string& host, std::uint16_t port) {
  boost::system::error_code ec;
  const auto address = asio::ip::make_address(host, ec);
  if (ec) throw std::runtime_error("bind address \"" + host + "\" is not an IP address");
  return {address, port};
}

}  // namespace

Acceptor::Acceptor(asio::io_context& io, Metrics& metrics, std::string what)
    : io_(io), metrics_(metrics), what_(std::move(what)), acceptor_(io), retry_timer_(io) {}

void Acceptor::listen(const std::string& host, std::uint16_t port) {
  const tcp::endpoint endpoint = make_endpoint(host, port);
  boost::system::error_code ec;
  acceptor_.open(endpoint.protocol(), ec);
  if (!ec) acceptor_.set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor_.bind(endpoint, ec);
  if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    std::string message = "cannot listen on " + what_;
    message += ' ';
    message += endpoint.address().to_string();
    message += ':';
    message += std::to_string(endpoint.port());
    message += ": ";
    message += ec.message();
    throw std::runtime_error(message);
  }
  port_ = acceptor_.local_endpoint().port();
}

void Acceptor::start(Handler on_accept) {
  on_accept_ = std::move(on_accept);
  accept();
}

void Acceptor::close() {
  boost::system::error_code ec;
  acceptor_.close(ec);
  retry_timer_.cancel();
}

void Acceptor::accept() {
  acceptor_.async_accept(asio::make_strand(io_), [this](boost::system::error_code ec,
                                                        tcp::socket socket) {
    if (ec) {
      if (acceptor_.is_open() && ec != asio::error::operation_aborted) retry_later(ec);
      return;
    }
    on_accept_(std::move(socket));
    accept();
  });
}

void Acceptor::retry_later(const boost::system::error_code& ec) {
  metrics_.accept_errors.fetch_add(1, std::memory_order_relaxed);
  const auto now = std::chrono::steady_clock::now();
  if (now - last_warning_ > kAcceptWarningInterval) {
    last_warning_ = now;
    spdlog::warn("accept failed on {}: {} (retrying in {} ms)", what_, ec.message(),
                 kAcceptRetryDelay.count());
  }
  retry_timer_.expires_after(kAcceptRetryDelay);
  retry_timer_.async_wait([this](boost::system::error_code timer_ec) {
    if (!timer_ec && acceptor_.is_open()) accept();
  });
}

}  // namespace geoprox::server
