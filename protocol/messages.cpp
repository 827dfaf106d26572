#include "protocol/messages.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "protocol/base64.h"
#include "protocol/json_access.h"
#include "protocol/json_rpc.h"

namespace geoprox::protocol {

using detail::ObjectFields;
using nlohmann::json;

namespace {

struct MethodEntry {
  Method method;
  std::string_view name;
};

// In declaration order of Method (checked at compile time below).
constexpr std::array kMethods = {
    MethodEntry{Method::GeodesicDistance, "geodesic.distance"},
    MethodEntry{Method::GeodesicPath, "geodesic.path"},
    MethodEntry{Method::GeodesicField, "geodesic.field"},
    MethodEntry{Method::GeodesicMatrix, "geodesic.matrix"},
    MethodEntry{Method::Batch, "batch"},
    MethodEntry{Method::MeshList, "mesh.list"},
    MethodEntry{Method::MeshInfo, "mesh.info"},
    MethodEntry{Method::ServerInfo, "server.info"},
    MethodEntry{Method::ServerHealth, "server.health"},
    MethodEntry{Method::ServerMetrics, "server.metrics"},
    MethodEntry{Method::AdminRegister, "admin.register"},
    MethodEntry{Method::AdminRebuild, "admin.rebuild"},
    MethodEntry{Method::AdminUnregister, "admin.unregister"},
    MethodEntry{Method::AdminReload, "admin.reload"},
    MethodEntry{Method::GeodesicExpmap, "geodesic.expmap"},
    MethodEntry{Method::GeodesicSpline, "geodesic.spline"},
    MethodEntry{Method::ServerAuth, "server.auth"},
};

constexpr bool methods_follow_enum_order() {
  for (std::size_t i = 0; i < kMethods.size(); ++i) {
    if (static_cast<std::size_t>(kMethods[i].method) != i) return false;
  }
  return static_cast<std::size_t>(Method::ServerAuth) + 1 == kMethods.size();
}
static_assert(methods_follow_enum_order(), "kMethods must list every Method in enum order");

constexpr std::array<Method, kMethods.size()> make_method_list() {
  std::array<Method, kMethods.size()> list{};
  for (std::size_t i = 0; i < kMethods.size(); ++i) list[i] = kMethods[i].method;
  return list;
}
constexpr std::array kMethodList = make_method_list();

constexpr std::size_t kMaxMeshIdLength = 128;
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

std::size_t count_points(const Params& params) {
  if (std::holds_alternative<DistanceParams>(params)) return 2;
  if (std::holds_alternative<PathParams>(params)) return 2;
  if (const auto* p = std::get_if<FieldParams>(&params)) return p->sources.size();
  if (const auto* p = std::get_if<MatrixParams>(&params)) {
    return p->sources.size() + p->targets.size();
  }
  if (std::holds_alternative<ExpmapParams>(params)) return 1;
  if (const auto* p = std::get_if<SplineParams>(&params)) return p->control.size();
  return 0;
}

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
      total_points += count_points(*entry.params);
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

}  // namespace

std::span<const Method> all_methods() { return kMethodList; }

std::string_view method_name(Method method) {
  const auto index = static_cast<std::size_t>(method);
  return index < kMethods.size() ? kMethods[index].name : std::string_view("unknown");
}

std::optional<Method> method_from_name(std::string_view name) {
  for (const MethodEntry& entry : kMethods) {
    if (entry.name == name) return entry.method;
  }
  return std::nullopt;
}

bool is_admin_method(Method method) {
  return method == Method::AdminRegister || method == Method::AdminRebuild ||
         method == Method::AdminUnregister || method == Method::AdminReload;
}

bool allowed_before_auth(Method method) {
  return method == Method::ServerHealth || method == Method::ServerAuth;
}

bool is_valid_mesh_id(std::string_view id) {
  if (id.empty() || id.size() > kMaxMeshIdLength) return false;
  const auto alnum = [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
  };
  if (!alnum(id[0])) return false;
  for (char c : id) {
    if (!alnum(c) && c != '.' && c != '_' && c != '-') return false;
  }
  return true;
}

std::string_view encoding_name(FieldEncoding encoding) {
  return encoding == FieldEncoding::Json ? "json" : "f32le-base64";
}

std::string_view sampling_name(SamplingMethod sampling) {
  switch (sampling) {
    case SamplingMethod::Fmm:
      return "fmm";
    case SamplingMethod::Exact:
      return "exact";
    case SamplingMethod::Auto:
      break;
  }
  return "auto";
}

std::string_view spline_kind_name(SplineKind kind) {
  return kind == SplineKind::Bezier ? "bezier" : "bspline";
}

std::string_view mesh_state_name(MeshState state) {
  switch (state) {
    case MeshState::Ready:
      return "ready";
    case MeshState::Building:
      return "building";
    case MeshState::Failed:
      break;
  }
  return "failed";
}

std::string_view health_status_name(HealthStatus status) {
  switch (status) {
    case HealthStatus::Ok:
      return "ok";
    case HealthStatus::Starting:
      return "starting";
    case HealthStatus::Draining:
      break;
  }
  return "draining";
}

Method method_of(const Params& params) { return kMethods[params.index()].method; }
static_assert(std::variant_size_v<Params> == kMethods.size(),
              "Params has one alternative per Method, in the same order");

Params parse_params(Method method, const json& params, const Limits& limits,
                    std::optional<std::int64_t>* timeout_ms) {
  const auto finish = [&](const ObjectFields& fields) {
    const std::optional<std::int64_t> timeout = read_timeout(fields);
    if (timeout_ms != nullptr) *timeout_ms = timeout;
  };
  switch (method) {
    case Method::GeodesicDistance: {
      const ObjectFields fields(params, "params",
                                {"mesh", "source", "target", "exact", "timeout_ms"});
      DistanceParams parsed{read_mesh_id(fields),
                            parse_point(fields.require("source"), "params.source"),
                            parse_point(fields.require("target"), "params.target"),
                            fields.optional_bool("exact", false)};
      finish(fields);
      return parsed;
    }
    case Method::GeodesicPath: {
      const ObjectFields fields(params, "params", {"mesh", "source", "target", "timeout_ms"});
      PathParams parsed{read_mesh_id(fields),
                        parse_point(fields.require("source"), "params.source"),
                        parse_point(fields.require("target"), "params.target")};
      finish(fields);
      return parsed;
    }
    case Method::GeodesicField: {
      const ObjectFields fields(params, "params",
                                {"mesh", "source", "sources", "cutoff", "encoding", "timeout_ms"});
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
        parsed.sources =
            read_points(fields, "sources", limits.max_field_sources, "max_field_sources");
      } else {
        throw ProtocolError(ErrorReason::InvalidParams,
                            "params.source (or params.sources) is missing");
      }
      parsed.cutoff = fields.optional_positive_number("cutoff");
      if (auto encoding = fields.optional_string("encoding")) {
        if (*encoding == "json") {
          parsed.encoding = FieldEncoding::Json;
        } else if (*encoding == "f32le-base64") {
          parsed.encoding = FieldEncoding::F32leBase64;
        } else {
          fields.fail("encoding", "must be \"json\" or \"f32le-base64\", not \"" +
                                      detail::excerpt(*encoding) + "\"");
        }
      }
      finish(fields);
      return parsed;
    }
    case Method::GeodesicMatrix: {
      const ObjectFields fields(params, "params", {"mesh", "sources", "targets", "timeout_ms"});
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
      finish(fields);
      return parsed;
    }
    case Method::Batch: {
      const ObjectFields fields(params, "params", {"requests", "timeout_ms"});
      Params parsed = parse_batch(fields, limits);
      finish(fields);
      return parsed;
    }
    case Method::MeshList: {
      const ObjectFields fields(params, "params", {"timeout_ms"});
      finish(fields);
      return MeshListParams{};
    }
    case Method::MeshInfo: {
      const ObjectFields fields(params, "params", {"mesh", "timeout_ms"});
      MeshInfoParams parsed{read_mesh_id(fields)};
      finish(fields);
      return parsed;
    }
    case Method::ServerInfo: {
      const ObjectFields fields(params, "params", {"timeout_ms"});
      finish(fields);
      return ServerInfoParams{};
    }
    case Method::ServerHealth: {
      const ObjectFields fields(params, "params", {"timeout_ms"});
      finish(fields);
      return ServerHealthParams{};
    }
    case Method::ServerMetrics: {
      const ObjectFields fields(params, "params", {"timeout_ms"});
      finish(fields);
      return ServerMetricsParams{};
    }
    case Method::ServerAuth: {
      // Messages never quote the token: error replies and logs must not carry it.
      const ObjectFields fields(params, "params", {"token", "timeout_ms"});
      ServerAuthParams parsed{fields.require_string("token")};
      finish(fields);
      return parsed;
    }
    case Method::AdminRegister: {
      const ObjectFields fields(
          params, "params", {"token", "mesh", "mesh_file", "graph_file", "build", "timeout_ms"});
      AdminRegisterParams parsed;
      parsed.token = read_admin_token(fields);
      parsed.mesh = read_mesh_id(fields);
      parsed.mesh_file = read_admin_path(fields, "mesh_file");
      if (fields.has("graph_file")) parsed.graph_file = read_admin_path(fields, "graph_file");
      parsed.build = read_build_options(fields);
      finish(fields);
      return parsed;
    }
    case Method::AdminRebuild: {
      const ObjectFields fields(params, "params", {"token", "mesh", "build", "timeout_ms"});
      AdminRebuildParams parsed;
      parsed.token = read_admin_token(fields);
      parsed.mesh = read_mesh_id(fields);
      parsed.build = read_build_options(fields);
      finish(fields);
      return parsed;
    }
    case Method::AdminUnregister: {
      const ObjectFields fields(params, "params", {"token", "mesh", "timeout_ms"});
      AdminUnregisterParams parsed;
      parsed.token = read_admin_token(fields);
      parsed.mesh = read_mesh_id(fields);
      finish(fields);
      return parsed;
    }
    case Method::AdminReload: {
      const ObjectFields fields(params, "params", {"token", "mesh", "timeout_ms"});
      AdminReloadParams parsed;
      parsed.token = read_admin_token(fields);
      if (fields.has("mesh")) parsed.mesh = read_mesh_id(fields);
      finish(fields);
      return parsed;
    }
    case Method::GeodesicExpmap: {
      const ObjectFields fields(params, "params",
                                {"mesh", "source", "radius", "exact", "timeout_ms"});
      ExpmapParams parsed;
      parsed.mesh = read_mesh_id(fields);
      parsed.source = parse_point(fields.require("source"), "params.source");
      fields.require("radius");
      parsed.radius = *fields.optional_positive_number("radius");
      parsed.exact = fields.optional_bool("exact", false);
      finish(fields);
      return parsed;
    }
    case Method::GeodesicSpline: {
      const ObjectFields fields(
          params, "params", {"mesh", "control", "type", "samples", "exact", "timeout_ms"});
      SplineParams parsed;
      parsed.mesh = read_mesh_id(fields);
      if (const json* control = fields.find("control"); control && control->is_array()) {
        check_point_count(control->size(), "params.control", limits);
      }
      parsed.control =
          read_points(fields, "control", limits.max_points_per_request, "max_points_per_request");
      if (auto type = fields.optional_string("type")) {
        if (*type == "bezier") {
          parsed.type = SplineKind::Bezier;
        } else if (*type == "bspline") {
          parsed.type = SplineKind::BSpline;
        } else {
          fields.fail("type", "must be \"bezier\" or \"bspline\", not \"" +
                                  detail::excerpt(*type) + "\"");
        }
      }
      const std::size_t n = parsed.control.size();
      if (parsed.type == SplineKind::Bezier && (n < 4 || (n - 1) % 3 != 0)) {
        fields.fail("control", "needs 3k + 1 points for a cubic Bezier spline (4, 7, 10, ...), "
                               "not " + std::to_string(n));
      }
      if (parsed.type == SplineKind::BSpline && n < 4) {
        fields.fail("control",
                    "needs at least 4 points for a cubic B-spline, not " + std::to_string(n));
      }
      if (auto samples = fields.optional_positive_integer("samples", limits.max_points_per_request)) {
        if (*samples < 2) fields.fail("samples", "must be at least 2 (the curve's two ends)");
        parsed.samples = static_cast<std::uint32_t>(*samples);
      } else {
        // The default must itself be a valid request under a server's smaller limit.
        parsed.samples = static_cast<std::uint32_t>(std::min<std::size_t>(
            parsed.samples, std::max<std::size_t>(2, limits.max_points_per_request)));
      }
      parsed.exact = fields.optional_bool("exact", false);
      finish(fields);
      return parsed;
    }
  }
  throw ProtocolError(ErrorReason::Internal, "parse_params: method out of range");
}

