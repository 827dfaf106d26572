#include "server/service.h"

#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>
#include <new>
#include <nlohmann/json.hpp>
#include <variant>

#include "core/apps/exponential_map.h"
#include "core/query/geodesic_query.h"
#include "core/apps/geodesic_spline.h"
#include "core/mesh/mesh_repair.h"
#include "core/mesh/surface_point.h"

namespace geoprox::server {

namespace fs = std::filesystem;
using nlohmann::json;
using protocol::ErrorReason;
using protocol::ProtocolError;
using protocol::WirePoint;

namespace {

template <class... Ts>
struct Overloaded : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;

/// The protocol reason of an InvalidInput: point reasons keep their name, positions that cannot
/// be snapped and unreadable point text are BadPoint, any other reason is InvalidParams.
ErrorReason invalid_input_reason(ErrorCode code) {
  switch (code) {
    case ErrorCode::VertexOutOfRange:
      return ErrorReason::VertexOutOfRange;
    case ErrorCode::EdgeOutOfRange:
      return ErrorReason::EdgeOutOfRange;
    case ErrorCode::FaceOutOfRange:
      return ErrorReason::FaceOutOfRange;
    case ErrorCode::SampleOutOfRange:
      return ErrorReason::SampleOutOfRange;
    case ErrorCode::IsolatedVertex:
      return ErrorReason::IsolatedVertex;
    case ErrorCode::BadBarycentric:
      return ErrorReason::BadBarycentric;
    case ErrorCode::BadEdgeParameter:
      return ErrorReason::BadEdgeParameter;
    case ErrorCode::BadPoint:
    case ErrorCode::BadPosition:
    case ErrorCode::TooFarFromSurface:
    case ErrorCode::BadPointSyntax:
      return ErrorReason::BadPoint;
    default: return ErrorReason::InvalidParams;
  }
}

/// The mesh in service for `id`, or the error saying why there is none.
std::shared_ptr<const LoadedMesh> acquire(const Registry& registry, const Config& config,
                                          const std::string& id, RequestContext& context) {
  auto entry = registry.find(id);
  if (!entry) {
    throw ProtocolError(ErrorReason::UnknownMesh,
                        "params.mesh: no mesh " + quote(id) + " (mesh.list lists them)");
  }
  context.mesh = id;
  if (auto loaded = entry->loaded()) return loaded;
  const MeshStatus status = entry->status();
  if (status.loaded) return status.loaded;
  if (status.state == protocol::MeshState::Building) {
    char progress[32];
    std::snprintf(progress, sizeof progress, "%.0f%%", 100 * status.progress);
    throw ProtocolError(ErrorReason::MeshNotReady,
                        "mesh " + quote(id) + " is building (" + progress +
                            (status.phase ? ", " + *status.phase : std::string()) + ")")
        .set_retry_after_ms(config.not_ready_retry_after_ms);
  }
  throw ProtocolError(ErrorReason::MeshBuildFailed,
                      "mesh " + quote(id) + " has no graph: " +
                          status.error.value_or("unknown error") + " (mesh.list has the error)");
}

/// A wire point as a point of the mesh, checked against it; errors name `path`.
SurfacePoint resolve(const WirePoint& w, const LoadedMesh& m, const std::string& path) {
  try {
    SurfacePoint p;
    switch (w.kind) {
      case WirePoint::Kind::Vertex:
        p = SurfacePoint::vertex(w.id);
        break;
      case WirePoint::Kind::Edge:
        p = SurfacePoint::edge(w.id, w.t);
        break;
      case WirePoint::Kind::Face:
        p = SurfacePoint::face(w.id, w.bary[0], w.bary[1], w.bary[2]);
        break;
      case WirePoint::Kind::Sample:
        p = m.query().sample_point(w.id);
        break;
      case WirePoint::Kind::Position:
        p = m.query().snap(Vec3{w.position[0], w.position[1], w.position[2]}).point;
        break;
    }
    p.validate(m.mesh());
    if (p.kind == SurfacePoint::Kind::Vertex && m.mesh().is_isolated_vertex(p.id)) {
      throw InvalidInput(
          ErrorCode::IsolatedVertex,
          "vertex " + std::to_string(p.id) + " belongs to no face, so no geodesic reaches it");
    }
    return p;
  } catch (const InvalidInput& e) {
    // Translation only (adds the parameter's name); the request boundary catches the rest.
    throw ProtocolError(invalid_input_reason(e.code()), path + ": " + e.what());
  }
}

std::string indexed(const char* name, std::size_t i, std::size_t count, const char* single) {
  if (count == 1 && single) return std::string("params.") + single;
  return std::string("params.") + name + "[" + std::to_string(i) + "]";
}

/// Leases a scratch and arms the request's interrupt on it.
LoadedMesh::Lease lease_for(const LoadedMesh& mesh, RequestContext& context) {
  context.interrupt.check();  // the deadline may have passed in the queue
  LoadedMesh::Lease lease = mesh.lease();
  lease.scratch().set_interrupt(&context.interrupt);
  return lease;
}

/// The fewest bytes one distance takes in a reply: a digit and a comma in JSON, the base64 of
/// 4 or 8 bytes (5 or 10 characters, rounded down) in the binary encodings.
std::size_t bytes_per_value(protocol::FieldEncoding encoding) {
  switch (encoding) {
    case protocol::FieldEncoding::Json:
      return 2;
    case protocol::FieldEncoding::F32leBase64:
      return 5;
    case protocol::FieldEncoding::F64leBase64:
      return 10;
  }
  return 2;
}

void check_output(std::size_t min_bytes, const protocol::Limits& limits, const char* what) {
  if (min_bytes > limits.max_output_bytes) {
    throw ProtocolError(ErrorReason::TooLarge,
                        std::string(what) + " would take at least " + std::to_string(min_bytes) +
                            " bytes, more than max_output_bytes (" +
                            std::to_string(limits.max_output_bytes) + ")");
  }
}

protocol::DistanceResult run_distance(const protocol::DistanceParams& p, const LoadedMesh& m,
                                      RequestContext& context) {
  const SurfacePoint s = resolve(p.source, m, "params.source");
  const SurfacePoint t = resolve(p.target, m, "params.target");
  LoadedMesh::Lease lease = lease_for(m, context);
  protocol::DistanceResult r;
  r.mesh = context.mesh;
  r.mesh_version = m.version();
  r.source = p.source;
  r.target = p.target;
  // Exact: the exact solver, bounded by the graph's answer and goal-directed (GeodesicQuery).
  const DistanceResult d = p.exact ? m.query().exact_distance(s, t, lease.scratch())
                                   : m.query().distance(s, t, lease.scratch());
  r.distance = d.distance;
  r.exact = d.exact;
  return r;
}

/// A path point as a face point of the mesh in service, with the file's polygon of that face
/// when the file had polygons.
protocol::WirePathPoint to_wire_point(const PathPoint& point, const LoadedMesh& m) {
  const MeshData& data = m.data();
  const auto [face, bary] = point.point.in_face(data.mesh);
  protocol::WirePathPoint wire{face, bary, {point.position.x, point.position.y, point.position.z},
                               std::nullopt};
  if (!data.face_polygon.empty()) wire.polygon = data.face_polygon[face];
  return wire;
}

protocol::PathResult run_path(const protocol::PathParams& p, const LoadedMesh& m,
                              RequestContext& context) {
  const SurfacePoint s = resolve(p.source, m, "params.source");
  const SurfacePoint t = resolve(p.target, m, "params.target");
  LoadedMesh::Lease lease = lease_for(m, context);
  PathResult path = m.query().path(s, t, lease.scratch());
  protocol::PathResult r;
  r.mesh = context.mesh;
  r.mesh_version = m.version();
  r.source = p.source;
  r.target = p.target;
  r.distance = path.distance;
  r.exact = path.exact;
  r.points.reserve(path.points.size());
  for (const PathPoint& point : path.points) r.points.push_back(to_wire_point(point, m));
  return r;
}

protocol::FieldResult run_field(const protocol::FieldParams& p, const LoadedMesh& m,
                                RequestContext& context, const protocol::Limits& limits) {
  const std::size_t n = m.mesh().num_vertices();
  const bool several = p.sources.size() > 1;
  const std::size_t per_vertex = bytes_per_value(p.encoding);
  check_output(n * per_vertex * (several ? 2 : 1), limits, "the field");
  std::vector<SurfacePoint> sources;
  sources.reserve(p.sources.size());
  for (std::size_t i = 0; i < p.sources.size(); ++i) {
    sources.push_back(resolve(p.sources[i], m, indexed("sources", i, p.sources.size(), "source")));
  }
  LoadedMesh::Lease lease = lease_for(m, context);
  DistanceFieldOptions options;
  options.threads = 1;  // the compute pool is the parallelism
  if (p.cutoff) options.max_distance = *p.cutoff;
  DistanceField field = m.query().field(sources, lease.scratch(), options);
  protocol::FieldResult r;
  r.mesh = context.mesh;
  r.mesh_version = m.version();
  r.encoding = p.encoding;
  r.cutoff = p.cutoff;
  r.distances = std::move(field.distances);
  if (several) {
    r.nearest_source.resize(field.nearest_source.size());
    for (std::size_t v = 0; v < field.nearest_source.size(); ++v) {
      const std::int32_t k = field.nearest_source[v];
      r.nearest_source[v] = k < 0 || !std::isfinite(r.distances[v])
                                ? protocol::FieldResult::kNotReached
                                : static_cast<std::uint32_t>(k);
    }
  }
  return r;
}

protocol::MatrixResult run_matrix(const protocol::MatrixParams& p, const LoadedMesh& m,
                                  RequestContext& context, const protocol::Limits& limits) {
  check_output(p.sources.size() * p.targets.size() * bytes_per_value(p.encoding), limits,
               "the matrix");
  std::vector<SurfacePoint> sources, targets;
  sources.reserve(p.sources.size());
  targets.reserve(p.targets.size());
  for (std::size_t i = 0; i < p.sources.size(); ++i) {
    sources.push_back(resolve(p.sources[i], m, indexed("sources", i, 0, nullptr)));
  }
  for (std::size_t i = 0; i < p.targets.size(); ++i) {
    targets.push_back(resolve(p.targets[i], m, indexed("targets", i, 0, nullptr)));
  }
  LoadedMesh::Lease lease = lease_for(m, context);
  protocol::MatrixResult r;
  r.mesh = context.mesh;
  r.mesh_version = m.version();
  r.source_count = sources.size();
  r.target_count = targets.size();
  r.encoding = p.encoding;
  r.distances = m.query().matrix(sources, targets, lease.scratch());
  return r;
}

protocol::ExpmapResult run_expmap(const protocol::ExpmapParams& p, const LoadedMesh& m,
                                  RequestContext& context) {
  const SurfacePoint source = resolve(p.source, m, "params.source");
  LoadedMesh::Lease lease = lease_for(m, context);
  ExponentialMap& map = lease.exponential_map();  // the slot's: buffers sized by the mesh
  ExponentialMapOptions options;
  options.radius = p.radius;
  options.mode = p.exact ? ExponentialMapMode::Exact : ExponentialMapMode::Graph;
  options.interrupt = &context.interrupt;
  const ExponentialMapResult map_result = map.compute(source, options);
  protocol::ExpmapResult r;
  r.mesh = context.mesh;
  r.mesh_version = m.version();
  r.source = p.source;
  r.radius = p.radius;
  r.exact = p.exact;
  r.vertices.reserve(map_result.vertices.size());
  r.u.reserve(map_result.vertices.size());
  r.v.reserve(map_result.vertices.size());
  for (const ExponentialMapVertex& e : map_result.vertices) {
    r.vertices.push_back(e.vertex);
    r.u.push_back(e.u);
    r.v.push_back(e.v);
  }
  return r;
}

protocol::SplineResult run_spline(const protocol::SplineParams& p, const LoadedMesh& m,
                                  RequestContext& context) {
  std::vector<SurfacePoint> control;
  control.reserve(p.control.size());
  for (std::size_t i = 0; i < p.control.size(); ++i) {
    control.push_back(resolve(p.control[i], m, indexed("control", i, 0, nullptr)));
  }
  LoadedMesh::Lease lease = lease_for(m, context);
  GeodesicSpline& spline = lease.spline();  // the slot's: buffers sized by the mesh
  GeodesicSplineOptions options;
  options.type = p.type == protocol::SplineKind::Bezier ? SplineType::Bezier : SplineType::BSpline;
  options.samples = p.samples;
  options.geodesics = p.exact ? SplineGeodesics::Exact : SplineGeodesics::Graph;
  options.interrupt = &context.interrupt;
  const GeodesicSplineResult curve = spline.compute(control, options);
  protocol::SplineResult r;
  r.mesh = context.mesh;
  r.mesh_version = m.version();
  r.type = p.type;
  r.exact = p.exact;
  r.points.reserve(curve.curve.size());
  for (const PathPoint& point : curve.curve) r.points.push_back(to_wire_point(point, m));
  for (const std::vector<PathPoint>& leg : curve.control_polygon) {
    std::vector<protocol::WirePathPoint> wire;
    wire.reserve(leg.size());
    for (const PathPoint& point : leg) wire.push_back(to_wire_point(point, m));
    r.control_polygon.push_back(std::move(wire));
  }
  return r;
}

protocol::SamplingMethod to_wire(SamplingMethod s) {
  switch (s) {
    case SamplingMethod::FastMarching:
      return protocol::SamplingMethod::Fmm;
    case SamplingMethod::Exact:
      return protocol::SamplingMethod::Exact;
    case SamplingMethod::Automatic:
      break;
  }
  return protocol::SamplingMethod::Auto;
}

protocol::MeshRepairCounts to_wire(const MeshRepairReport& report) {
  return {report.vertices_in,
          report.faces_in,
          report.vertices_out,
          report.faces_out,
          report.degenerate_faces_dropped,
          report.duplicate_faces_dropped,
          report.edges_cut,
          report.faces_flipped,
          report.vertices_split,
          report.vertices_added};
}

std::string display_path(const fs::path& path, const fs::path& data_dir) {
  const fs::path rel = path.lexically_relative(data_dir);
  if (!rel.empty() && *rel.begin() != "..") return rel.generic_string();
  return path.generic_string();
}

}  // namespace

bool constant_time_equal(std::string_view a, std::string_view b) {
  // Runs over b's length whatever a is; differences in length or content both count.
  volatile unsigned char diff = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < b.size(); ++i) {
    const unsigned char x = a.empty() ? 0 : static_cast<unsigned char>(a[i % a.size()]);
    diff = static_cast<unsigned char>(diff | (x ^ static_cast<unsigned char>(b[i])));
  }
  return diff == 0 && !b.empty();
}

