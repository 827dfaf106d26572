// What geoproxd answers over HTTP (private to server/; docs/http.md): one parsed request in,
// a response out, or the work that makes the response on a compute thread. No sockets: the
// session (server/http_session.h) reads and writes; the fuzz target calls this directly.
//
// The routes map onto the service's methods (server/service.h): POST /v1/rpc takes JSON-RPC
// requests and batch arrays as the TCP port does, and the resource paths (/v1/meshes/...) take
// the same params as the methods, from a JSON body or a query string, and answer their result
// object, or its array in binary. Errors carry the JSON-RPC error object and the HTTP status of
// their reason (protocol/http_api.h). Any other path outside /v1/ is a file of the web viewer
// (server/static_files.h), served without the query token.
//
// Threads: const, and safe to call from any thread; HttpWork::run runs on a compute thread.
#pragma once

#include <boost/beast/http.hpp>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "protocol/errors.h"
#include "protocol/http_api.h"
#include "protocol/request.h"
#include "protocol/messages.h"
#include "server/config.h"
#include "server/service.h"
#include "server/static_files.h"

namespace geoprox::server {

using HttpRequest = boost::beast::http::request<boost::beast::http::string_body>;
using HttpResponse = boost::beast::http::response<boost::beast::http::string_body>;

/// Beast's string_view (Boost's in Boost 1.74) as the standard one.
inline std::string_view as_std(boost::beast::string_view text) {
  return {text.data(), text.size()};
}

/// A response, with what the metrics and the log record of it.
struct HttpReply {
  HttpResponse response;
  std::optional<protocol::Method> method;      ///< the method it ran, once known
  std::optional<protocol::ErrorReason> error;  ///< nullopt: a success
  std::string mesh;                            ///< the mesh it ran on, once known
  bool close = false;                          ///< close the connection after it
  bool recorded = false;  ///< in the metrics already (a batch array's elements, each on its own)
  /// Never gzipped: binary float arrays, which gzip shrinks little at a cost above the time the
  /// bytes saved take on a fast link (docs/http.md).
  bool no_gzip = false;
};

/// Work for a compute thread: runs the request under `context` and builds its reply.
struct HttpWork {
  /// What it runs (an admin method: queued whatever the backlog).
  protocol::Method method = protocol::Method::ServerHealth;
  std::optional<std::int64_t> timeout_ms;  ///< as asked; Limits::effective_timeout_ms applies
  std::function<HttpReply(RequestContext& context)> run;
  /// The reply when it cannot run (Overloaded, ShuttingDown).
  std::function<HttpReply(const protocol::ProtocolError& error)> refuse;
};

class HttpHandler {
 public:
  /// Throws ConfigError when config.http_static_dir names no directory.
  HttpHandler(const Config& config, const Service& service);

  /// The web viewer's directory served at "/" (empty: none).
  const std::filesystem::path& static_dir() const { return static_files_.root(); }

  /// The reply to `request`, or the work that makes it (never throws).
  std::variant<HttpReply, HttpWork> handle(const HttpRequest& request) const noexcept;
  /// The reply to a request whose work could not run (Overloaded, ShuttingDown).
  HttpReply refuse(const HttpRequest& request, protocol::Method method,
                   const protocol::ProtocolError& error) const noexcept;
  /// The reply to a request that could not be read (malformed, too large, too slow): `status`
  /// with a text body, closing the connection.
  HttpReply transport_error(unsigned version, unsigned status, const std::string& message) const;

 private:
  struct Shape;
  Shape shape_of(const HttpRequest& request) const;
  std::variant<HttpReply, HttpWork> route(const HttpRequest& request, const Shape& shape) const;
  using QueryParameters = std::vector<std::pair<std::string, std::string>>;
  HttpReply static_reply(const Shape& shape, std::string_view path) const;
  HttpReply mesh_reply(const Shape& shape, const protocol::HttpRoute& route) const;
  HttpWork geometry_work(const Shape& shape, const std::string& mesh_id) const;
  HttpWork query_work(const HttpRequest& request, const Shape& shape,
                      const protocol::HttpRoute& route, const QueryParameters& parameters) const;
  std::variant<HttpReply, HttpWork> rpc(const HttpRequest& request, const Shape& shape) const;
  HttpReply query_reply(const Shape& shape, const protocol::Call& call,
                        RequestContext& context) const;
  HttpReply rpc_reply(const Shape& shape, std::optional<protocol::Method> method,
                      std::string line, std::optional<protocol::ErrorReason> error,
                      std::string mesh) const;
  void set_binary(HttpReply& reply, const Shape& shape, protocol::BinaryArray array) const;
  HttpReply error_reply(const Shape& shape, const protocol::ProtocolError& error,
                        std::optional<protocol::Method> method) const;
  /// Headers every response gets (Server, CORS, Content-Length), gzip, HEAD's empty body.
  HttpReply finish(const Shape& shape, HttpReply reply) const;

  const Config& config_;
  const Service& service_;
  StaticFiles static_files_;
};

}  // namespace geoprox::server
