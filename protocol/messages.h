// Methods, their parameters and their results, as plain structs with their JSON mapping.
//
// Parameters are parsed and validated here (types, shapes, finiteness, limits) by
// parse_params(); ranges against a mesh (ids, samples) and everything needing server state are
// the server's checks. Results are filled by the server and serialized with to_json. Every
// query result carries `mesh` and `mesh_version` (an opaque string the server chooses, e.g. the
// graph file's checksum; it changes whenever the mesh's graph is replaced, so clients compare it
// for equality only). docs/protocol.md shows every message.
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

enum class FieldEncoding : std::uint8_t { Json, F32leBase64 };
std::string_view encoding_name(FieldEncoding encoding);  ///< "json", "f32le-base64"

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

/// A method's params, validated. Throws ProtocolError: InvalidParams (missing, mistyped, unknown
/// members), point reasons (BadPoint, BadBarycentric, ...), PathNotAllowed, TooLarge (limits).
/// `params` must be an object (parse_envelope() guarantees it). `timeout_ms`, if given, is
/// returned through `timeout_ms`.
Params parse_params(Method method, const nlohmann::json& params, const Limits& limits,
                    std::optional<std::int64_t>* timeout_ms = nullptr);

/// The params object of `params` (what a client sends); parse_params() reads it back equal.
void to_json(nlohmann::json& out, const Params& params);

// ---- Results ----

/// Unreachable points are an error (reason Unreachable), never a result, so `distance` is
/// always finite; to_json refuses a non-finite one (ProtocolError Internal).
struct DistanceResult {
  std::string mesh;
  std::string mesh_version;
  double distance = 0;
  WirePoint source;
  WirePoint target;
  bool exact = false;  ///< the answer is exact (not the graph's approximation)
};

struct PathPoint {
  std::uint32_t face = 0;
  std::array<double, 3> bary{1, 0, 0};
  std::array<double, 3> position{0, 0, 0};
};

/// From source to target; `distance` finite as in DistanceResult.
struct PathResult {
  std::string mesh;
  std::string mesh_version;
  double distance = 0;
  WirePoint source;
  WirePoint target;
  bool exact = false;
  std::vector<PathPoint> points;
};

/// One value per mesh vertex, in vertex order.
struct FieldResult {
  std::string mesh;
  std::string mesh_version;
  FieldEncoding encoding = FieldEncoding::Json;
  std::optional<double> cutoff;  ///< echoed
  /// +inf where not reached (beyond the cutoff or in another component): null in "json",
  /// +inf in "f32le-base64".
  std::vector<double> distances;
  /// Index into the request's sources of each vertex's nearest source, only with several
  /// sources (empty otherwise); kNotReached where not reached. null / 0xFFFFFFFF on the wire;
  /// "u32le-base64" with the f32le-base64 encoding.
  std::vector<std::uint32_t> nearest_source;
  static constexpr std::uint32_t kNotReached = 0xFFFFFFFF;
};

/// Row-major, sources x targets; +inf for an unreachable pair (null on the wire). Unlike
/// geodesic.distance, one unreachable pair does not fail the whole matrix; `unreachable` counts
/// them so a client cannot miss them.
struct MatrixResult {
  std::string mesh;
  std::string mesh_version;
  std::size_t source_count = 0;
  std::size_t target_count = 0;
  std::vector<double> distances;
};

enum class MeshState : std::uint8_t { Ready, Building, Failed };
std::string_view mesh_state_name(MeshState state);  ///< "ready", "building", "failed"

struct MeshSummary {
  std::string mesh;
  std::optional<std::string> mesh_version;  ///< null until a graph is loaded
  MeshState state = MeshState::Building;
  double progress = 0;               ///< of the current build, 0 to 1 (1 when ready)
  std::optional<std::string> phase;  ///< of the current build, e.g. "sampling"
  std::uint64_t vertices = 0;
  std::uint64_t faces = 0;
  std::optional<std::uint64_t> samples;  ///< once a graph is loaded
  std::optional<std::string> error;      ///< state "failed": why
};

struct MeshListResult {
  std::vector<MeshSummary> meshes;
};