ProtocolError current_error(bool draining) {
  try {
    throw;
  } catch (const ProtocolError& e) {
    return e;
  } catch (const Interrupted& e) {
    if (e.code() == ErrorCode::Cancelled) {
      if (draining) {
        return ProtocolError(ErrorReason::ShuttingDown,
                             "the server is shutting down; the request was cancelled");
      }
      return ProtocolError(ErrorReason::DeadlineExceeded, "the request was cancelled");
    }
    return ProtocolError(ErrorReason::DeadlineExceeded,
                         "the request ran past its deadline (timeout_ms; server.info gives the "
                         "default and the maximum)");
  } catch (const geoprox::Unreachable& e) {
    return ProtocolError(ErrorReason::Unreachable, e.what());
  } catch (const InvalidInput& e) {
    return ProtocolError(invalid_input_reason(e.code()), e.what());
  } catch (const geoprox::ResourceExhausted& e) {
    return ProtocolError(ErrorReason::ResourceExhausted, e.what());
  } catch (const geoprox::Error& e) {
    return ProtocolError(ErrorReason::Internal, describe_exception(e));
  } catch (const std::bad_alloc&) {
    return ProtocolError(ErrorReason::ResourceExhausted, "out of memory while answering");
  } catch (const std::exception& e) {
    return ProtocolError(ErrorReason::Internal, std::string("unexpected failure: ") + e.what());
  } catch (...) {
    return ProtocolError(ErrorReason::Internal, "unexpected failure (non-standard exception)");
  }
}