// ---- parameters back to JSON (clients) ----

namespace {

json points_json(const std::vector<WirePoint>& points) {
  json array = json::array();
  for (const WirePoint& point : points) array.push_back(point);
  return array;
}

json params_json(const DistanceParams& p) {
  json out = {{"mesh", p.mesh}, {"source", p.source}, {"target", p.target}};
  if (p.exact) out["exact"] = true;
  return out;
}
json params_json(const PathParams& p) {
  return {{"mesh", p.mesh}, {"source", p.source}, {"target", p.target}};
}
json params_json(const FieldParams& p) {
  json out = {{"mesh", p.mesh}, {"encoding", encoding_name(p.encoding)}};
  if (p.sources.size() == 1) {
    out["source"] = p.sources.front();
  } else {
    out["sources"] = points_json(p.sources);
  }
  if (p.cutoff) out["cutoff"] = *p.cutoff;
  return out;
}
json params_json(const MatrixParams& p) {
  return {
      {"mesh", p.mesh}, {"sources", points_json(p.sources)}, {"targets", points_json(p.targets)}};
}
json params_json(const BatchParams& p) {
  json requests = json::array();
  for (const BatchEntry& entry : p.requests) {
    json item = {{"method", entry.method}};
    if (entry.params) item["params"] = *entry.params;
    if (entry.timeout_ms) item["params"]["timeout_ms"] = *entry.timeout_ms;
    requests.push_back(std::move(item));
  }
  return {{"requests", std::move(requests)}};
}
json params_json(const MeshInfoParams& p) { return {{"mesh", p.mesh}}; }
json params_json(const MeshListParams&) { return json::object(); }
json params_json(const ServerInfoParams&) { return json::object(); }
json params_json(const ServerHealthParams&) { return json::object(); }
json params_json(const ServerMetricsParams&) { return json::object(); }
json params_json(const ServerAuthParams& p) { return {{"token", p.token}}; }
json params_json(const AdminRegisterParams& p) {
  json out = {{"token", p.token}, {"mesh", p.mesh}, {"mesh_file", p.mesh_file}};
  if (p.graph_file) out["graph_file"] = *p.graph_file;
  if (p.build != BuildOptions{}) out["build"] = p.build;
  return out;
}
json params_json(const AdminRebuildParams& p) {
  json out = {{"token", p.token}, {"mesh", p.mesh}};
  if (p.build != BuildOptions{}) out["build"] = p.build;
  return out;
}
json params_json(const AdminUnregisterParams& p) { return {{"token", p.token}, {"mesh", p.mesh}}; }
json params_json(const ExpmapParams& p) {
  json out = {{"mesh", p.mesh}, {"source", p.source}, {"radius", p.radius}};
  if (p.exact) out["exact"] = true;
  return out;
}
json params_json(const SplineParams& p) {
  json out = {{"mesh", p.mesh},
              {"control", points_json(p.control)},
              {"type", spline_kind_name(p.type)},
              {"samples", p.samples}};
  if (p.exact) out["exact"] = true;
  return out;
}
json params_json(const AdminReloadParams& p) {
  json out = {{"token", p.token}};
  if (p.mesh) out["mesh"] = *p.mesh;
  return out;
}

}  // namespace

