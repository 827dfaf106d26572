// geoprox::client::Client over blocking POSIX sockets, with poll() for the timeouts.
#include "geoprox_client.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <utility>

#include "protocol/errors.h"
#include "protocol/json_rpc.h"

namespace geoprox::client {
namespace {

using Clock = std::chrono::steady_clock;

std::string errno_text(int error) { return std::strerror(error); }

/// Milliseconds left until `deadline` (>= 0), or -1 (infinite) without a deadline.
int remaining_ms(const std::optional<Clock::time_point>& deadline) {
  if (!deadline) return -1;
  const auto left =
      std::chrono::duration_cast<std::chrono::milliseconds>(*deadline - Clock::now()).count();
  return left < 0 ? 0 : static_cast<int>(left);
}

std::optional<Clock::time_point> deadline_after(int timeout_ms) {
  if (timeout_ms <= 0) return std::nullopt;
  return Clock::now() + std::chrono::milliseconds(timeout_ms);
}

/// Connects one address non-blockingly within the deadline; returns the fd (blocking again) or
/// throws. `timed_out` is set when the deadline passed.
int connect_one(const addrinfo& ai, const std::optional<Clock::time_point>& deadline,
                bool& timed_out, std::string& failure) {
  const int fd = ::socket(ai.ai_family, ai.ai_socktype | SOCK_CLOEXEC, ai.ai_protocol);
  if (fd < 0) {
    failure = errno_text(errno);
    return -1;
  }
  const int flags = ::fcntl(fd, F_GETFL, 0);
  ::fcntl(fd, F_SETFL, flags | O_NONBLOCK);
  int rc = ::connect(fd, ai.ai_addr, ai.ai_addrlen);
  if (rc != 0 && errno == EINPROGRESS) {
    pollfd p{fd, POLLOUT, 0};
    do {
      rc = ::poll(&p, 1, remaining_ms(deadline));
    } while (rc < 0 && errno == EINTR);
    if (rc == 0) {
      timed_out = true;
      ::close(fd);
      return -1;
    }
    int error = 0;
    socklen_t length = sizeof error;
    if (rc < 0) error = errno;
    else if (::getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &length) != 0) error = errno;
    if (error != 0) {
      failure = errno_text(error);
      ::close(fd);
      return -1;
    }
  } else if (rc != 0) {
    failure = errno_text(errno);
    ::close(fd);
    return -1;
  }
  ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  const int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  return fd;
}

nlohmann::json points_json(const std::vector<std::string>& points) {
  nlohmann::json array = nlohmann::json::array();
  for (const std::string& point : points) array.push_back(point);
  return array;
}

}  // namespace

Client::Client(std::string host, std::uint16_t port, Options options)
    : host_(std::move(host)), port_(port), options_(options) {}

Client::~Client() { close(); }

Client::Client(Client&& other) noexcept
    : host_(std::move(other.host_)),
      port_(other.port_),
      options_(other.options_),
      fd_(std::exchange(other.fd_, -1)),
      next_id_(other.next_id_),
      buffer_(std::move(other.buffer_)) {}

Client& Client::operator=(Client&& other) noexcept {
  if (this != &other) {
    close();
    host_ = std::move(other.host_);
    port_ = other.port_;
    options_ = other.options_;
    fd_ = std::exchange(other.fd_, -1);
    next_id_ = other.next_id_;
    buffer_ = std::move(other.buffer_);
  }
  return *this;
}

void Client::close() noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  buffer_.clear();
}

void Client::connect() {
  if (fd_ >= 0) return;
  const std::string where = host_ + ":" + std::to_string(port_);
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* list = nullptr;
  const std::string service = std::to_string(port_);
  const int rc = ::getaddrinfo(host_.c_str(), service.c_str(), &hints, &list);
  if (rc != 0) {
    throw ConnectionError("cannot resolve " + host_ + ": " + ::gai_strerror(rc));
  }
  const auto deadline = deadline_after(options_.connect_timeout_ms);
  bool timed_out = false;
  std::string failure = "no address";
  for (addrinfo* ai = list; ai != nullptr && fd_ < 0 && !timed_out; ai = ai->ai_next) {
    fd_ = connect_one(*ai, deadline, timed_out, failure);
  }
  ::freeaddrinfo(list);
  if (fd_ >= 0) {
    if (options_.token.empty()) return;
    try {
      exchange("server.auth", {{"token", options_.token}});
    } catch (...) {
      close();  // the next call connects and authenticates again
      throw;
    }
    return;
  }
  if (timed_out) {
    throw TimeoutError("cannot connect to " + where + ": no answer within " +
                       std::to_string(options_.connect_timeout_ms) + " ms");
  }
  throw ConnectionError("cannot connect to " + where + ": " + failure);
}