Service::Service(const Config& config, Registry& registry, Metrics& metrics, ServerState& state)
    : config_(config), registry_(registry), metrics_(metrics), state_(state) {}

bool Service::answered_inline(protocol::Method method) {
  switch (method) {
    case protocol::Method::MeshList:
    case protocol::Method::MeshInfo:
    case protocol::Method::ServerInfo:
    case protocol::Method::ServerHealth:
    case protocol::Method::ServerMetrics:
    case protocol::Method::ServerAuth:
      return true;
    default:
      return false;
  }
}

Answer Service::refuse(const protocol::Call& call, const ProtocolError& error) {
  Answer a;
  a.error = error.reason();
  if (call.id) a.line = protocol::serialize_error(*call.id, error);
  return a;
}

Answer Service::answer(const protocol::Call& call, RequestContext& context) const noexcept {
  Outcome outcome = evaluate(call, context);
  Answer a;
  if (!outcome.error) {
    try {
      const protocol::RequestId id = call.id.value_or(protocol::RequestId());
      if (outcome.field) {
        a.line = protocol::serialize_field_result(id, *outcome.field);
      } else if (outcome.matrix) {
        a.line = protocol::serialize_result(id, json(*outcome.matrix));
      } else {
        a.line = protocol::serialize_result(id, outcome.result);
      }
      if (a.line.size() > config_.limits.max_output_bytes) {
        throw ProtocolError(ErrorReason::TooLarge,
                            "the reply takes " + std::to_string(a.line.size()) +
                                " bytes, more than max_output_bytes (" +
                                std::to_string(config_.limits.max_output_bytes) + ")");
      }
      if (!call.id) a.line.clear();
      return a;
    } catch (...) {
      outcome.error = current_error(state_.draining.load());
    }
  }
  a.error = outcome.error->reason();
  a.line.clear();
  if (call.id) {
    try {
      a.line = protocol::serialize_error(*call.id, *outcome.error);
    } catch (...) {
      a.line = "{\"jsonrpc\":\"2.0\",\"id\":null,\"error\":{\"code\":-32603,\"data\":{"
               "\"reason\":\"Internal\",\"retryable\":true},\"message\":\"out of memory\"}}\n";
    }
  }
  return a;
}

