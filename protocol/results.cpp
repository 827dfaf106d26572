// Results to JSON (and the field result's own serialisation, written without a JSON tree).
#include "protocol/results.h"

#include <cmath>

#include "protocol/base64.h"
#include "protocol/json_rpc.h"

namespace geoprox::protocol {

using nlohmann::json;

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

void to_json(json& out, const WirePathPoint& point) {
  out = {{"face", point.face}, {"bary", point.bary}, {"position", point.position}};
  if (point.polygon) out["polygon"] = *point.polygon;
}

void to_json(json& out, const PathResult& result) {
  json points = json::array();
  for (const WirePathPoint& point : result.points) points.push_back(point);
  out = {{"mesh", result.mesh},
         {"mesh_version", result.mesh_version},
         {"distance", finite_distance(result.distance, "geodesic.path")},
         {"source", result.source},
         {"target", result.target},
         {"exact", result.exact},
         {"points", std::move(points)}};
}

namespace {

/// Distances in a base64 encoding (+inf stays +inf).
std::string encode_distances(FieldEncoding encoding, const std::vector<double>& distances) {
  if (encoding == FieldEncoding::F64leBase64) return encode_f64le_base64(distances);
  return encode_f32le_base64(std::span<const double>(distances));
}

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
  if (result.encoding != FieldEncoding::Json) {
    out["distances"] = encode_distances(result.encoding, result.distances);
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

std::string field_result_object(const FieldResult& result) {
  if (result.encoding == FieldEncoding::Json) return dump_one_line(json(result));
  const std::size_t reached = count_reached(result);
  const std::string distances = encode_distances(result.encoding, result.distances);
  const std::string nearest =
      result.nearest_source.empty() ? std::string() : encode_u32le_base64(result.nearest_source);
  // The members of to_json(FieldResult), in the alphabetical order nlohmann writes them.
  std::string text;
  text.reserve(distances.size() + nearest.size() + result.mesh.size() + result.mesh_version.size() +
               256);
  text += R"({"cutoff":)";
  text += dump_one_line(optional_json(result.cutoff));
  text += R"(,"distances":")";
  text += distances;
  text += R"(","encoding":")";
  text += encoding_name(result.encoding);
  text += R"(","mesh":)";
  text += dump_one_line(json(result.mesh));
  text += R"(,"mesh_version":)";
  text += dump_one_line(json(result.mesh_version));
  if (!nearest.empty()) {
    text += R"(,"nearest_source":")";
    text += nearest;
    text += '"';
  }
  text += R"(,"reached":)";
  text += std::to_string(reached);
  text += R"(,"vertices":)";
  text += std::to_string(result.distances.size());
  text += "}";
  return text;
}

std::string serialize_field_result(const RequestId& id, const FieldResult& result) {
  if (result.encoding == FieldEncoding::Json) return serialize_result(id, json(result));
  std::string line = R"({"jsonrpc":"2.0","id":)";
  line += id.json_text();
  line += R"(,"result":)";
  line += field_result_object(result);
  line += "}\n";
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
  if (result.encoding != FieldEncoding::Json) {
    std::size_t unreachable = 0;
    for (double distance : result.distances) unreachable += std::isfinite(distance) ? 0 : 1;
    out = {{"mesh", result.mesh},
           {"mesh_version", result.mesh_version},
           {"sources", result.source_count},
           {"targets", result.target_count},
           {"unreachable", unreachable},
           {"encoding", encoding_name(result.encoding)},
           {"distances", encode_distances(result.encoding, result.distances)}};
    return;
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

void to_json(json& out, const MeshRepairCounts& counts) {
  out = {{"vertices_in", counts.vertices_in},
         {"faces_in", counts.faces_in},
         {"vertices_out", counts.vertices_out},
         {"faces_out", counts.faces_out},
         {"degenerate_faces_dropped", counts.degenerate_faces_dropped},
         {"duplicate_faces_dropped", counts.duplicate_faces_dropped},
         {"edges_cut", counts.edges_cut},
         {"faces_flipped", counts.faces_flipped},
         {"vertices_split", counts.vertices_split},
         {"vertices_added", counts.vertices_added}};
}

void to_json(json& out, const MeshRefinement& refinement) {
  out = {{"vertices", refinement.vertices},
         {"faces", refinement.faces},
         {"max_edge_length", refinement.max_edge_length}};
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
  out["polygons"] = optional_json(result.polygons);
  out["repair"] = optional_json(result.repair);
  out["refined"] = optional_json(result.refined);
}

void to_json(json& out, const ServerInfoResult& result) {
  json methods = json::array();
  for (Method method : all_methods()) methods.push_back(method_name(method));
  out = {{"protocol_version", kProtocolVersion},
         {"server_version", result.server_version},
         {"limits", result.limits},
         {"encodings",
          {encoding_name(FieldEncoding::Json), encoding_name(FieldEncoding::F32leBase64),
           encoding_name(FieldEncoding::F64leBase64)}},
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
  for (const std::vector<WirePathPoint>& leg : result.control_polygon) polygon.push_back(leg);
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