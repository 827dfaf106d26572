// parse_params: the params object of each method, checked member by member (unknown members
// refused, limits applied before points are parsed), into its Params alternative.
#include <algorithm>
#include <limits>

#include "protocol/json_access.h"
#include "protocol/json_rpc.h"
#include "protocol/params.h"
#include "protocol/points.h"

namespace geoprox::protocol {

using detail::ObjectFields;
using nlohmann::json;

namespace {

constexpr std::size_t kMaxPathLength = 4096;
constexpr std::uint64_t kMaxTimeoutMs = std::numeric_limits<std::int64_t>::max();

// ---- parameter readers ----

std::string read_mesh_id(const ObjectFields& fields, std::string_view member = "mesh") {
  std::string id = fields.require_string(member);
  if (!is_valid_mesh_id(id)) {
    fields.fail(member, "\"" + detail::excerpt(id) +
                            "\" is not a mesh id (1 to 128 characters of A-Z a-z 0-9 . _ -, "
                            "starting with a letter or digit)");
  }
  return id;
}

std::string read_admin_path(const ObjectFields& fields, std::string_view member) {
  std::string path = fields.require_string(member);
  const auto refuse = [&](const std::string& why) {
    throw ProtocolError(ErrorReason::PathNotAllowed,
                        fields.path_of(member) + " \"" + detail::excerpt(path) + "\" " + why);
  };
  if (path.empty()) refuse("is empty");
  if (path.size() > kMaxPathLength) refuse("is longer than 4096 bytes");
  if (path.find('\0') != std::string::npos) refuse("contains a NUL byte");
  if (path.find('\\') != std::string::npos) refuse("contains a backslash");
  std::string_view rest = path;
  while (true) {
    const std::size_t slash = rest.find('/');
    if (rest.substr(0, slash) == "..") {
      refuse("contains a '..' component (paths stay inside the data directory)");
    }
    if (slash == std::string_view::npos) break;
    rest.remove_prefix(slash + 1);
  }
  return path;
}

std::string read_admin_token(const ObjectFields& fields) {
  const json* token = fields.find("token");
  if (token == nullptr || !token->is_string() || token->get_ref<const std::string&>().empty()) {
    throw ProtocolError(ErrorReason::Unauthorized,
                        "admin methods need " + fields.path_of("token") + " (a non-empty string)");
  }
  return token->get<std::string>();
}

BuildOptions read_build_options(const ObjectFields& fields) {
  BuildOptions build;
  const json* value = fields.find("build");
  if (value == nullptr) return build;
  const ObjectFields options(*value, fields.path_of("build"), {"samples", "neighbors", "sampling"});
  constexpr std::uint64_t kMaxCount = std::numeric_limits<std::uint32_t>::max();
  if (auto samples = options.optional_positive_integer("samples", kMaxCount)) {
    build.samples = static_cast<std::uint32_t>(*samples);
  }
  if (auto neighbors = options.optional_positive_integer("neighbors", kMaxCount)) {
    build.neighbors = static_cast<std::uint32_t>(*neighbors);
  }
  if (auto sampling = options.optional_string("sampling")) {
    if (*sampling == "fmm") {
      build.sampling = SamplingMethod::Fmm;
    } else if (*sampling == "exact") {
      build.sampling = SamplingMethod::Exact;
    } else if (*sampling == "auto") {
      build.sampling = SamplingMethod::Auto;
    } else {
      options.fail("sampling", "must be \"fmm\", \"exact\" or \"auto\", not \"" +
                                   detail::excerpt(*sampling) + "\"");
    }
  }
  return build;
}

void check_point_count(std::size_t count, const std::string& where, const Limits& limits) {
  if (count > limits.max_points_per_request) {
    throw ProtocolError(ErrorReason::TooLarge,
                        where + ": " + std::to_string(count) + " points exceed the limit of " +
                            std::to_string(limits.max_points_per_request) + " points per request");
  }
}

/// A non-empty array of points, its size checked against `max_count` before any is parsed.
std::vector<WirePoint> read_points(const ObjectFields& fields, std::string_view member,
                                   std::size_t max_count, std::string_view limit_name) {
  const json& value = fields.require(member);
  const std::string where = fields.path_of(member);
  if (!value.is_array()) {
    fields.fail(member, std::string("must be an array of points, not ") + detail::type_of(value));
  }
  if (value.empty()) fields.fail(member, "must not be empty");
  if (value.size() > max_count) {
    throw ProtocolError(ErrorReason::TooLarge, where + ": " + std::to_string(value.size()) +
                                                   " points exceed " + std::string(limit_name) +
                                                   " = " + std::to_string(max_count));
  }
  std::vector<WirePoint> points;
  points.reserve(value.size());
  for (std::size_t i = 0; i < value.size(); ++i) {
    points.push_back(parse_point(value[i], where + "[" + std::to_string(i) + "]"));
  }
  return points;
}

std::optional<std::int64_t> read_timeout(const ObjectFields& fields) {
  if (auto timeout = fields.optional_positive_integer("timeout_ms", kMaxTimeoutMs)) {
    return static_cast<std::int64_t>(*timeout);
  }
  return std::nullopt;
}

}  // namespace

std::size_t point_count(const Params& params) {
  if (std::holds_alternative<DistanceParams>(params)) return 2;
  if (std::holds_alternative<PathParams>(params)) return 2;
  if (const auto* p = std::get_if<FieldParams>(&params)) return p->sources.size();
  if (const auto* p = std::get_if<MatrixParams>(&params)) {
    return p->sources.size() + p->targets.size();
  }
  if (std::holds_alternative<ExpmapParams>(params)) return 1;
  if (const auto* p = std::get_if<SplineParams>(&params)) return p->control.size();
  if (const auto* p = std::get_if<BatchParams>(&params)) {
    std::size_t total = 0;
    for (const BatchEntry& entry : p->requests) {
      if (entry.params) total += point_count(*entry.params);
    }
    return total;
  }
  return 0;
}

namespace {

Params parse_batch(const ObjectFields& fields, const Limits& limits) {
  const json& requests = fields.require("requests");
  const std::string where = fields.path_of("requests");
  if (!requests.is_array()) {
    fields.fail("requests",
                std::string("must be an array of {\"method\", \"params\"} objects, not ") +
                    detail::type_of(requests));
  }
  if (requests.empty()) fields.fail("requests", "must not be empty");
  if (requests.size() > limits.max_batch_requests) {
    throw ProtocolError(ErrorReason::TooLarge, where + ": " + std::to_string(requests.size()) +
                                                   " requests exceed max_batch_requests = " +
                                                   std::to_string(limits.max_batch_requests));
  }
  BatchParams batch;
  batch.requests.reserve(requests.size());
  std::size_t total_points = 0;
  for (std::size_t i = 0; i < requests.size(); ++i) {
    const std::string entry_path = where + "[" + std::to_string(i) + "]";
    BatchEntry entry;
    try {
      const ObjectFields entry_fields(requests[i], entry_path, {"method", "params"});
      entry.method = entry_fields.require_string("method");
      const std::optional<Method> method = method_from_name(entry.method);
      if (!method) {
        throw ProtocolError(ErrorReason::UnknownMethod, entry_fields.path_of("method") +
                                                            ": unknown method \"" +
                                                            detail::excerpt(entry.method) + "\"");
      }
      if (*method == Method::Batch || *method == Method::ServerAuth ||
          is_admin_method(*method)) {
        entry_fields.fail("method", "\"" + entry.method +
                                        "\" cannot be batched (no nested batches, no admin "
                                        "methods, no server.auth)");
      }
      static const json kNoParams = json::object();
      const json* params = entry_fields.find("params");
      if (params != nullptr && !params->is_object()) {
        entry_fields.fail("params",
                          std::string("must be an object, not ") + detail::type_of(*params));
      }
      entry.params = parse_params(*method, params ? *params : kNoParams, limits, &entry.timeout_ms);
      total_points += point_count(*entry.params);
    } catch (const ProtocolError& error) {
      // Messages of entries name the entry's own params ("params.source"): say which entry.
      const std::string message = error.what();
      entry.error = message.starts_with(entry_path)
                        ? error
                        : ProtocolError(error.reason(), entry_path + ": " + message);
      entry.params.reset();
    }
    batch.requests.push_back(std::move(entry));
  }
  check_point_count(total_points, where, limits);
  return batch;
}
// ---- one reader per method; timeout_ms is read after them (parse_with) ----

Params read_distance(const ObjectFields& fields, const Limits&) {
  return DistanceParams{read_mesh_id(fields),
                        parse_point(fields.require("source"), "params.source"),
                        parse_point(fields.require("target"), "params.target"),
                        fields.optional_bool("exact", false)};
}

Params read_path(const ObjectFields& fields, const Limits&) {
  return PathParams{read_mesh_id(fields), parse_point(fields.require("source"), "params.source"),
                    parse_point(fields.require("target"), "params.target")};
}

FieldEncoding read_encoding(const ObjectFields& fields, FieldEncoding absent,
                            bool allow_f32 = true) {
  const auto encoding = fields.optional_string("encoding");
  if (!encoding) return absent;
  if (*encoding == "json") return FieldEncoding::Json;
  if (*encoding == "f64le-base64") return FieldEncoding::F64leBase64;
  if (allow_f32 && *encoding == "f32le-base64") return FieldEncoding::F32leBase64;
  fields.fail("encoding", std::string(allow_f32 ? R"(must be "json", "f32le-base64" or )"
                                                : R"(must be "json" or )") +
                              R"("f64le-base64", not ")" + detail::excerpt(*encoding) + "\"");
}

Params read_field(const ObjectFields& fields, const Limits& limits) {
  FieldParams parsed;
  parsed.mesh = read_mesh_id(fields);
  if (fields.has("source") && fields.has("sources")) {
    throw ProtocolError(ErrorReason::InvalidParams,
                        "params.source and params.sources are both given; give one");
  }
  if (fields.has("source")) {
    parsed.sources.push_back(parse_point(fields.require("source"), "params.source"));
  } else if (const json* sources = fields.find("sources")) {
    if (sources->is_array()) check_point_count(sources->size(), "params.sources", limits);
    parsed.sources = read_points(fields, "sources", limits.max_field_sources, "max_field_sources");
  } else {
    throw ProtocolError(ErrorReason::InvalidParams,
                        "params.source (or params.sources) is missing");
  }
  parsed.cutoff = fields.optional_positive_number("cutoff");
  parsed.encoding = read_encoding(fields, parsed.encoding);
  return parsed;
}

Params read_matrix(const ObjectFields& fields, const Limits& limits) {
  MatrixParams parsed;
  parsed.mesh = read_mesh_id(fields);
  // Sizes first, so an oversized request is refused before its points are parsed.
  const json& sources = fields.require("sources");
  const json& targets = fields.require("targets");
  if (sources.is_array() && targets.is_array()) {
    check_point_count(sources.size() + targets.size(), "params.sources + params.targets",
                      limits);
    if (sources.size() * targets.size() > limits.max_matrix_pairs) {
      throw ProtocolError(
          ErrorReason::TooLarge,
          "params: " + std::to_string(sources.size()) + " x " + std::to_string(targets.size()) +
              " pairs exceed max_matrix_pairs = " + std::to_string(limits.max_matrix_pairs));
    }
  }
  parsed.sources =
      read_points(fields, "sources", limits.max_points_per_request, "max_points_per_request");
  parsed.targets =
      read_points(fields, "targets", limits.max_points_per_request, "max_points_per_request");
  parsed.encoding = read_encoding(fields, parsed.encoding, /*allow_f32=*/false);
  return parsed;
}

Params read_mesh_info(const ObjectFields& fields, const Limits&) {
  return MeshInfoParams{read_mesh_id(fields)};
}

/// Messages never quote the token: error replies and logs must not carry it.
Params read_server_auth(const ObjectFields& fields, const Limits&) {
  return ServerAuthParams{fields.require_string("token")};
}

Params read_admin_register(const ObjectFields& fields, const Limits&) {
  AdminRegisterParams parsed;
  parsed.token = read_admin_token(fields);
  parsed.mesh = read_mesh_id(fields);
  parsed.mesh_file = read_admin_path(fields, "mesh_file");
  if (fields.has("graph_file")) parsed.graph_file = read_admin_path(fields, "graph_file");
  parsed.repair = fields.optional_bool("repair", false);
  parsed.build = read_build_options(fields);
  return parsed;
}

Params read_admin_rebuild(const ObjectFields& fields, const Limits&) {
  AdminRebuildParams parsed;
  parsed.token = read_admin_token(fields);
  parsed.mesh = read_mesh_id(fields);
  parsed.build = read_build_options(fields);
  return parsed;
}

Params read_admin_unregister(const ObjectFields& fields, const Limits&) {
  AdminUnregisterParams parsed;
  parsed.token = read_admin_token(fields);
  parsed.mesh = read_mesh_id(fields);
  return parsed;
}

Params read_admin_reload(const ObjectFields& fields, const Limits&) {
  AdminReloadParams parsed;
  parsed.token = read_admin_token(fields);
  if (fields.has("mesh")) parsed.mesh = read_mesh_id(fields);
  return parsed;
}

Params read_expmap(const ObjectFields& fields, const Limits&) {
  ExpmapParams parsed;
  parsed.mesh = read_mesh_id(fields);
  parsed.source = parse_point(fields.require("source"), "params.source");
  fields.require("radius");
  parsed.radius = *fields.optional_positive_number("radius");
  parsed.exact = fields.optional_bool("exact", false);
  return parsed;
}

SplineKind read_spline_kind(const ObjectFields& fields, SplineKind absent) {
  const auto type = fields.optional_string("type");
  if (!type) return absent;
  if (*type == "bezier") return SplineKind::Bezier;
  if (*type == "bspline") return SplineKind::BSpline;
  fields.fail("type", "must be \"bezier\" or \"bspline\", not \"" + detail::excerpt(*type) + "\"");
}

Params read_spline(const ObjectFields& fields, const Limits& limits) {
  SplineParams parsed;
  parsed.mesh = read_mesh_id(fields);
  if (const json* control = fields.find("control"); control && control->is_array()) {
    check_point_count(control->size(), "params.control", limits);
  }
  parsed.control =
      read_points(fields, "control", limits.max_points_per_request, "max_points_per_request");
  parsed.type = read_spline_kind(fields, parsed.type);
  const std::size_t n = parsed.control.size();
  if (parsed.type == SplineKind::Bezier && (n < 4 || (n - 1) % 3 != 0)) {
    fields.fail("control", "needs 3k + 1 points for a cubic Bezier spline (4, 7, 10, ...), "
                           "not " + std::to_string(n));
  }
  if (parsed.type == SplineKind::BSpline && n < 4) {
    fields.fail("control",
                "needs at least 4 points for a cubic B-spline, not " + std::to_string(n));
  }
  if (auto samples =
          fields.optional_positive_integer("samples", limits.max_points_per_request)) {
    if (*samples < 2) fields.fail("samples", "must be at least 2 (the curve's two ends)");
    parsed.samples = static_cast<std::uint32_t>(*samples);
  } else {
    // The default must itself be a valid request under a server's smaller limit.
    parsed.samples = static_cast<std::uint32_t>(std::min<std::size_t>(
        parsed.samples, std::max<std::size_t>(2, limits.max_points_per_request)));
  }
  parsed.exact = fields.optional_bool("exact", false);
  return parsed;
}

Params read_batch(const ObjectFields& fields, const Limits& limits) {
  return parse_batch(fields, limits);
}

template <class Parsed>
Params read_nothing(const ObjectFields&, const Limits&) {
  return Parsed{};
}

using Reader = Params (*)(const ObjectFields&, const Limits&);

/// Refuses members outside `members`, reads the method's own ones, then timeout_ms (so that
/// errors in the method's members come first).
Params parse_with(const json& params, std::initializer_list<std::string_view> members,
                  Reader read, const Limits& limits, std::optional<std::int64_t>* timeout_ms) {
  const ObjectFields fields(params, "params", members);
  Params parsed = read(fields, limits);
  const std::optional<std::int64_t> timeout = read_timeout(fields);
  if (timeout_ms != nullptr) *timeout_ms = timeout;
  return parsed;
}

}  // namespace