Outcome Service::evaluate(const protocol::Call& call, RequestContext& context) const noexcept {
  Outcome outcome;
  try {
    // The request boundary: whatever fails below becomes this request's error.
    if (const auto* field = std::get_if<protocol::FieldParams>(&call.params)) {
      auto mesh = acquire(registry_, config_, field->mesh, context);
      outcome.field = run_field(*field, *mesh, context, config_.limits);
    } else if (const auto* matrix = std::get_if<protocol::MatrixParams>(&call.params)) {
      auto mesh = acquire(registry_, config_, matrix->mesh, context);
      outcome.matrix = run_matrix(*matrix, *mesh, context, config_.limits);
    } else {
      outcome.result = execute(call.params, context);
    }
  } catch (...) {
    outcome.error = current_error(state_.draining.load());
  }
  return outcome;
}

MeshGeometry Service::geometry(const std::string& id, RequestContext& context) const {
  auto mesh = acquire(registry_, config_, id, context);
  const TriangleMesh& surface = mesh->mesh();
  check_output(surface.num_vertices() * 3 * sizeof(float) +
                   surface.num_faces() * 3 * sizeof(std::uint32_t),
               config_.limits, "the geometry");
  MeshGeometry g;
  g.mesh = id;
  g.mesh_version = mesh->version();
  g.positions.reserve(3 * surface.num_vertices());
  for (const Vec3& p : surface.positions()) {
    g.positions.insert(g.positions.end(), {p.x, p.y, p.z});
  }
  g.triangles.reserve(3 * surface.num_faces());
  for (const auto& t : surface.faces()) g.triangles.insert(g.triangles.end(), {t[0], t[1], t[2]});
  return g;
}

