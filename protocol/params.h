// Methods and their parameters, as plain structs with their JSON mapping.
//
// Parameters are parsed and validated here (types, shapes, finiteness, limits) by
// parse_params(); ranges against a mesh (ids, samples) and everything needing server state are
// the server's checks. docs/protocol.md shows every message.
//
// Common to all methods: params may hold `timeout_ms` (an integer >= 1; the server clamps it to
// its maximum, see Limits), returned apart from the method's own params.
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "protocol/errors.h"
#include "protocol/json_rpc.h"
#include "protocol/limits.h"
#include "protocol/points.h"

namespace geoprox::protocol {

/// Version of this protocol, reported by server.info; bumped on incompatible changes.
inline constexpr int kProtocolVersion = 1;

enum class Method : std::uint8_t {
  GeodesicDistance,
  GeodesicPath,
  GeodesicField,
  GeodesicMatrix,
  Batch,
  MeshList,
  MeshInfo,
  ServerInfo,
  ServerHealth,
  ServerMetrics,
  AdminRegister,
  AdminRebuild,
  AdminUnregister,
  AdminReload,
  GeodesicExpmap,
  GeodesicSpline,
  ServerAuth,
};

/// Every method in declaration order, and their wire names ("geodesic.distance", ...).
std::span<const Method> all_methods();
std::string_view method_name(Method method);
std::optional<Method> method_from_name(std::string_view name);
/// admin.*: need the admin token; never allowed inside a batch.
bool is_admin_method(Method method);
/// The methods a connection may call before server.auth when the server has a query token:
/// server.health (probes) and server.auth itself.
bool allowed_before_auth(Method method);

/// Mesh ids: 1 to 128 characters of [A-Za-z0-9._-], starting with a letter or a digit (they
/// may name files and appear in metrics labels). The server applies the same rule to its config.
bool is_valid_mesh_id(std::string_view id);

// ---- Parameters ----

struct DistanceParams {
  std::string mesh;
  WirePoint source;
  WirePoint target;
  bool exact = false;  ///< ask for an exact solve instead of the graph's approximation
};

struct PathParams {
  std::string mesh;
  WirePoint source;
  WirePoint target;
};

/// How geodesic.field and geodesic.matrix send their distances: JSON numbers (null where not
/// reached), or base64 of little-endian binary32 / binary64 values (+inf where not reached).
enum class FieldEncoding : std::uint8_t { Json, F32leBase64, F64leBase64 };
/// "json", "f32le-base64", "f64le-base64"
std::string_view encoding_name(FieldEncoding encoding);

struct FieldParams {
  std::string mesh;
  /// From "source" (one point) or "sources" (1 to max_field_sources points); the result has
  /// nearest_source when there are several.
  std::vector<WirePoint> sources;
  /// Vertices farther than this are not reached: it bounds the work.
  std::optional<double> cutoff;
  FieldEncoding encoding = FieldEncoding::Json;
};

struct MatrixParams {
  std::string mesh;
  std::vector<WirePoint> sources;
  std::vector<WirePoint> targets;
  /// Json (default) or F64leBase64; F32leBase64 is refused (a matrix is small enough to send
  /// exactly).
  FieldEncoding encoding = FieldEncoding::Json;
};

struct MeshListParams {};
struct MeshInfoParams {
  std::string mesh;
};
struct ServerInfoParams {};
struct ServerHealthParams {};
struct ServerMetricsParams {};

/// server.auth: authenticates the connection with the server's query token. Any string is
/// accepted here (an empty one never matches); the comparison is the server's. Never batched.
struct ServerAuthParams {
  std::string token;
};

enum class SamplingMethod : std::uint8_t { Fmm, Exact, Auto };
std::string_view sampling_name(SamplingMethod sampling);  ///< "fmm", "exact", "auto"

/// Build parameters of a proximity graph (as `geoprox build`); absent ones take the server's
/// defaults (the paper's Table 1 by face count).
struct BuildOptions {
  std::optional<std::uint32_t> samples;
  std::optional<std::uint32_t> neighbors;
  std::optional<SamplingMethod> sampling;