Params parse_params(Method method, const json& params, const Limits& limits,
                    std::optional<std::int64_t>* timeout_ms) {
  const auto parse = [&](std::initializer_list<std::string_view> members, Reader read) {
    return parse_with(params, members, read, limits, timeout_ms);
  };
  switch (method) {
    case Method::GeodesicDistance:
      return parse({"mesh", "source", "target", "exact", "timeout_ms"}, read_distance);
    case Method::GeodesicPath:
      return parse({"mesh", "source", "target", "timeout_ms"}, read_path);
    case Method::GeodesicField:
      return parse({"mesh", "source", "sources", "cutoff", "encoding", "timeout_ms"}, read_field);
    case Method::GeodesicMatrix:
      return parse({"mesh", "sources", "targets", "encoding", "timeout_ms"}, read_matrix);
    case Method::Batch:
      return parse({"requests", "timeout_ms"}, read_batch);
    case Method::MeshList:
      return parse({"timeout_ms"}, read_nothing<MeshListParams>);
    case Method::MeshInfo:
      return parse({"mesh", "timeout_ms"}, read_mesh_info);
    case Method::ServerInfo:
      return parse({"timeout_ms"}, read_nothing<ServerInfoParams>);
    case Method::ServerHealth:
      return parse({"timeout_ms"}, read_nothing<ServerHealthParams>);
    case Method::ServerMetrics:
      return parse({"timeout_ms"}, read_nothing<ServerMetricsParams>);
    case Method::ServerAuth:
      return parse({"token", "timeout_ms"}, read_server_auth);
    case Method::AdminRegister:
      return parse({"token", "mesh", "mesh_file", "graph_file", "repair", "build", "timeout_ms"},
                   read_admin_register);
    case Method::AdminRebuild:
      return parse({"token", "mesh", "build", "timeout_ms"}, read_admin_rebuild);
    case Method::AdminUnregister:
      return parse({"token", "mesh", "timeout_ms"}, read_admin_unregister);
    case Method::AdminReload:
      return parse({"token", "mesh", "timeout_ms"}, read_admin_reload);
    case Method::GeodesicExpmap:
      return parse({"mesh", "source", "radius", "exact", "timeout_ms"}, read_expmap);
    case Method::GeodesicSpline:
      return parse({"mesh", "control", "type", "samples", "exact", "timeout_ms"}, read_spline);
  }
  throw ProtocolError(ErrorReason::Internal, "parse_params: method out of range");
}

}  // namespace geoprox::protocol