void Client::send_all(const std::string& data) {
  std::size_t sent = 0;
  while (sent < data.size()) {
    const ssize_t n = ::send(fd_, data.data() + sent, data.size() - sent, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int error = errno;
      close();
      throw ConnectionError("connection to " + host_ + ":" + std::to_string(port_) +
                            " lost while sending: " + errno_text(error));
    }
    sent += static_cast<std::size_t>(n);
  }
}

std::string Client::read_line() {
  const auto deadline = deadline_after(options_.read_timeout_ms);
  const std::string where = host_ + ":" + std::to_string(port_);
  std::size_t scanned = 0;
  for (;;) {
    const std::size_t newline = buffer_.find('\n', scanned);
    if (newline != std::string::npos) {
      std::string line = buffer_.substr(0, newline);
      buffer_.erase(0, newline + 1);
      return line;
    }
    scanned = buffer_.size();
    pollfd p{fd_, POLLIN, 0};
    int rc;
    do {
      rc = ::poll(&p, 1, remaining_ms(deadline));
    } while (rc < 0 && errno == EINTR);
    if (rc == 0) {
      close();
      throw TimeoutError("no reply from " + where + " within " +
                         std::to_string(options_.read_timeout_ms) + " ms");
    }
    char chunk[65536];
    const ssize_t n = rc < 0 ? -1 : ::recv(fd_, chunk, sizeof chunk, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = n == 0 ? "closed by the server" : errno_text(errno);
      close();
      throw ConnectionError("connection to " + where + " lost: " + why);
    }
    buffer_.append(chunk, static_cast<std::size_t>(n));
  }
}

nlohmann::json Client::call(std::string_view method, const nlohmann::json& params) {
  connect();
  return exchange(method, params);
}

nlohmann::json Client::exchange(std::string_view method, const nlohmann::json& params) {
  const std::int64_t id = next_id_++;
  const auto request_id = protocol::RequestId::number(id);
  std::string line;
  try {
    line = protocol::serialize_request(request_id, method, params);
  } catch (const std::exception& e) {
    throw ClientError(std::string("cannot serialize the request: ") + e.what());
  }
  send_all(line);
  for (;;) {
    const std::string reply_line = read_line();
    protocol::Reply reply;
    try {
      reply = protocol::parse_reply(reply_line);
    } catch (const std::exception& e) {
      close();
      throw ConnectionError(std::string("bad reply from the server: ") + e.what());
    }
    if (reply.id != request_id && !reply.id.is_null()) continue;  // a stale reply: skip it
    if (reply.error) {
      const protocol::ReplyError& error = *reply.error;
      throw ServerError(error.code, error.reason, error.retryable, error.message,
                        error.retry_after_ms);
    }
    return std::move(*reply.result);
  }
}

nlohmann::json Client::distance(const std::string& mesh, const std::string& source,
                                const std::string& target, bool exact) {
  nlohmann::json params = {{"mesh", mesh}, {"source", source}, {"target", target}};
  if (exact) params["exact"] = true;
  return call("geodesic.distance", params);
}

nlohmann::json Client::path(const std::string& mesh, const std::string& source,
                            const std::string& target) {
  return call("geodesic.path", {{"mesh", mesh}, {"source", source}, {"target", target}});
}

nlohmann::json Client::field(const std::string& mesh, const std::vector<std::string>& sources,
                             std::optional<double> cutoff, const std::string& encoding) {
  nlohmann::json params = {{"mesh", mesh}, {"encoding", encoding}};
  if (sources.size() == 1) params["source"] = sources.front();
  else params["sources"] = points_json(sources);
  if (cutoff) params["cutoff"] = *cutoff;
  return call("geodesic.field", params);
}

nlohmann::json Client::matrix(const std::string& mesh, const std::vector<std::string>& sources,
                              const std::vector<std::string>& targets) {
  return call("geodesic.matrix", {{"mesh", mesh},
                                  {"sources", points_json(sources)},
                                  {"targets", points_json(targets)}});
}

nlohmann::json Client::mesh_list() { return call("mesh.list"); }
nlohmann::json Client::mesh_info(const std::string& mesh) {
  return call("mesh.info", {{"mesh", mesh}});
}
nlohmann::json Client::server_info() { return call("server.info"); }
nlohmann::json Client::health() { return call("server.health"); }

}  // namespace geoprox::client