void to_json(json& out, const Params& params) {
  out = std::visit([](const auto& p) { return params_json(p); }, params);
}

void to_json(json& out, const BuildOptions& build) {
  out = json::object();
  if (build.samples) out["samples"] = *build.samples;
  if (build.neighbors) out["neighbors"] = *build.neighbors;
  if (build.sampling) out["sampling"] = sampling_name(*build.sampling);
}

// ---- results ----

namespace {

/// Results never carry NaN or infinity: JSON has neither, and nlohmann would print null.
double finite_distance(double distance, std::string_view what) {
  if (!std::isfinite(distance)) {
    throw ProtocolError(ErrorReason::Internal,
                        std::string(what) +
                            ": distance is not finite; an unreachable target "
                            "must be answered with the Unreachable error");
  }
  return distance;
}

json distance_or_null(double distance) {
  return std::isfinite(distance) ? json(distance) : json(nullptr);
}

json optional_json(const auto& value) { return value ? json(*value) : json(nullptr); }

void write_summary(json& out, const MeshSummary& summary, std::string_view id_key) {
  out[std::string(id_key)] = summary.mesh;
  out["mesh_version"] = optional_json(summary.mesh_version);
  out["state"] = mesh_state_name(summary.state);
  out["progress"] = summary.progress;
  out["phase"] = optional_json(summary.phase);
  out["vertices"] = summary.vertices;
  out["faces"] = summary.faces;
  out["samples"] = optional_json(summary.samples);
  out["error"] = optional_json(summary.error);
}

}  // namespace