json Service::execute(const protocol::Params& params, RequestContext& context) const {
  return std::visit(
      Overloaded{
          [&](const protocol::DistanceParams& p) -> json {
            auto mesh = acquire(registry_, config_, p.mesh, context);
            return run_distance(p, *mesh, context);
          },
          [&](const protocol::PathParams& p) -> json {
            auto mesh = acquire(registry_, config_, p.mesh, context);
            return run_path(p, *mesh, context);
          },
          [&](const protocol::FieldParams& p) -> json {
            auto mesh = acquire(registry_, config_, p.mesh, context);
            return run_field(p, *mesh, context, config_.limits);
          },
          [&](const protocol::MatrixParams& p) -> json {
            auto mesh = acquire(registry_, config_, p.mesh, context);
            return run_matrix(p, *mesh, context, config_.limits);
          },
          [&](const protocol::ExpmapParams& p) -> json {
            auto mesh = acquire(registry_, config_, p.mesh, context);
            return run_expmap(p, *mesh, context);
          },
          [&](const protocol::SplineParams& p) -> json {
            auto mesh = acquire(registry_, config_, p.mesh, context);
            return run_spline(p, *mesh, context);
          },
          [&](const protocol::BatchParams& p) -> json { return batch(p, context); },
          [&](const protocol::MeshListParams&) -> json {
            protocol::MeshListResult r;
            for (const auto& entry : registry_.entries()) {
              r.meshes.push_back(to_summary(entry->status()));
            }
            return r;
          },
          [&](const protocol::MeshInfoParams& p) -> json { return mesh_info(p, context); },
          [&](const protocol::ServerInfoParams&) -> json {
            protocol::ServerInfoResult r;
            r.server_version = GEOPROX_VERSION;
            r.limits = config_.limits;
            r.admin_enabled = !config_.admin_token.empty();
            return r;
          },
          [&](const protocol::ServerHealthParams&) -> json { return health(); },
          [&](const protocol::ServerAuthParams& p) -> json {
            // The connection keeps the outcome (server/connection.cpp); the token is never echoed.
            if (!query_token_matches(p.token)) {
              throw ProtocolError(ErrorReason::Unauthorized, "params.token: wrong query token");
            }
            return protocol::ServerAuthResult{};
          },
          [&](const protocol::ServerMetricsParams&) -> json {
            return protocol::MetricsResult{metrics_text()};
          },
          [&](const protocol::AdminRegisterParams& p) -> json {
            check_admin_token(p.token);
            context.mesh = p.mesh;
            return to_summary(registry_.register_mesh(p));
          },
          [&](const protocol::AdminRebuildParams& p) -> json {
            check_admin_token(p.token);
            context.mesh = p.mesh;
            return to_summary(registry_.rebuild(p.mesh, p.build));
          },
          [&](const protocol::AdminUnregisterParams& p) -> json {
            check_admin_token(p.token);
            context.mesh = p.mesh;
            registry_.unregister(p.mesh);
            return protocol::AdminUnregisterResult{p.mesh};
          },
          [&](const protocol::AdminReloadParams& p) -> json {
            check_admin_token(p.token);
            if (p.mesh) context.mesh = *p.mesh;
            protocol::AdminReloadResult r;
            r.meshes = reload(p.mesh);
            return r;
          },
      },
      params);
}

