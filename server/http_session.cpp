#include "server/http_session.h"

#include <spdlog/spdlog.h>

#include <boost/beast/http/error.hpp>
#include <cmath>
#include <nlohmann/json.hpp>

#include "server/logging.h"

namespace geoprox::server {

namespace asio = boost::asio;
namespace http = boost::beast::http;
using asio::ip::tcp;
using protocol::ErrorReason;
using protocol::ProtocolError;

namespace {

/// Bytes asked of the socket per read while waiting for a request.
constexpr std::size_t kReadChunkBytes = 16 * 1024;

bool expects_continue(const HttpRequest& request) {
  const auto it = request.find(http::field::expect);
  if (it == request.end()) return false;
  constexpr std::string_view kContinue = "100-continue";
  const std::string_view value = as_std(it->value());
  return value.size() == kContinue.size() &&
         std::equal(value.begin(), value.end(), kContinue.begin(), [](char a, char b) {
           return (a >= 'A' && a <= 'Z' ? char(a - 'A' + 'a') : a) == b;
         });
}

/// Beast's HTTP parse errors (bad method, bad field, ...), as opposed to socket errors.
bool is_http_parse_error(const boost::system::error_code& ec) {
  return ec.category() == http::make_error_code(http::error::bad_method).category();
}

}  // namespace

HttpSession::HttpSession(const HttpSessionEnv& env, tcp::socket socket)
    : env_(env), socket_(std::move(socket)), timer_(socket_.get_executor()) {
  boost::system::error_code ec;
  const auto endpoint = socket_.remote_endpoint(ec);
  peer_ = ec ? std::string("?")
             : endpoint.address().to_string() + ":" + std::to_string(endpoint.port());
}

void HttpSession::start() {
  asio::dispatch(socket_.get_executor(), [self = shared_from_this()] {
    self->wait_for_request();
  });
}

void HttpSession::drain_close() {
  asio::dispatch(socket_.get_executor(), [self = shared_from_this()] {
    self->draining_ = true;
    // Idle: nothing is owed. Otherwise the response being made or written says
    // Connection: close and the session ends after it.
    if (self->phase_ == Phase::Idle) self->close("server shutdown");
  });
}

void HttpSession::force_close() {
  asio::dispatch(socket_.get_executor(),
                 [self = shared_from_this()] { self->close("server shutdown deadline"); });
}

// ---- reading ----

/// Between requests: waits for the first byte of the next one (read_timeout_ms), unless a
/// pipelined one is already buffered.
void HttpSession::wait_for_request() {
  if (closed_) return;
  phase_ = Phase::Idle;
  if (draining_) {
    close("server shutdown");
    return;
  }
  if (buffer_.size() > 0) {
    read_header();
    return;
  }
  arm_timer(std::chrono::milliseconds(env_.config.server_limits.read_timeout_ms));
  socket_.async_read_some(
      buffer_.prepare(kReadChunkBytes),
      [self = shared_from_this()](boost::system::error_code ec, std::size_t n) {
        self->buffer_.commit(n);
        if (self->closed_) return;
        if (ec) {
          if (self->timed_out_) {
            self->env_.metrics.read_timeouts.fetch_add(1, std::memory_order_relaxed);
            self->close("idle timeout");
          } else {
            self->close(ec == asio::error::eof ? "client closed" : "read error");
          }
          return;
        }
        self->read_header();
      });
}

void HttpSession::read_header() {
  phase_ = Phase::Reading;
  const ServerLimits& limits = env_.config.server_limits;
  parser_.emplace();
  parser_->header_limit(static_cast<std::uint32_t>(limits.http_max_header_bytes));
  parser_->body_limit(env_.config.limits.max_line_bytes);
  arm_timer(std::chrono::milliseconds(limits.http_request_timeout_ms));
  http::async_read_header(socket_, buffer_, *parser_,
                          [self = shared_from_this()](boost::system::error_code ec,
                                                      std::size_t n) {
                            self->env_.metrics.bytes_read.fetch_add(n, std::memory_order_relaxed);
                            self->on_header(ec);
                          });
}

void HttpSession::on_header(boost::system::error_code ec) {
  if (closed_) return;
  if (ec) {
    on_read_error(ec);
    return;
  }
  if (parser_->is_done()) {
    dispatch();
    return;
  }
  auto read_body = [self = shared_from_this()] {
    http::async_read(self->socket_, self->buffer_, *self->parser_,
                     [self](boost::system::error_code read_ec, std::size_t n) {
                       self->env_.metrics.bytes_read.fetch_add(n, std::memory_order_relaxed);
                       self->on_body(read_ec);
                     });
  };
  if (expects_continue(parser_->get())) {
    // The client waits for this before sending its body (curl does for large bodies).
    static const std::string kContinue = "HTTP/1.1 100 Continue\r\n\r\n";
    asio::async_write(socket_, asio::buffer(kContinue),
                      [self = shared_from_this(), read_body](
                          boost::system::error_code write_ec, std::size_t) {
                        if (self->closed_) return;
                        if (write_ec) {
                          self->close("write error");
                          return;
                        }
                        read_body();
                      });
    return;
  }
  read_body();
}

void HttpSession::on_body(boost::system::error_code ec) {
  if (closed_) return;
  if (ec) {
    on_read_error(ec);
    return;
  }
  dispatch();
}

/// A request that could not be read: answered with the status that says why, then closed (the
/// stream cannot be trusted to be at a request boundary any more).
void HttpSession::on_read_error(boost::system::error_code ec) {
  const unsigned version = parser_ && parser_->get().version() == 10 ? 10 : 11;
  if (timed_out_) {
    send(env_.handler.transport_error(
        version, 408,
        "request not complete within " +
            std::to_string(env_.config.server_limits.http_request_timeout_ms) +
            " ms (limits.http_request_timeout_ms)"));
    return;
  }
  if (ec == http::error::end_of_stream || ec == asio::error::eof ||
      ec == asio::error::connection_reset || ec == asio::error::operation_aborted) {
    close("client closed");
    return;
  }
  if (ec == http::error::header_limit) {
    send(env_.handler.transport_error(
        version, 431,
        "request header fields over " +
            std::to_string(env_.config.server_limits.http_max_header_bytes) +
            " bytes (limits.http_max_header_bytes)"));
  } else if (ec == http::error::body_limit) {
    send(env_.handler.transport_error(
        version, 413,
        "request body over " + std::to_string(env_.config.limits.max_line_bytes) +
            " bytes (limits.max_line_bytes)"));
  } else if (is_http_parse_error(ec)) {
    send(env_.handler.transport_error(version, 400, "malformed HTTP request: " + ec.message()));
  } else {
    close("read error");
  }
}

// ---- answering ----

void HttpSession::dispatch() {
  timer_.cancel();
  ++timer_generation_;
  phase_ = Phase::Working;
  received_ = Clock::now();
  const HttpRequest request = parser_->release();
  parser_.reset();
  std::variant<HttpReply, HttpWork> handled = env_.handler.handle(request);
  if (auto* reply = std::get_if<HttpReply>(&handled)) {
    send(std::move(*reply));
    return;
  }
  HttpWork work = std::move(std::get<HttpWork>(handled));
  if (env_.state.draining.load()) {
    send(work.refuse(ProtocolError(ErrorReason::ShuttingDown,
                                   "the server is shutting down; retry on another instance")));
    return;
  }
  run(std::move(work));
}

void HttpSession::run(HttpWork work) {
  cancelled_ = std::make_shared<std::atomic<bool>>(false);
  const auto deadline =
      received_ +
      std::chrono::milliseconds(env_.config.limits.effective_timeout_ms(work.timeout_ms));
  const protocol::Method method = work.method;
  auto refuse = std::move(work.refuse);
  auto task = [self = shared_from_this(), run = std::move(work.run), cancelled = cancelled_,
               deadline] {
    RequestContext context;
    context.interrupt.deadline = deadline;
    context.interrupt.cancelled = cancelled.get();
    HttpReply reply = run(context);
    asio::post(self->socket_.get_executor(),
               [self, reply = std::move(reply)]() mutable {
                 self->env_.metrics.in_flight.fetch_sub(1, std::memory_order_relaxed);
                 self->send(std::move(reply));
               });
  };
  env_.metrics.in_flight.fetch_add(1, std::memory_order_relaxed);
  const bool queued =
      env_.pool.submit_request(std::move(task), protocol::is_admin_method(method));
  if (!queued) {
    env_.metrics.in_flight.fetch_sub(1, std::memory_order_relaxed);
    ProtocolError error(ErrorReason::Overloaded, "compute queue full (" +
                                                     std::to_string(env_.pool.waiting()) +
                                                     " waiting)");
    error.set_retry_after_ms(env_.pool.retry_after_ms());
    send(refuse(error));
  }
}

void HttpSession::send(HttpReply reply) {
  if (closed_) return;
  const double seconds =
      phase_ == Phase::Working ? std::chrono::duration<double>(Clock::now() - received_).count()
                               : 0.0;
  if (!reply.recorded) {
    env_.metrics.record_request(Transport::Http, reply.method, reply.error, seconds);
  }
  if (spdlog::should_log(spdlog::level::debug) ||
      (reply.error && *reply.error == ErrorReason::Internal)) {
    nlohmann::ordered_json fields;
    fields["peer"] = peer_;
    fields["status"] = reply.response.result_int();
    fields["method"] = reply.method ? std::string(protocol::method_name(*reply.method)) : "-";
    fields["mesh"] = nullptr;  // unknown: the request failed before naming one
    if (!reply.mesh.empty()) fields["mesh"] = reply.mesh;
    fields["duration_ms"] = std::round(seconds * 1e6) / 1000;
    fields["outcome"] = reply.error ? std::string(protocol::reason_name(*reply.error)) : "ok";
    const bool internal = reply.error && *reply.error == ErrorReason::Internal;
    log_fields(internal ? spdlog::level::err : spdlog::level::debug, "http request", fields);
  }
  phase_ = Phase::Writing;
  const bool keep_alive = reply.response.keep_alive() && !reply.close && !draining_;
  if (!keep_alive) reply.response.keep_alive(false);
  response_ = std::make_shared<HttpResponse>(std::move(reply.response));
  arm_timer(std::chrono::milliseconds(env_.config.server_limits.read_timeout_ms));
  http::async_write(socket_, *response_,
                    [self = shared_from_this(), keep_alive](boost::system::error_code ec,
                                                            std::size_t bytes) {
                      self->on_write(ec, bytes, keep_alive);
                    });
}

void HttpSession::on_write(boost::system::error_code ec, std::size_t bytes, bool keep_alive) {
  env_.metrics.bytes_written.fetch_add(bytes, std::memory_order_relaxed);
  response_.reset();
  if (closed_) return;
  if (ec) {
    if (timed_out_) env_.metrics.slow_reader_disconnects.fetch_add(1, std::memory_order_relaxed);
    close(timed_out_ ? "response not read in time" : "write error");
    return;
  }
  if (!keep_alive) {
    close("Connection: close");
    return;
  }
  wait_for_request();
}

// ---- timing out and closing ----

void HttpSession::arm_timer(std::chrono::milliseconds timeout) {
  timed_out_ = false;
  const std::uint64_t generation = ++timer_generation_;
  timer_.expires_after(timeout);
  timer_.async_wait([self = shared_from_this(), generation](boost::system::error_code ec) {
    // Cancelled, or a later phase re-armed it: this phase ended in time.
    if (ec || self->closed_ || generation != self->timer_generation_) return;
    self->timed_out_ = true;
    boost::system::error_code ignored;
    self->socket_.cancel(ignored);
  });
}

void HttpSession::close(const char* why) {
  if (closed_) return;
  closed_ = true;
  if (cancelled_) cancelled_->store(true);
  boost::system::error_code ec;
  timer_.cancel();
  socket_.shutdown(tcp::socket::shutdown_both, ec);
  socket_.close(ec);
  spdlog::debug("http connection {}: closed ({})", peer_, why);
  env_.manager.remove(this);
}

}  // namespace geoprox::server
