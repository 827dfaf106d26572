// The results of the methods (protocol/params.h), as plain structs with their JSON mapping.
//
// Results are filled by the server and serialized with to_json. Every query result carries
// `mesh` and `mesh_version` (an opaque string the server chooses, e.g. the graph file's
// checksum; it changes whenever the mesh's graph is replaced, so clients compare it for equality
// only). docs/protocol.md shows every message.
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "protocol/errors.h"
#include "protocol/json_rpc.h"
#include "protocol/params.h"
#include "protocol/points.h"

namespace geoprox::protocol {

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

/// A point of a path on the wire: its face, barycentrics there, and position.
struct WirePathPoint {
  std::uint32_t face = 0;
  std::array<double, 3> bary{1, 0, 0};
  std::array<double, 3> position{0, 0, 0};
  /// The mesh file's polygon (face record) that `face` is a triangle of, when the file had
  /// polygons (written only then).
  std::optional<std::uint32_t> polygon;
};

/// From source to target; `distance` finite as in DistanceResult.
struct PathResult {
  std::string mesh;
  std::string mesh_version;
  double distance = 0;
  WirePoint source;
  WirePoint target;
  bool exact = false;
  std::vector<WirePathPoint> points;
};

/// One value per mesh vertex, in vertex order.
struct FieldResult {
  std::string mesh;
  std::string mesh_version;
  FieldEncoding encoding = FieldEncoding::Json;
  std::optional<double> cutoff;  ///< echoed
  /// +inf where not reached (beyond the cutoff or in another component): null in "json",
  /// +inf in "f32le-base64" and "f64le-base64".
  std::vector<double> distances;
  /// Index into the request's sources of each vertex's nearest source, only with several
  /// sources (empty otherwise); kNotReached where not reached. null / 0xFFFFFFFF on the wire;
  /// "u32le-base64" with the base64 encodings.
  std::vector<std::uint32_t> nearest_source;
  static constexpr std::uint32_t kNotReached = 0xFFFFFFFF;
};

/// Row-major, sources x targets; +inf for an unreachable pair (null in "json", +inf in
/// "f64le-base64", whose `distances` is one base64 string of the whole row-major matrix). Unlike
/// geodesic.distance, one unreachable pair does not fail the whole matrix; `unreachable` counts
/// them so a client cannot miss them.
struct MatrixResult {
  std::string mesh;
  std::string mesh_version;
  std::size_t source_count = 0;
  std::size_t target_count = 0;
  std::vector<double> distances;
  /// Json or F64leBase64; the result has an "encoding" member only when it is not Json.
  FieldEncoding encoding = FieldEncoding::Json;
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

/// What repair changed in a mesh file (the counts of core's MeshRepairReport).
struct MeshRepairCounts {
  std::uint64_t vertices_in = 0, faces_in = 0;
  std::uint64_t vertices_out = 0, faces_out = 0;
  std::uint64_t degenerate_faces_dropped = 0;  ///< faces that repeat a vertex index
  std::uint64_t duplicate_faces_dropped = 0;   ///< same three vertices as an earlier face
  std::uint64_t edges_cut = 0;       ///< edges with 3+ faces, or that no orientation fixes
  std::uint64_t faces_flipped = 0;   ///< faces turned round
  std::uint64_t vertices_split = 0;  ///< vertices whose faces formed several fans
  std::uint64_t vertices_added = 0;  ///< copies appended after the file's vertices
};

/// The refinement a graph was built on (the build refines long faces internally; queries stay
/// in the mesh's ids).
struct MeshRefinement {
  std::uint64_t vertices = 0, faces = 0;  ///< of the refined mesh the graph is over
  double max_edge_length = 0;             ///< its longest edge allowed (mesh units)
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
  /// Face records in the mesh file, when some of them were polygons split into triangles
  /// (`faces` counts the triangles).
  std::optional<std::uint64_t> polygons;
  /// What repair changed, when the mesh in service was loaded with repair (all zero when it
  /// needed none).
  std::optional<MeshRepairCounts> repair;
  /// When the graph is over a refinement of the mesh.
  std::optional<MeshRefinement> refined;
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
  std::vector<WirePathPoint> points;                       ///< the curve, in order
  std::vector<std::vector<WirePathPoint>> control_polygon;  ///< geodesic i from control i to i + 1
};

/// The answers of a batch, one per entry in order: a result object or an error.
struct BatchResult {
  std::vector<std::variant<nlohmann::json, ProtocolError>> results;
};

void to_json(nlohmann::json& out, const DistanceResult& result);
void to_json(nlohmann::json& out, const PathResult& result);
void to_json(nlohmann::json& out, const WirePathPoint& point);
void to_json(nlohmann::json& out, const FieldResult& result);
void to_json(nlohmann::json& out, const MatrixResult& result);
void to_json(nlohmann::json& out, const MeshSummary& summary);
void to_json(nlohmann::json& out, const MeshListResult& result);
void to_json(nlohmann::json& out, const MeshRepairCounts& counts);
void to_json(nlohmann::json& out, const MeshRefinement& refinement);
void to_json(nlohmann::json& out, const MeshInfoResult& result);
void to_json(nlohmann::json& out, const ServerInfoResult& result);
void to_json(nlohmann::json& out, const HealthResult& result);
void to_json(nlohmann::json& out, const ServerAuthResult& result);
void to_json(nlohmann::json& out, const MetricsResult& result);
void to_json(nlohmann::json& out, const AdminUnregisterResult& result);
void to_json(nlohmann::json& out, const AdminReloadResult& result);
void to_json(nlohmann::json& out, const BatchResult& result);
void to_json(nlohmann::json& out, const ExpmapResult& result);
void to_json(nlohmann::json& out, const SplineResult& result);

/// The field result object as compact JSON text: byte for byte dump_one_line(json(result)), but
/// with a base64 encoding the base64 strings go straight into the text instead of through a JSON
/// document (no copy, no escaping pass; base64 needs none). Fields are the large replies.
std::string field_result_object(const FieldResult& result);
/// The reply line of a field result (its `result` is field_result_object(result)).
std::string serialize_field_result(const RequestId& id, const FieldResult& result);

}  // namespace geoprox::protocol