json Service::mesh_info(const protocol::MeshInfoParams& p, RequestContext& context) const {
  auto entry = registry_.find(p.mesh);
  if (!entry) {
    throw ProtocolError(ErrorReason::UnknownMesh,
                        "params.mesh: no mesh " + quote(p.mesh) +
                            " (mesh.list lists them)");
  }
  context.mesh = p.mesh;
  const MeshStatus s = entry->status();
  protocol::MeshInfoResult r;
  r.summary = to_summary(s);
  r.edges = s.edges;
  r.mesh_file = display_path(s.mesh_path, config_.data_dir);
  r.graph_file = display_path(s.graph_path, config_.data_dir);
  if (s.loaded) {
    const MeshData& data = s.loaded->data();
    if (!data.face_polygon.empty()) r.polygons = data.polygons;
    if (data.repair) r.repair = to_wire(*data.repair);
    if (const auto from = s.loaded->file().refined_from()) {
      r.refined = protocol::MeshRefinement{s.loaded->file().counts().vertices,
                                           s.loaded->file().counts().faces, from->max_edge_length};
    }
    const GraphFileParams fp = s.loaded->file().params();
    r.graph_edges = s.loaded->file().counts().graph_edges;
    r.covering_radius = s.loaded->file().covering_radius();
    r.link_radius = s.loaded->file().link_radius();
    r.build.samples = fp.num_samples;
    r.build.neighbors = fp.neighbors;
    r.build.sampling = to_wire(fp.sampling);
  } else {
    if (s.build.samples) r.build.samples = s.build.samples;
    if (s.build.neighbors) r.build.neighbors = s.build.neighbors;
    r.build.sampling = to_wire(s.build.sampling);
  }
  return r;
}

RequestContext Service::element_context(const RequestContext& outer,
                                        std::optional<std::int64_t> timeout_ms) const {
  RequestContext element;
  element.interrupt = outer.interrupt;
  if (timeout_ms) {
    const auto own = std::chrono::steady_clock::now() +
                     std::chrono::milliseconds(config_.limits.effective_timeout_ms(timeout_ms));
    if (own < element.interrupt.deadline) element.interrupt.deadline = own;
  }
  return element;
}

json Service::batch(const protocol::BatchParams& params, RequestContext& context) const {
  protocol::BatchResult result;
  result.results.reserve(params.requests.size());
  for (const protocol::BatchEntry& entry : params.requests) {
    context.interrupt.check();  // the batch's own deadline fails the whole batch
    if (entry.error) {
      result.results.emplace_back(*entry.error);
      continue;
    }
    RequestContext sub = element_context(context, entry.timeout_ms);
    try {
      if (!entry.params) throw ProtocolError(ErrorReason::Internal, "batch entry without params");
      result.results.emplace_back(execute(*entry.params, sub));
    } catch (...) {
      // Each entry is its own request boundary: its failure fills its slot only.
      ProtocolError error = current_error(state_.draining.load());
      if (error.reason() == ErrorReason::DeadlineExceeded) context.interrupt.check();
      result.results.emplace_back(std::move(error));
    }
    if (context.mesh.empty()) context.mesh = sub.mesh;
  }
  return result;
}

// ---- JSON-RPC 2.0 batch arrays ----