  bool operator==(const BuildOptions&) const = default;
};

/// Paths are relative to the server's data directory; this layer refuses empty paths, NUL
/// bytes and ".." components (PathNotAllowed); the server confines absolute ones.
struct AdminRegisterParams {
  std::string token;
  std::string mesh;
  std::string mesh_file;
  std::optional<std::string> graph_file;  ///< default: chosen by the server
  /// Load the mesh repaired (ids as in the file `geoprox repair` writes) instead of refusing a
  /// mesh that is not an oriented manifold; for every load and build of this mesh.
  bool repair = false;
  BuildOptions build;
};

struct AdminRebuildParams {
  std::string token;
  std::string mesh;
  BuildOptions build;  ///< overrides for this rebuild; absent ones keep the registered values
};

struct AdminUnregisterParams {
  std::string token;
  std::string mesh;
};

/// Reopens graph files from disk (after an offline rebuild), like SIGHUP.
struct AdminReloadParams {
  std::string token;
  std::optional<std::string> mesh;  ///< absent: every mesh
};

/// geodesic.expmap: geodesic polar coordinates of every vertex within `radius` of `source`
/// (core/apps/exponential_map.h).
struct ExpmapParams {
  std::string mesh;
  WirePoint source;
  double radius = 0;   ///< > 0, finite
  bool exact = false;  ///< the exact solver's map instead of the graph's
};

enum class SplineKind : std::uint8_t { Bezier, BSpline };
std::string_view spline_kind_name(SplineKind kind);  ///< "bezier", "bspline"

/// geodesic.spline: a cubic Bezier (3k + 1 control points) or uniform cubic B-spline (>= 4)
/// on the surface (core/apps/geodesic_spline.h).
struct SplineParams {
  std::string mesh;
  std::vector<WirePoint> control;  ///< 4 to max_points_per_request points
  SplineKind type = SplineKind::Bezier;
  /// Curve points, 2 to max_points_per_request; 100 when absent (or the limit if less).
  std::uint32_t samples = 100;
  bool exact = false;           ///< exact geodesics instead of the graph's
};

struct BatchEntry;

/// Independent requests answered together, in order, each with its own result or error.
struct BatchParams {
  std::vector<BatchEntry> requests;
};

/// One alternative per method, so the alternative alone says the method (method_of()).
using Params =
    std::variant<DistanceParams, PathParams, FieldParams, MatrixParams, BatchParams, MeshListParams,
                 MeshInfoParams, ServerInfoParams, ServerHealthParams, ServerMetricsParams,
                 AdminRegisterParams, AdminRebuildParams, AdminUnregisterParams, AdminReloadParams,
                 ExpmapParams, SplineParams, ServerAuthParams>;

/// One entry of a batch, `{"method": ..., "params": {...}}`. An entry that does not parse does
/// not fail the batch: it carries its error, answered in its slot.
struct BatchEntry {
  std::string method;            ///< as sent, for logs
  std::optional<Params> params;  ///< set when the entry is valid
  std::optional<std::int64_t> timeout_ms;
  std::optional<ProtocolError> error;  ///< set when it is not
};

Method method_of(const Params& params);

/// Points `params` names, as max_points_per_request counts them: sources + targets, a path's or
/// distance's two ends, a spline's control points; a batch counts its valid entries together.
std::size_t point_count(const Params& params);

/// A method's params, validated. Throws ProtocolError: InvalidParams (missing, mistyped, unknown
/// members), point reasons (BadPoint, BadBarycentric, ...), PathNotAllowed, TooLarge (limits).
/// `params` must be an object (parse_envelope() guarantees it). `timeout_ms`, if given, is
/// returned through `timeout_ms`.
Params parse_params(Method method, const nlohmann::json& params, const Limits& limits,
                    std::optional<std::int64_t>* timeout_ms = nullptr);

/// The params object of `params` (what a client sends); parse_params() reads it back equal.
void to_json(nlohmann::json& out, const Params& params);
void to_json(nlohmann::json& out, const BuildOptions& build);

}  // namespace geoprox::protocol