void to_json(json& out, const DistanceResult& result) {
  out = {{"mesh", result.mesh},
         {"mesh_version", result.mesh_version},
         {"distance", finite_distance(result.distance, "geodesic.distance")},
         {"source", result.source},
         {"target", result.target},
         {"exact", result.exact}};
}

void to_json(json& out, const PathPoint& point) {
  out = {{"face", point.face}, {"bary", point.bary}, {"position", point.position}};
}

void to_json(json& out, const PathResult& result) {
  json points = json::array();
  for (const PathPoint& point : result.points) points.push_back(point);
  out = {{"mesh", result.mesh},
         {"mesh_version", result.mesh_version},
         {"distance", finite_distance(result.distance, "geodesic.path")},
         {"source", result.source},
         {"target", result.target},
         {"exact", result.exact},
         {"points", std::move(points)}};
}

namespace {

/// Vertices with a distance; checks the shape the server filled in.
std::size_t count_reached(const FieldResult& result) {
  if (!result.nearest_source.empty() && result.nearest_source.size() != result.distances.size()) {
    throw ProtocolError(ErrorReason::Internal,
                        "geodesic.field: nearest_source and distances differ in length");
  }
  std::size_t reached = 0;
  for (double distance : result.distances) reached += std::isfinite(distance) ? 1 : 0;
  return reached;
}

}  // namespace

