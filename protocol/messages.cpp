// The method table (names in enum order) and the names of the protocol's enums. Parameters are
// parsed in params_parse.cpp and written back in params_json.cpp; results in results.cpp.
#include "protocol/messages.h"

#include <array>

namespace geoprox::protocol {

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
  switch (encoding) {
    case FieldEncoding::Json:
      return "json";
    case FieldEncoding::F32leBase64:
      return "f32le-base64";
    case FieldEncoding::F64leBase64:
      return "f64le-base64";
  }
  return "json";
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

}  // namespace geoprox::protocol
