// Parameters back to JSON, as clients send them (the inverse of parse_params).
#include "protocol/params.h"

#include "protocol/points.h"

namespace geoprox::protocol {

using nlohmann::json;

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
  json out = {
      {"mesh", p.mesh}, {"sources", points_json(p.sources)}, {"targets", points_json(p.targets)}};
  if (p.encoding != FieldEncoding::Json) out["encoding"] = encoding_name(p.encoding);
  return out;
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
  if (p.repair) out["repair"] = true;
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

}  // namespace geoprox::protocol