struct MeshInfoResult {
  MeshSummary summary;
  std::uint64_t edges = 0;
  std::optional<std::uint64_t> graph_edges;
  std::string mesh_file;
  std::string graph_file;
  BuildOptions build;                     ///< the parameters the graph was (or is being) built with
  std::optional<double> covering_radius;  ///< the graph's r (its error bound grows with it)
  /// rho: where queries answer exactly, and the R of the bound 2r / (rho - 2r) (0: unknown)
  std::optional<double> link_radius;
};

struct ServerInfoResult {
  std::string server_version;
  Limits limits;
  bool admin_enabled = false;
  // protocol_version, methods and encodings are written by to_json from this header.
};

/// "ok" once serving (some meshes may still build), "starting" before the first mesh is ready,
/// "draining" after SIGTERM.
enum class HealthStatus : std::uint8_t { Ok, Starting, Draining };
std::string_view health_status_name(HealthStatus status);

struct HealthResult {
  HealthStatus status = HealthStatus::Ok;
  std::uint64_t meshes_ready = 0;
  std::uint64_t meshes_total = 0;
  double uptime_seconds = 0;
  std::uint64_t in_flight = 0;
  /// The server has a query token: other methods than server.health need server.auth first.
  bool auth_required = false;
};

/// A successful server.auth (a wrong token is the error Unauthorized).
struct ServerAuthResult {
  bool authenticated = true;
};

/// The Prometheus text exposition, as served on the admin port's /metrics.
struct MetricsResult {
  std::string text;
};

struct AdminUnregisterResult {
  std::string mesh;
};

struct ReloadOutcome {
  std::string mesh;
  bool reloaded = false;                    ///< false: the old graph stays in service
  std::optional<std::string> mesh_version;  ///< after the reload
  std::optional<ProtocolError> error;       ///< why it was not reloaded
};

struct AdminReloadResult {
  std::vector<ReloadOutcome> meshes;
};

/// Columns of equal length, in increasing vertex id: the vertices within the radius and their
/// (u, v) = d (cos theta, sin theta).
struct ExpmapResult {
  std::string mesh;
  std::string mesh_version;
  WirePoint source;
  double radius = 0;
  bool exact = false;
  std::vector<std::uint32_t> vertices;
  std::vector<double> u;
  std::vector<double> v;
};

struct SplineResult {
  std::string mesh;
  std::string mesh_version;
  SplineKind type = SplineKind::Bezier;
  bool exact = false;
  std::vector<PathPoint> points;                       ///< the curve, in order
  std::vector<std::vector<PathPoint>> control_polygon;  ///< geodesic i from control i to i + 1
};

/// The answers of a batch, one per entry in order: a result object or an error.
struct BatchResult {
  std::vector<std::variant<nlohmann::json, ProtocolError>> results;
};

void to_json(nlohmann::json& out, const DistanceResult& result);
void to_json(nlohmann::json& out, const PathResult& result);
void to_json(nlohmann::json& out, const PathPoint& point);
void to_json(nlohmann::json& out, const FieldResult& result);
void to_json(nlohmann::json& out, const MatrixResult& result);
void to_json(nlohmann::json& out, const MeshSummary& summary);
void to_json(nlohmann::json& out, const MeshListResult& result);
void to_json(nlohmann::json& out, const MeshInfoResult& result);
void to_json(nlohmann::json& out, const ServerInfoResult& result);
void to_json(nlohmann::json& out, const HealthResult& result);
void to_json(nlohmann::json& out, const ServerAuthResult& result);
void to_json(nlohmann::json& out, const MetricsResult& result);
void to_json(nlohmann::json& out, const AdminUnregisterResult& result);
void to_json(nlohmann::json& out, const AdminReloadResult& result);
void to_json(nlohmann::json& out, const BatchResult& result);
void to_json(nlohmann::json& out, const BuildOptions& build);
void to_json(nlohmann::json& out, const ExpmapResult& result);
void to_json(nlohmann::json& out, const SplineResult& result);

/// The reply line of a field result: byte for byte serialize_result(id, json(result)), but with
/// "f32le-base64" the base64 strings go straight into the line instead of through a JSON
/// document (no copy, no escaping pass; base64 needs none). Fields are the large replies.
std::string serialize_field_result(const RequestId& id, const FieldResult& result);

}  // namespace geoprox::protocol