void to_json(json& out, const FieldResult& result) {
  const std::size_t reached = count_reached(result);
  out = {{"mesh", result.mesh},
         {"mesh_version", result.mesh_version},
         {"encoding", encoding_name(result.encoding)},
         {"vertices", result.distances.size()},
         {"reached", reached},
         {"cutoff", optional_json(result.cutoff)}};
  if (result.encoding == FieldEncoding::F32leBase64) {
    out["distances"] = encode_f32le_base64(std::span<const double>(result.distances));
    if (!result.nearest_source.empty()) {
      out["nearest_source"] = encode_u32le_base64(result.nearest_source);
    }
    return;
  }
  json distances = json::array();
  distances.get_ref<json::array_t&>().reserve(result.distances.size());
  for (double distance : result.distances) distances.push_back(distance_or_null(distance));
  out["distances"] = std::move(distances);
  if (!result.nearest_source.empty()) {
    json nearest = json::array();
    nearest.get_ref<json::array_t&>().reserve(result.nearest_source.size());
    for (std::uint32_t index : result.nearest_source) {
      nearest.push_back(index == FieldResult::kNotReached ? json(nullptr) : json(index));
    }
    out["nearest_source"] = std::move(nearest);
  }
}

std::string serialize_field_result(const RequestId& id, const FieldResult& result) {
  if (result.encoding != FieldEncoding::F32leBase64) return serialize_result(id, json(result));
  const std::size_t reached = count_reached(result);
  const std::string distances = encode_f32le_base64(std::span<const double>(result.distances));
  const std::string nearest =
      result.nearest_source.empty() ? std::string() : encode_u32le_base64(result.nearest_source);
  // The members of to_json(FieldResult), in the alphabetical order nlohmann writes them.
  std::string line;
  line.reserve(distances.size() + nearest.size() + result.mesh.size() + result.mesh_version.size() +
               256);
  line += R"({"jsonrpc":"2.0","id":)";
  line += id.json_text();
  line += R"(,"result":{"cutoff":)";
  line += dump_one_line(optional_json(result.cutoff));
  line += R"(,"distances":")";
  line += distances;
  line += R"(","encoding":")";
  line += encoding_name(result.encoding);
  line += R"(","mesh":)";
  line += dump_one_line(json(result.mesh));
  line += R"(,"mesh_version":)";
  line += dump_one_line(json(result.mesh_version));
  if (!nearest.empty()) {
    line += R"(,"nearest_source":")";
    line += nearest;
    line += '"';
  }
  line += R"(,"reached":)";
  line += std::to_string(reached);
  line += R"(,"vertices":)";
  line += std::to_string(result.distances.size());
  line += "}}\n";
  return line;
}

void to_json(json& out, const MatrixResult& result) {
  if (result.distances.size() != result.source_count * result.target_count) {
    throw ProtocolError(ErrorReason::Internal, "geodesic.matrix: distances hold " +
                                                   std::to_string(result.distances.size()) +
                                                   " values, not " +
                                                   std::to_string(result.source_count) + " x " +
                                                   std::to_string(result.target_count));
  }
  json rows = json::array();
  std::size_t unreachable = 0;
  for (std::size_t s = 0; s < result.source_count; ++s) {
    json row = json::array();
    for (std::size_t t = 0; t < result.target_count; ++t) {
      const double distance = result.distances[s * result.target_count + t];
      unreachable += std::isfinite(distance) ? 0 : 1;
      row.push_back(distance_or_null(distance));
    }
    rows.push_back(std::move(row));
  }
  out = {{"mesh", result.mesh},
         {"mesh_version", result.mesh_version},
         {"sources", result.source_count},
         {"targets", result.target_count},
         {"unreachable", unreachable},
         {"distances", std::move(rows)}};
}