namespace {

/// What answer() replies when even its error reply cannot be built.
constexpr std::string_view kOutOfMemoryReply =
    "{\"jsonrpc\":\"2.0\",\"id\":null,\"error\":{\"code\":-32603,\"data\":{"
    "\"reason\":\"Internal\",\"retryable\":true},\"message\":\"out of memory\"}}\n";

const std::optional<protocol::RequestId>& id_of(
    const std::variant<protocol::Call, protocol::Rejection>& element) {
  if (const auto* call = std::get_if<protocol::Call>(&element)) return call->id;
  return std::get<protocol::Rejection>(element).id;
}

/// The elements of `batch` answered in order into one reply line: an element that is no valid
/// request with its own error, a call with `answer_call`, except the calls refused before
/// server.auth and server.auth itself. Every element is recorded in `metrics`.
template <class AnswerCall>
Answer reply_to_batch(const protocol::BatchCall& batch, bool authenticated, Transport transport,
                      Metrics& metrics, const protocol::Limits& limits, const ServerState& state,
                      AnswerCall&& answer_call) noexcept {
  using Clock = std::chrono::steady_clock;
  try {
    Answer reply;
    std::vector<std::string> lines;
    lines.reserve(batch.elements.size());
    std::size_t reply_bytes = 2;  // the brackets
    for (const auto& element : batch.elements) {
      const auto started = Clock::now();
      std::optional<protocol::Method> method;
      Answer answer;
      if (const auto* rejection = std::get_if<protocol::Rejection>(&element)) {
        method = protocol::method_from_name(rejection->method_name);
        // Before server.auth, even a malformed query learns nothing but Unauthorized.
        const bool refused_before_auth =
            !authenticated && method && !protocol::allowed_before_auth(*method);
        const ProtocolError error =
            refused_before_auth ? Service::unauthenticated_error(*method) : rejection->error;
        answer.error = error.reason();
        if (rejection->id) answer.line = protocol::serialize_error(*rejection->id, error);
      } else {
        const protocol::Call& call = std::get<protocol::Call>(element);
        method = call.method();
        if (!authenticated && !protocol::allowed_before_auth(*method)) {
          answer = Service::refuse(call, Service::unauthenticated_error(*method));
        } else if (*method == protocol::Method::ServerAuth) {
          answer = Service::refuse(
              call, ProtocolError(ErrorReason::InvalidRequest,
                                  "server.auth must be sent alone, not in a batch array"));
        } else {
          answer = answer_call(call);
        }
      }
      metrics.record_request(transport, method, answer.error,
                             std::chrono::duration<double>(Clock::now() - started).count());
      if (answer.error && (!reply.error || *answer.error == ErrorReason::Internal)) {
        reply.error = answer.error;
      }
      if (answer.line.empty()) continue;
      if (reply_bytes + answer.line.size() > limits.max_output_bytes) {
        // Each reply fits on its own; together they are bounded like one reply.
        answer.line = protocol::serialize_error(
            id_of(element).value_or(protocol::RequestId()),
            ProtocolError(ErrorReason::TooLarge,
                          "the replies of this batch array take more than max_output_bytes (" +
                              std::to_string(limits.max_output_bytes) + ")"));
        if (!reply.error) reply.error = ErrorReason::TooLarge;
      }
      reply_bytes += answer.line.size();
      lines.push_back(std::move(answer.line));
    }
    reply.line = protocol::serialize_batch_reply(lines);
    return reply;
  } catch (...) {
    // The boundary of the array: what fails outside its elements' own boundaries (memory for
    // the replies) is one error object, id null.
    const ProtocolError error = current_error(state.draining.load());
    Answer failed;
    failed.error = error.reason();
    try {
      failed.line = protocol::serialize_error(protocol::RequestId(), error);
    } catch (...) {
      failed.line = kOutOfMemoryReply;
    }
    return failed;
  }
}

}  // namespace

Answer Service::answer_batch(const protocol::BatchCall& batch, RequestContext& context,
                             bool authenticated, Transport transport) const noexcept {
  return reply_to_batch(
      batch, authenticated, transport, metrics_, config_.limits, state_,
      [&](const protocol::Call& call) {
        RequestContext element = element_context(context, call.timeout_ms);
        Answer reply = answer(call, element);
        if (context.mesh.empty()) context.mesh = std::move(element.mesh);
        return reply;
      });
}

Answer Service::refuse_batch(const protocol::BatchCall& batch, const ProtocolError& error,
                             bool authenticated, Transport transport) const noexcept {
  return reply_to_batch(batch, authenticated, transport, metrics_, config_.limits, state_,
                        [&](const protocol::Call& call) { return refuse(call, error); });
}

ProtocolError Service::unauthenticated_error(protocol::Method method) {
  return ProtocolError(ErrorReason::Unauthorized,
                       "this server needs server.auth with its query token before " +
                           std::string(protocol::method_name(method)) +
                           " (server.health says auth_required)");
}

std::vector<protocol::ReloadOutcome> Service::reload(const std::optional<std::string>& mesh) const {
  std::vector<protocol::ReloadOutcome> outcomes = registry_.reload(mesh);
  for (const auto& outcome : outcomes) {
    if (outcome.reloaded) {
      metrics_.reloads_ok.fetch_add(1);
    } else if (outcome.error) {
      metrics_.reloads_failed.fetch_add(1);
    }
  }
  return outcomes;
}

