#include "server/http_handler.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string_view>
#include <utility>
#include <vector>

#include "protocol/http_api.h"
#include "protocol/json_rpc.h"
#include "protocol/request.h"
#include "server/gzip.h"

namespace geoprox::server {

namespace http = boost::beast::http;
using nlohmann::json;
using protocol::ErrorReason;
using protocol::HttpFormat;
using protocol::HttpRoute;
using protocol::ProtocolError;

/// Which array of a result a binary response carries. Not in the anonymous namespace:
/// HttpHandler::Shape, a class with external linkage, holds one.
enum class ArrayChoice : std::uint8_t { Distances, NearestSource, Positions, Triangles };

namespace {

/// Bodies at least this large are gzipped for clients that accept it (and at most the largest
/// zlib takes in one call).
constexpr std::size_t kMinGzipBytes = 1024;
constexpr std::size_t kMaxGzipBytes = std::size_t{1} << 30;
/// How long browsers may cache a CORS preflight answer (seconds).
constexpr int kPreflightMaxAgeSeconds = 600;

constexpr const char* kJsonType = "application/json";
constexpr const char* kExposedHeaders =
    "X-Geoprox-Dtype, X-Geoprox-Shape, X-Geoprox-Mesh-Version, Retry-After";

std::string in_quotes(std::string_view text) {
  constexpr std::size_t kMaxQuoted = 80;
  std::string out = "\"";
  out += text.substr(0, kMaxQuoted);
  if (text.size() > kMaxQuoted) out += "...";
  out += '"';
  return out;
}

/// The methods a route answers, as the Allow header lists them.
const char* allowed_methods(HttpRoute::Kind kind) {
  switch (kind) {
    case HttpRoute::Kind::Static:
      return "GET, HEAD";
    case HttpRoute::Kind::Rpc:
      return "POST, OPTIONS";
    case HttpRoute::Kind::Query:
      return "GET, HEAD, POST, OPTIONS";
    default:
      return "GET, HEAD, OPTIONS";
  }
}

bool method_allowed(HttpRoute::Kind kind, http::verb verb) {
  if (kind == HttpRoute::Kind::Static) return verb == http::verb::get || verb == http::verb::head;
  if (verb == http::verb::options) return true;
  switch (kind) {
    case HttpRoute::Kind::Rpc:
      return verb == http::verb::post;
    case HttpRoute::Kind::Query:
      return verb == http::verb::get || verb == http::verb::head || verb == http::verb::post;
    default:
      return verb == http::verb::get || verb == http::verb::head;
  }
}

std::string_view header(const HttpRequest& request, http::field field) {
  const auto it = request.find(field);
  return it == request.end() ? std::string_view() : as_std(it->value());
}

bool iequals_prefix(std::string_view text, std::string_view prefix) {
  if (text.size() < prefix.size()) return false;
  for (std::size_t i = 0; i < prefix.size(); ++i) {
    const auto lower = [](char c) { return c >= 'A' && c <= 'Z' ? char(c - 'A' + 'a') : c; };
    if (lower(text[i]) != lower(prefix[i])) return false;
  }
  return true;
}

/// A POST body must be JSON: a Content-Type, when given, must say so (415 otherwise).
bool is_json_body(const HttpRequest& request) {
  const std::string_view type = header(request, http::field::content_type);
  return type.empty() || iequals_prefix(type, kJsonType);
}

ArrayChoice array_choice(HttpRoute::Kind kind, std::string_view name) {
  if (kind == HttpRoute::Kind::Geometry) {
    if (name.empty() || name == "positions") return ArrayChoice::Positions;
    if (name == "triangles") return ArrayChoice::Triangles;
  } else {
    if (name.empty() || name == "distances") return ArrayChoice::Distances;
    if (name == "nearest_source") return ArrayChoice::NearestSource;
  }
  throw ProtocolError(ErrorReason::InvalidParams,
                      "query parameter \"array\": " + in_quotes(name) + " is not an array of this "
                      "resource (" + std::string(kind == HttpRoute::Kind::Geometry
                                                     ? "positions or triangles"
                                                     : "distances or nearest_source") + ")");
}

}  // namespace

/// What a response depends on besides its content, read from the request once.
struct HttpHandler::Shape {
  unsigned version = 11;
  bool keep_alive = true;
  bool head = false;
  bool gzip = false;
  /// A token was given, or the request is past the query token: Unauthorized is then 403.
  bool token_sent = false;
  std::string cors_origin;  ///< Access-Control-Allow-Origin to send; empty: no CORS headers
  HttpFormat format = HttpFormat::Json;
  protocol::Dtype dtype = protocol::Dtype::Float64;
  ArrayChoice array = ArrayChoice::Distances;
};

HttpHandler::HttpHandler(const Config& config, const Service& service)
    : config_(config),
      service_(service),
      static_files_(static_dir_of(config), config.limits.max_output_bytes) {}

HttpHandler::Shape HttpHandler::shape_of(const HttpRequest& request) const {
  Shape shape;
  shape.version = request.version();
  shape.keep_alive = request.keep_alive();
  shape.head = request.method() == http::verb::head;
  shape.gzip = protocol::accepts_gzip(header(request, http::field::accept_encoding));
  const std::string_view origin = header(request, http::field::origin);
  if (!origin.empty()) {
    for (const std::string& allowed : config_.http_cors_origins) {
      if (allowed == "*" || allowed == origin) {
        shape.cors_origin = allowed == "*" ? "*" : std::string(origin);
        break;
      }
    }
  }
  return shape;
}

std::variant<HttpReply, HttpWork> HttpHandler::handle(const HttpRequest& request) const noexcept {
  Shape shape;
  shape.version = request.version();
  shape.keep_alive = request.keep_alive();
  try {
    shape = shape_of(request);
    return route(request, shape);
  } catch (...) {
    return error_reply(shape, current_error(false), std::nullopt);
  }
}

std::variant<HttpReply, HttpWork> HttpHandler::route(const HttpRequest& request,
                                                    const Shape& shape_in) const {
  Shape shape = shape_in;
  const std::string_view target = as_std(request.target());
  const std::size_t question = target.find('?');
  const std::string_view path = target.substr(0, question);
  const std::string_view query =
      question == std::string_view::npos ? std::string_view() : target.substr(question + 1);
  const HttpRoute route = protocol::route_http_path(path);
  if (route.kind == HttpRoute::Kind::Unknown) {
    throw ProtocolError(ErrorReason::NotFound,
                        "no resource at " + in_quotes(path) +
                            " (docs/http.md lists them: /v1/rpc, /v1/meshes, "
                            "/v1/meshes/{id}/distance, ...)");
  }
  const http::verb verb = request.method();
  if (!method_allowed(route.kind, verb)) {
    HttpReply reply = error_reply(
        shape,
        ProtocolError(ErrorReason::InvalidRequest,
                      "method " + in_quotes(as_std(request.method_string())) +
                          " is not allowed on " + in_quotes(path) + " (allowed: " +
                          std::string(allowed_methods(route.kind)) + ")"),
        std::nullopt);
    reply.response.result(http::status::method_not_allowed);
    reply.response.set(http::field::allow, allowed_methods(route.kind));
    return reply;
  }
  if (verb == http::verb::options) {
    HttpReply reply;
    reply.response.result(http::status::no_content);
    reply.response.set(http::field::allow, allowed_methods(route.kind));
    if (!shape.cors_origin.empty()) {
      reply.response.set(http::field::access_control_allow_methods, allowed_methods(route.kind));
      reply.response.set(http::field::access_control_allow_headers,
                         "Authorization, Content-Type, Accept");
      reply.response.set(http::field::access_control_max_age,
                         std::to_string(kPreflightMaxAgeSeconds));
    }
    reply.method = protocol::Method::ServerHealth;
    return finish(shape, std::move(reply));
  }

  // The viewer's files: no query token (the page asks for it and sends it to the API).
  if (route.kind == HttpRoute::Kind::Static) return static_reply(shape, path);

  if (route.kind == HttpRoute::Kind::Healthz || route.kind == HttpRoute::Kind::Readyz) {
    HttpReply reply;
    reply.method = protocol::Method::ServerHealth;
    reply.response.set(http::field::content_type, "text/plain; charset=utf-8");
    if (route.kind == HttpRoute::Kind::Healthz) {
      reply.response.body() = "ok\n";
    } else {
      auto [ready, body] = service_.readiness();
      if (!ready) reply.response.result(http::status::service_unavailable);
      reply.response.body() = std::move(body);
    }
    return finish(shape, std::move(reply));
  }

  // The query token, for everything but the health checks.
  const std::string_view authorization = header(request, http::field::authorization);
  shape.token_sent = !authorization.empty();
  if (service_.query_token_required()) {
    constexpr std::string_view kBearer = "Bearer ";
    if (authorization.empty()) {
      HttpReply reply = error_reply(
          shape,
          ProtocolError(ErrorReason::Unauthorized,
                        "this server needs its query token: send \"Authorization: Bearer "
                        "TOKEN\""),
          std::nullopt);
      reply.response.set(http::field::www_authenticate, "Bearer");
      return reply;
    }
    if (!iequals_prefix(authorization, kBearer) ||
        !service_.query_token_matches(authorization.substr(kBearer.size()))) {
      return error_reply(
          shape, ProtocolError(ErrorReason::Unauthorized, "Authorization: wrong query token"),
          std::nullopt);
    }
  }
  // Past the query token: any later Unauthorized (an admin token in the params) is 403.
  shape.token_sent = true;

  QueryParameters parameters = protocol::parse_query_string(query);
  // `array` and `dtype` shape binary responses; the rest are the method's params.
  std::string array_name;
  for (auto it = parameters.begin(); it != parameters.end();) {
    if (it->first == "array") {
      array_name = it->second;
    } else if (it->first == "dtype") {
      const auto dtype = protocol::float_dtype_from_name(it->second);
      if (!dtype) {
        throw ProtocolError(ErrorReason::InvalidParams, "query parameter \"dtype\": " +
                                                            in_quotes(it->second) +
                                                            " is not float64 or float32");
      }
      shape.dtype = *dtype;
    } else {
      ++it;
      continue;
    }
    it = parameters.erase(it);
  }
  const bool binary_allowed =
      route.kind == HttpRoute::Kind::Geometry ||
      (route.kind == HttpRoute::Kind::Query &&
       (*route.method == protocol::Method::GeodesicField ||
        *route.method == protocol::Method::GeodesicMatrix));
  const auto format = protocol::negotiate_format(header(request, http::field::accept),
                                                 binary_allowed);
  if (!format) {
    HttpReply reply = error_reply(
        shape,
        ProtocolError(ErrorReason::InvalidRequest,
                      "Accept " + in_quotes(header(request, http::field::accept)) +
                          ": this resource answers application/json" +
                          (binary_allowed ? ", application/octet-stream or application/x-npy"
                                          : std::string())),
        std::nullopt);
    reply.response.result(http::status::not_acceptable);
    return reply;
  }
  shape.format = *format;
  if (binary_allowed) shape.array = array_choice(route.kind, array_name);
  if (verb == http::verb::post && !is_json_body(request)) {
    HttpReply reply = error_reply(
        shape,
        ProtocolError(ErrorReason::InvalidRequest,
                      "Content-Type " + in_quotes(header(request, http::field::content_type)) +
                          ": the body must be application/json (curl --json sends it so)"),
        std::nullopt);
    reply.response.result(http::status::unsupported_media_type);
    return reply;
  }

  switch (route.kind) {
    case HttpRoute::Kind::MeshList:
    case HttpRoute::Kind::MeshInfo:
      return mesh_reply(shape, route);
    case HttpRoute::Kind::Geometry:
      return geometry_work(shape, route.mesh);
    case HttpRoute::Kind::Query:
      return query_work(request, shape, route, parameters);
    case HttpRoute::Kind::Rpc:
      return rpc(request, shape);
    default:
      break;
  }
  throw ProtocolError(ErrorReason::Internal, "unrouted path " + in_quotes(path));
}

HttpReply HttpHandler::static_reply(const Shape& shape, std::string_view path) const {
  StaticFile file = static_files_.read(path);
  HttpReply reply;
  reply.response.set(http::field::content_type, std::string(file.content_type));
  reply.response.set(http::field::cache_control, std::string(file.cache_control));
  reply.response.set("X-Content-Type-Options", "nosniff");
  reply.response.body() = std::move(file.body);
  return finish(shape, std::move(reply));
}

HttpReply HttpHandler::mesh_reply(const Shape& shape, const HttpRoute& route) const {
  protocol::Call call;
  if (route.kind == HttpRoute::Kind::MeshList) {
    call.params = protocol::MeshListParams{};
  } else {
    call.params = protocol::MeshInfoParams{route.mesh};
  }
  RequestContext context;
  Outcome outcome = service_.evaluate(call, context);
  if (outcome.error) return error_reply(shape, *outcome.error, call.method());
  HttpReply reply;
  reply.method = call.method();
  reply.mesh = context.mesh;
  reply.response.set(http::field::content_type, kJsonType);
  reply.response.body() = protocol::dump_one_line(outcome.result);
  return finish(shape, std::move(reply));
}

HttpWork HttpHandler::geometry_work(const Shape& shape, const std::string& mesh_id) const {
  HttpWork work;
  work.method = protocol::Method::MeshInfo;
  work.refuse = [this, shape](const ProtocolError& error) {
    return error_reply(shape, error, protocol::Method::MeshInfo);
  };
  work.run = [this, shape, mesh = mesh_id](RequestContext& context) {
    HttpReply reply;
    reply.method = protocol::Method::MeshInfo;
    try {
      MeshGeometry g = service_.geometry(mesh, context);
      reply.mesh = mesh;
      reply.response.set("X-Geoprox-Mesh-Version", g.mesh_version);
      if (shape.format == HttpFormat::Json) {
        json body = {{"mesh", g.mesh},
                     {"mesh_version", g.mesh_version},
                     {"vertices", g.positions.size() / 3},
                     {"faces", g.triangles.size() / 3},
                     {"positions", std::move(g.positions)},
                     {"triangles", std::move(g.triangles)}};
        reply.response.set(http::field::content_type, kJsonType);
        reply.response.body() = protocol::dump_one_line(body);
      } else if (shape.array == ArrayChoice::Positions) {
        const std::size_t n = g.positions.size() / 3;
        set_binary(reply, shape, protocol::float_array(g.positions, {n, 3}, shape.dtype));
      } else {
        const std::size_t m = g.triangles.size() / 3;
        set_binary(reply, shape, protocol::uint32_array(g.triangles, {m, 3}));
      }
      return finish(shape, std::move(reply));
    } catch (...) {
      return error_reply(shape, current_error(false), protocol::Method::MeshInfo);
    }
  };
  return work;
}

HttpWork HttpHandler::query_work(const HttpRequest& request, const Shape& shape,
                                 const HttpRoute& route, const QueryParameters& parameters) const {
  const protocol::Method method = *route.method;
  json params;
  if (request.method() == http::verb::post) {
    params = protocol::parse_json_text(request.body(), config_.limits.max_nesting_depth);
    if (!params.is_object()) {
      throw ProtocolError(ErrorReason::InvalidParams,
                          "the body must be a JSON object of params, not " +
                              std::string(params.is_array() ? "an array" : "a scalar"));
    }
    if (params.contains("mesh")) {
      throw ProtocolError(ErrorReason::InvalidParams,
                          "params.mesh: the mesh is named by the path, not the body");
    }
    // Query parameters beyond array/dtype would be ignored: refuse them instead.
    if (!parameters.empty()) {
      throw ProtocolError(ErrorReason::InvalidParams,
                          "query parameter " + in_quotes(parameters.front().first) +
                              ": a POST takes its params from the body");
    }
    params["mesh"] = route.mesh;
  } else {
    params = protocol::query_params_object(route.mesh, parameters);
  }
  protocol::Call call;
  call.method_name = std::string(protocol::method_name(method));
  call.params = protocol::parse_params(method, params, config_.limits, &call.timeout_ms);
  HttpWork work;
  work.method = method;
  work.timeout_ms = call.timeout_ms;
  work.refuse = [this, shape, method](const ProtocolError& error) {
    return error_reply(shape, error, method);
  };
  work.run = [this, shape, call = std::move(call)](RequestContext& context) {
    return query_reply(shape, call, context);
  };
  return work;
}

std::variant<HttpReply, HttpWork> HttpHandler::rpc(const HttpRequest& request,
                                                  const Shape& shape) const {
  auto decoded = protocol::decode_message(request.body(), config_.limits);
  if (auto* rejection = std::get_if<protocol::Rejection>(&decoded)) {
    const auto method = protocol::method_from_name(rejection->method_name);
    std::string line = rejection->reply_line().value_or(std::string());
    return rpc_reply(shape, method, std::move(line), rejection->error.reason(), "");
  }
  if (auto* single = std::get_if<protocol::Call>(&decoded)) {
    auto call = std::make_shared<const protocol::Call>(std::move(*single));
    const protocol::Method method = call->method();
    auto run = [this, shape, call, method](RequestContext& context) {
      Answer answer = service_.answer(*call, context);
      return rpc_reply(shape, method, std::move(answer.line), answer.error, context.mesh);
    };
    if (Service::answered_inline(method)) {
      RequestContext context;
      return run(context);
    }
    HttpWork work;
    work.method = method;
    work.timeout_ms = call->timeout_ms;
    work.refuse = [this, shape, call, method](const ProtocolError& error) {
      Answer answer = Service::refuse(*call, error);
      return rpc_reply(shape, method, std::move(answer.line), answer.error, "");
    };
    work.run = std::move(run);
    return work;
  }
  // A batch array: one unit of work whose elements the service answers (and counts) in order.
  auto batch = std::make_shared<const protocol::BatchCall>(
      std::move(std::get<protocol::BatchCall>(decoded)));
  HttpWork work;
  work.method = protocol::Method::Batch;
  bool all_inline = true;
  std::int64_t longest_ms = 0;
  for (const auto& element : batch->elements) {
    const auto* call = std::get_if<protocol::Call>(&element);
    if (call == nullptr) continue;
    all_inline = all_inline && Service::answered_inline(call->method());
    // An admin call makes the array admin work: queued whatever the backlog.
    if (protocol::is_admin_method(call->method())) work.method = call->method();
    longest_ms = std::max(longest_ms, config_.limits.effective_timeout_ms(call->timeout_ms));
  }
  work.timeout_ms = longest_ms;
  const auto batch_reply = [this, shape](Answer answer, std::string mesh) {
    // Each element is in the metrics already (Service::answer_batch); the array is a success
    // unless it was refused as a whole.
    HttpReply reply = rpc_reply(shape, protocol::Method::Batch, std::move(answer.line),
                                std::nullopt, std::move(mesh));
    reply.recorded = true;
    return reply;
  };
  work.run = [this, batch, batch_reply](RequestContext& context) {
    Answer answer = service_.answer_batch(*batch, context, true, Transport::Http);
    return batch_reply(std::move(answer), context.mesh);
  };
  if (all_inline) {
    RequestContext context;
    return work.run(context);
  }
  work.refuse = [this, batch, batch_reply](const ProtocolError& error) {
    HttpReply reply =
        batch_reply(service_.refuse_batch(*batch, error, true, Transport::Http), "");
    reply.response.result(protocol::http_status(error.reason()));
    return reply;
  };
  return work;
}

HttpReply HttpHandler::query_reply(const Shape& shape, const protocol::Call& call,
                                   RequestContext& context) const {
  const protocol::Method method = call.method();
  Outcome outcome = service_.evaluate(call, context);
  if (outcome.error) return error_reply(shape, *outcome.error, method);
  try {
    HttpReply reply;
    reply.method = method;
    reply.mesh = context.mesh;
    if (shape.format != HttpFormat::Json && (outcome.field || outcome.matrix)) {
      if (outcome.field) {
        const protocol::FieldResult& field = *outcome.field;
        reply.response.set("X-Geoprox-Mesh-Version", field.mesh_version);
        const std::size_t n = field.distances.size();
        if (shape.array == ArrayChoice::NearestSource) {
          if (field.nearest_source.empty()) {
            throw ProtocolError(ErrorReason::InvalidParams,
                                "query parameter \"array\": nearest_source needs several "
                                "sources");
          }
          set_binary(reply, shape, protocol::uint32_array(field.nearest_source, {n}));
        } else {
          set_binary(reply, shape, protocol::float_array(field.distances, {n}, shape.dtype));
        }
      } else {
        const protocol::MatrixResult& matrix = *outcome.matrix;
        reply.response.set("X-Geoprox-Mesh-Version", matrix.mesh_version);
        set_binary(reply, shape,
                   protocol::float_array(matrix.distances,
                                         {matrix.source_count, matrix.target_count},
                                         shape.dtype));
      }
    } else {
      reply.response.set(http::field::content_type, kJsonType);
      if (outcome.field) {
        reply.response.body() = protocol::field_result_object(*outcome.field);
      } else if (outcome.matrix) {
        reply.response.body() = protocol::dump_one_line(json(*outcome.matrix));
      } else {
        reply.response.body() = protocol::dump_one_line(outcome.result);
      }
    }
    return finish(shape, std::move(reply));
  } catch (...) {
    return error_reply(shape, current_error(false), method);
  }
}

HttpReply HttpHandler::rpc_reply(const Shape& shape, std::optional<protocol::Method> method,
                                 std::string line, std::optional<ErrorReason> error,
                                 std::string mesh) const {
  HttpReply reply;
  reply.method = method;
  reply.error = error;
  reply.mesh = std::move(mesh);
  if (line.empty()) {
    reply.response.result(http::status::no_content);  // a notification: nothing owed
  } else {
    if (error) reply.response.result(protocol::http_status(*error, shape.token_sent));
    reply.response.set(http::field::content_type, kJsonType);
    reply.response.body() = std::move(line);
  }
  return finish(shape, std::move(reply));
}

void HttpHandler::set_binary(HttpReply& reply, const Shape& shape,
                             protocol::BinaryArray array) const {
  reply.no_gzip = array.dtype != protocol::Dtype::Uint32;
  reply.response.set("X-Geoprox-Dtype", std::string(protocol::dtype_name(array.dtype)));
  reply.response.set("X-Geoprox-Shape", protocol::shape_header(array.shape));
  if (shape.format == HttpFormat::Npy) {
    reply.response.set(http::field::content_type, "application/x-npy");
    reply.response.body() = protocol::encode_npy(array);
  } else {
    reply.response.set(http::field::content_type, "application/octet-stream");
    reply.response.body() = std::move(array.bytes);
  }
}

HttpReply HttpHandler::error_reply(const Shape& shape, const ProtocolError& error,
                                   std::optional<protocol::Method> method) const {
  HttpReply reply;
  reply.method = method;
  reply.error = error.reason();
  reply.response.result(protocol::http_status(error.reason(), shape.token_sent));
  reply.response.set(http::field::content_type, kJsonType);
  if (error.retry_after_ms()) {
    const auto seconds = std::max<std::int64_t>(1, (*error.retry_after_ms() + 999) / 1000);
    reply.response.set(http::field::retry_after, std::to_string(seconds));
  }
  reply.response.body() = protocol::http_error_body(error);
  return finish(shape, std::move(reply));
}

HttpReply HttpHandler::refuse(const HttpRequest& request, protocol::Method method,
                              const ProtocolError& error) const noexcept {
  Shape shape = shape_of(request);
  shape.gzip = false;
  return error_reply(shape, error, method);
}

HttpReply HttpHandler::transport_error(unsigned version, unsigned status,
                                       const std::string& message) const {
  HttpReply reply;
  reply.close = true;
  reply.error = ErrorReason::InvalidRequest;
  reply.response.version(version);
  reply.response.result(status);
  reply.response.set(http::field::content_type, "text/plain; charset=utf-8");
  reply.response.set(http::field::server, "geoproxd/" GEOPROX_VERSION);
  reply.response.keep_alive(false);
  reply.response.body() = message + "\n";
  reply.response.prepare_payload();
  return reply;
}

HttpReply HttpHandler::finish(const Shape& shape, HttpReply reply) const {
  HttpResponse& response = reply.response;
  response.version(shape.version);
  response.set(http::field::server, "geoproxd/" GEOPROX_VERSION);
  if (response.find(http::field::cache_control) == response.end()) {
    response.set(http::field::cache_control, "no-store");
  }
  if (!shape.cors_origin.empty()) {
    response.set(http::field::access_control_allow_origin, shape.cors_origin);
    response.set(http::field::access_control_expose_headers, kExposedHeaders);
    if (shape.cors_origin != "*") response.set(http::field::vary, "Origin");
  }
  if (response.result() == http::status::ok &&
      response.body().size() > config_.limits.max_output_bytes) {
    return error_reply(shape,
                       ProtocolError(ErrorReason::TooLarge,
                                     "the response takes " +
                                         std::to_string(response.body().size()) +
                                         " bytes, more than max_output_bytes (" +
                                         std::to_string(config_.limits.max_output_bytes) + ")"),
                       reply.method);
  }
  if (shape.gzip && !reply.no_gzip && response.body().size() >= kMinGzipBytes &&
      response.body().size() <= kMaxGzipBytes) {
    response.body() = gzip_compress(response.body());
    response.set(http::field::content_encoding, "gzip");
    response.set(http::field::vary, shape.cors_origin.empty() || shape.cors_origin == "*"
                                         ? "Accept-Encoding"
                                         : "Origin, Accept-Encoding");
  }
  response.keep_alive(shape.keep_alive && !reply.close);
  response.prepare_payload();
  if (response.result() == http::status::no_content) {
    response.erase(http::field::content_length);  // RFC 9110: never on a 204
  }
  if (shape.head) {
    // HEAD: the headers of the GET, Content-Length included, without the body.
    const std::size_t length = response.body().size();
    response.body().clear();
    response.content_length(length);
  }
  return reply;
}

}  // namespace geoprox::server
