// geoprox::client — a small synchronous C++ client of the geoproxd daemon (docs/protocol.md).
//
//   geoprox::client::Client client("127.0.0.1", 7878, {.connect_timeout_ms = 2000});
//   nlohmann::json reply = client.distance("spot", "v:0", "f:100:0.2:0.3:0.5");
//   double d = reply.at("distance").get<double>();
//
// One blocking TCP connection, opened on first use and kept; one request at a time (a Client is
// not thread-safe: use one per thread). Points are the command-line strings the protocol accepts
// (v:ID, e:ID:t, f:ID:b0:b1:b2, s:ID, p:x,y,z). Every method returns the reply's `result` object.
// Errors: ServerError (the server answered with an error: code, reason, retryable, message),
// ConnectionError (cannot connect, connection lost, garbled reply) and TimeoutError (connect or
// read timeout; the connection is closed since a late reply would be out of step), all derived
// from ClientError. With Options::token, every new connection first sends server.auth (the
// server's query token); a wrong token is a ServerError with reason "Unauthorized".
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace geoprox::client {

struct Options {
  int connect_timeout_ms = 5000;  ///< <= 0: wait as long as the system does
  int read_timeout_ms = 60000;    ///< per reply; <= 0: no timeout
  /// The server's query token, sent with server.auth as soon as a connection opens (servers
  /// without a query token accept any). Empty: none sent. Not the admin token.
  std::string token;
};

class ClientError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Cannot connect, the connection was lost, or the reply was not a JSON-RPC reply.
class ConnectionError : public ClientError {
 public:
  using ClientError::ClientError;
};

/// No connection or no reply within the configured timeout.
class TimeoutError : public ClientError {
 public:
  using ClientError::ClientError;
};

/// The server answered with an error reply.
class ServerError : public ClientError {
 public:
  ServerError(int code, std::string reason, bool retryable, const std::string& message,
              std::optional<std::int64_t> retry_after_ms = std::nullopt)
      : ClientError(message),
        code_(code),
        reason_(std::move(reason)),
        retryable_(retryable),
        retry_after_ms_(retry_after_ms) {}

  int code() const noexcept { return code_; }
  const std::string& reason() const noexcept { return reason_; }  ///< e.g. "UnknownMesh"
  bool retryable() const noexcept { return retryable_; }
  std::optional<std::int64_t> retry_after_ms() const noexcept { return retry_after_ms_; }

 private:
  int code_;
  std::string reason_;
  bool retryable_;
  std::optional<std::int64_t> retry_after_ms_;
};

class Client {
 public:
  Client(std::string host, std::uint16_t port, Options options = {});
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;
  Client(Client&& other) noexcept;
  Client& operator=(Client&& other) noexcept;

  /// Opens the connection now (otherwise the first call does) and authenticates it when
  /// Options::token is set. Throws ConnectionError/TimeoutError, or ServerError (Unauthorized)
  /// for a wrong token, leaving the client disconnected.
  void connect();
  void close() noexcept;
  bool is_connected() const noexcept { return fd_ >= 0; }

  /// Any method with named params (an object); returns `result` or throws.
  nlohmann::json call(std::string_view method,
                      const nlohmann::json& params = nlohmann::json::object());

  nlohmann::json distance(const std::string& mesh, const std::string& source,
                          const std::string& target, bool exact = false);
  nlohmann::json path(const std::string& mesh, const std::string& source,
                      const std::string& target);
  /// `encoding`: "json" (default) or "f32le-base64".
  nlohmann::json field(const std::string& mesh, const std::vector<std::string>& sources,
                       std::optional<double> cutoff = std::nullopt,
                       const std::string& encoding = "json");
  nlohmann::json matrix(const std::string& mesh, const std::vector<std::string>& sources,
                        const std::vector<std::string>& targets);
  nlohmann::json mesh_list();
  nlohmann::json mesh_info(const std::string& mesh);
  nlohmann::json server_info();
  nlohmann::json health();

 private:
  /// One request and its reply on the open connection.
  nlohmann::json exchange(std::string_view method, const nlohmann::json& params);
  std::string read_line();
  void send_all(const std::string& data);

  std::string host_;
  std::uint16_t port_;
  Options options_;
  int fd_ = -1;
  std::int64_t next_id_ = 1;
  std::string buffer_;  ///< bytes read past the last reply line
};

}  // namespace geoprox::client