bool Service::query_token_matches(std::string_view token) const {
  if (config_.query_token.empty()) return true;
  return constant_time_equal(token, config_.query_token);
}

void Service::check_admin_token(const std::string& token) const {
  if (config_.admin_token.empty()) {
    throw ProtocolError(ErrorReason::Unauthorized,
                        "admin methods are disabled: the server has no admin token "
                        "(admin_token in the config or GEOPROX_ADMIN_TOKEN)");
  }
  if (token.empty() || !constant_time_equal(token, config_.admin_token)) {
    spdlog::warn("admin call refused: wrong or missing token");
    throw ProtocolError(ErrorReason::Unauthorized, "params.token: wrong or missing admin token");
  }
}

protocol::HealthResult Service::health() const {
  protocol::HealthResult h;
  h.meshes_total = registry_.size();
  h.meshes_ready = registry_.ready_count();
  h.in_flight = static_cast<std::uint64_t>(std::max<std::int64_t>(0, metrics_.in_flight.load()));
  h.uptime_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - state_.started).count();
  h.auth_required = query_token_required();
  if (state_.draining.load()) {
    h.status = protocol::HealthStatus::Draining;
  } else if (h.meshes_ready > 0 || h.meshes_total == 0) {
    h.status = protocol::HealthStatus::Ok;
  } else {
    h.status = protocol::HealthStatus::Starting;
  }
  return h;
}

bool Service::ready() const { return health().status == protocol::HealthStatus::Ok; }

std::pair<bool, std::string> Service::readiness() const {
  const protocol::HealthStatus status = health().status;
  if (status == protocol::HealthStatus::Ok) return {true, "ready\n"};
  return {false, "not ready: " + std::string(protocol::health_status_name(status)) + "\n"};
}

std::string Service::metrics_text() const {
  std::string out;
  out.reserve(8192);
  metrics_.render(out);
  const auto entries = registry_.entries();
  std::size_t n_ready = 0, building = 0, failed = 0;
  std::string per_mesh_ready, per_mesh_progress, per_mesh_scratch;
  for (const auto& entry : entries) {
    const MeshStatus s = entry->status();
    switch (s.state) {
      case protocol::MeshState::Ready:
        ++n_ready;
        break;
      case protocol::MeshState::Building:
        ++building;
        break;
      case protocol::MeshState::Failed:
        ++failed;
        break;
    }
    const std::string label = "{mesh=\"" + prometheus_label(s.id) + "\"}";
    per_mesh_ready += "geoprox_mesh_ready" + label + (s.loaded ? " 1\n" : " 0\n");
    char progress[32];
    std::snprintf(progress, sizeof progress, " %.4f\n", s.progress);
    per_mesh_progress += "geoprox_mesh_build_progress" + label + progress;
    if (s.loaded) {
      per_mesh_scratch += "geoprox_mesh_scratch_buffers" + label + " " +
                          std::to_string(s.loaded->scratch_created()) + "\n";
    }
  }
  out += "# HELP geoprox_meshes Registered meshes by state.\n# TYPE geoprox_meshes gauge\n";
  out += "geoprox_meshes{state=\"ready\"} " + std::to_string(n_ready) + "\n";
  out += "geoprox_meshes{state=\"building\"} " + std::to_string(building) + "\n";
  out += "geoprox_meshes{state=\"failed\"} " + std::to_string(failed) + "\n";
  out += "# HELP geoprox_mesh_ready 1 when the mesh has a graph in service.\n"
         "# TYPE geoprox_mesh_ready gauge\n" +
         per_mesh_ready;
  out += "# HELP geoprox_mesh_build_progress Progress of the current load or build (1: done).\n"
         "# TYPE geoprox_mesh_build_progress gauge\n" +
         per_mesh_progress;
  out += "# HELP geoprox_mesh_scratch_buffers Query scratch buffers allocated for the graph in "
         "service.\n# TYPE geoprox_mesh_scratch_buffers gauge\n" +
         per_mesh_scratch;
  char uptime[64];
  std::snprintf(uptime, sizeof uptime, "%.3f",
                std::chrono::duration<double>(std::chrono::steady_clock::now() - state_.started)
                    .count());
  out += "# HELP geoprox_uptime_seconds Seconds since the server started.\n"
         "# TYPE geoprox_uptime_seconds gauge\ngeoprox_uptime_seconds " +
         std::string(uptime) + "\n";
  out += "# HELP geoprox_ready 1 when the server is ready (a mesh is ready, not draining).\n"
         "# TYPE geoprox_ready gauge\ngeoprox_ready " +
         std::string(ready() ? "1" : "0") + "\n";
  return out;
}

}  // namespace geoprox::server