void to_json(json& out, const MeshSummary& summary) {
  out = json::object();
  write_summary(out, summary, "mesh");
}

void to_json(json& out, const MeshListResult& result) {
  json meshes = json::array();
  for (const MeshSummary& summary : result.meshes) {
    json entry = json::object();
    write_summary(entry, summary, "id");
    meshes.push_back(std::move(entry));
  }
  out = {{"meshes", std::move(meshes)}};
}

void to_json(json& out, const MeshInfoResult& result) {
  out = json::object();
  write_summary(out, result.summary, "mesh");
  out["edges"] = result.edges;
  out["graph_edges"] = optional_json(result.graph_edges);
  out["mesh_file"] = result.mesh_file;
  out["graph_file"] = result.graph_file;
  out["build"] = result.build;
  out["covering_radius"] = optional_json(result.covering_radius);
  out["link_radius"] = optional_json(result.link_radius);
}

void to_json(json& out, const ServerInfoResult& result) {
  json methods = json::array();
  for (Method method : all_methods()) methods.push_back(method_name(method));
  out = {{"protocol_version", kProtocolVersion},
         {"server_version", result.server_version},
         {"limits", result.limits},
         {"encodings",
          {encoding_name(FieldEncoding::Json), encoding_name(FieldEncoding::F32leBase64)}},
         {"methods", std::move(methods)},
         {"admin_enabled", result.admin_enabled}};
}

void to_json(json& out, const HealthResult& result) {
  out = {
      {"status", health_status_name(result.status)}, {"ready", result.status == HealthStatus::Ok},
      {"meshes_ready", result.meshes_ready},         {"meshes_total", result.meshes_total},
      {"uptime_seconds", result.uptime_seconds},     {"in_flight", result.in_flight},
      {"auth_required", result.auth_required}};
}

void to_json(json& out, const ServerAuthResult& result) {
  out = {{"authenticated", result.authenticated}};
}

void to_json(json& out, const MetricsResult& result) {
  out = {{"format", "prometheus-text-0.0.4"}, {"text", result.text}};
}

void to_json(json& out, const AdminUnregisterResult& result) {
  out = {{"mesh", result.mesh}, {"unregistered", true}};
}

void to_json(json& out, const AdminReloadResult& result) {
  json meshes = json::array();
  for (const ReloadOutcome& outcome : result.meshes) {
    meshes.push_back({{"mesh", outcome.mesh},
                      {"reloaded", outcome.reloaded},
                      {"mesh_version", optional_json(outcome.mesh_version)},
                      {"error", outcome.error ? error_to_json(*outcome.error) : json(nullptr)}});
  }
  out = {{"meshes", std::move(meshes)}};
}

void to_json(json& out, const ExpmapResult& result) {
  if (result.u.size() != result.vertices.size() || result.v.size() != result.vertices.size()) {
    throw ProtocolError(ErrorReason::Internal, "geodesic.expmap: columns differ in length");
  }
  out = {{"mesh", result.mesh},
         {"mesh_version", result.mesh_version},
         {"source", result.source},
         {"radius", result.radius},
         {"exact", result.exact},
         {"count", result.vertices.size()},
         {"vertices", result.vertices},
         {"u", result.u},
         {"v", result.v}};
}

void to_json(json& out, const SplineResult& result) {
  json polygon = json::array();
  for (const std::vector<PathPoint>& leg : result.control_polygon) polygon.push_back(leg);
  out = {{"mesh", result.mesh},
         {"mesh_version", result.mesh_version},
         {"type", spline_kind_name(result.type)},
         {"exact", result.exact},
         {"points", result.points},
         {"control_polygon", std::move(polygon)}};
}

void to_json(json& out, const BatchResult& result) {
  json results = json::array();
  for (const auto& answer : result.results) {
    if (const auto* error = std::get_if<ProtocolError>(&answer)) {
      results.push_back({{"error", error_to_json(*error)}});
    } else {
      results.push_back({{"result", std::get<json>(answer)}});
    }
  }
  out = {{"results", std::move(results)}};
}

}  // namespace geoprox::protocol
