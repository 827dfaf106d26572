#include "core/apps/exponential_map.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <queue>
#include <string>
#include <utility>

#include "core/geodesic/geodesic_tracing.h"
#include "core/graph/refined_surface.h"

namespace geoprox {

namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;

double wrap_angle(double a) {
  a = std::fmod(a, kTwoPi);
  if (a < 0) a += kTwoPi;
  return a >= kTwoPi ? 0 : a;
}

ExponentialMapVertex polar(std::uint32_t vertex, double distance, double angle) {
  return {vertex, distance, angle, distance * std::cos(angle), distance * std::sin(angle)};
}

}  // namespace

SurfacePoint canonical_surface_point(const TriangleMesh& mesh, const SurfacePoint& point) {
  point.validate(mesh);
  switch (point.kind) {
    case SurfacePoint::Kind::Vertex:
      if (mesh.is_isolated_vertex(point.id)) {
        throw InvalidInput(ErrorCode::IsolatedVertex,
                           "vertex " + std::to_string(point.id) +
                               " belongs to no face, so no geodesic reaches it");
      }
      return point;
    case SurfacePoint::Kind::Edge:
      if (point.t <= 0) return SurfacePoint::vertex(mesh.edge_origin(point.id));
      if (point.t >= 1) return SurfacePoint::vertex(mesh.edge_target(point.id));
      return point;
    case SurfacePoint::Kind::Face:
      break;
  }
  const std::uint32_t f = point.id;
  int zeros = 0, zero_corner = 0, largest = 0;
  for (int c = 0; c < 3; ++c) {
    if (point.bary[c] <= 0) {
      ++zeros;
      zero_corner = c;
    }
    if (point.bary[c] > point.bary[largest]) largest = c;
  }
  if (zeros >= 2) return SurfacePoint::vertex(mesh.face(f)[largest]);
  if (zeros == 0) {
    SurfacePoint normalized = point;
    normalize_barycentrics(normalized.bary);
    return normalized;
  }
  // On the edge opposite corner c: halfedge 3f + (c+1)%3, from corner (c+1)%3 to (c+2)%3.
  const int a = (zero_corner + 1) % 3, b = (zero_corner + 2) % 3;
  const std::uint32_t h = 3 * f + static_cast<std::uint32_t>(a);
  const std::uint32_t e = mesh.edge_of(h);
  const double along_b = point.bary[b] / (point.bary[a] + point.bary[b]);
  const double t = mesh.origin(h) == mesh.edge_origin(e) ? along_b : 1 - along_b;
  return SurfacePoint::edge(e, t);
}

// ---------------------------------------------------------------------------------------------
// Tangent frame

TangentFrame::TangentFrame(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                           const SurfacePoint& source)
    : mesh_(&mesh), geometry_(&geometry), source_(canonical_surface_point(mesh, source)) {
  switch (source_.kind) {
    case SurfacePoint::Kind::Face:
      face_ = source_.id;
      return;
    case SurfacePoint::Kind::Edge:
      face_ = TriangleMesh::face_of(mesh.edge_halfedge(source_.id));
      return;
    case SurfacePoint::Kind::Vertex:
      break;
  }
  const std::uint32_t v = source_.id;
  const auto outgoing = mesh.outgoing_halfedges(v);
  std::uint32_t start = outgoing[0];
  for (std::uint32_t h : outgoing) {
    if (mesh.twin(h) < 0) start = h;  // the fan starts at its boundary edge
  }
  // Counter-clockwise: from h = v->a to the halfedge v->c of the next face, twin(prev(h)).
  std::uint32_t h = start;
  double angle = 0;
  for (std::size_t k = 0; k < outgoing.size(); ++k) {
    fan_.push_back(h);
    fan_start_.push_back(angle);
    angle += geometry.corner_angle(h);
    const std::int32_t next = mesh.twin(TriangleMesh::prev(h));
    if (next < 0 || static_cast<std::uint32_t>(next) == start) break;
    h = static_cast<std::uint32_t>(next);
  }
  GEOPROX_ASSERT(fan_.size() == outgoing.size(), "the faces around a vertex form one fan");
  scale_ = mesh.is_boundary_vertex(v) || angle <= 0 ? 1.0 : kTwoPi / angle;
}

double TangentFrame::angle(const FaceDirection& direction) const {
  const TriangleMesh& mesh = *mesh_;
  if (source_.kind != SurfacePoint::Kind::Vertex) {
    FaceDirection d = direction;
    if (d.face != face_) {
      bool unfolded = false;
      for (std::uint32_t k = 0; k < 3 && !unfolded; ++k) {
        const std::int32_t twin = mesh.twin(3 * face_ + k);
        if (twin >= 0 && TriangleMesh::face_of(static_cast<std::uint32_t>(twin)) == d.face) {
          d = unfold_direction(mesh, *geometry_, static_cast<std::uint32_t>(twin), d);
          unfolded = true;
        }
      }
      if (!unfolded) {
        throw InvalidInput(ErrorCode::BadDirection,
                           "a direction in face " + std::to_string(d.face) + " does not start at " +
                               source_.to_string());
      }
    }
    return wrap_angle(std::atan2(d.y, d.x));
  }
  for (std::size_t i = 0; i < fan_.size(); ++i) {
    const std::uint32_t h = fan_[i];
    if (TriangleMesh::face_of(h) != direction.face) continue;
    const int corner = static_cast<int>(h % 3);
    const Vec2 a = geometry_->face_corner(direction.face, corner);
    const Vec2 b = geometry_->face_corner(direction.face, (corner + 1) % 3);
    const double ex = b.x - a.x, ey = b.y - a.y;
    double within = std::atan2(ex * direction.y - ey * direction.x,
                               ex * direction.x + ey * direction.y);
    // Directions along the wedge's sides come out a rounding error outside it.
    within = std::clamp(within, 0.0, geometry_->corner_angle(h));
    const double angle = (fan_start_[i] + within) * scale_;
    return mesh.is_boundary_vertex(source_.id) ? angle : wrap_angle(angle);
  }
  throw InvalidInput(ErrorCode::BadDirection,
                     "a direction in face " + std::to_string(direction.face) +
                         " does not start at vertex " + std::to_string(source_.id));
}

// ---------------------------------------------------------------------------------------------
// The map

namespace {

/// A query on the mesh a graph was built on, when that is a refinement of the query's mesh.
std::unique_ptr<GeodesicQuery> query_on_refinement(const GeodesicQuery& query) {
  const RefinedSurface* refined = query.refined();
  if (refined == nullptr) return nullptr;
  return std::make_unique<GeodesicQuery>(refined->mesh(), refined->geometry(), query.graph(),
                                         query.options());
}

}  // namespace

ExponentialMap::ExponentialMap(const GeodesicQuery& query)
    : refined_query_(query_on_refinement(query)),
      refined_(query.refined()),
      given_geometry_(&query.geometry()),
      mesh_(refined_ ? &refined_->mesh() : &query.mesh()),
      geometry_(refined_ ? &refined_->geometry() : &query.geometry()),
      query_(refined_query_ ? refined_query_.get() : &query),
      scratch_(std::make_unique<QueryScratch>(query_->make_scratch())),
      solver_(*mesh_, *geometry_) {}

ExponentialMap::ExponentialMap(const TriangleMesh& mesh, const IntrinsicGeometry& geometry)
    : mesh_(&mesh), geometry_(&geometry), solver_(mesh, geometry) {}

ExponentialMap::~ExponentialMap() = default;

ExponentialMapResult ExponentialMap::compute(const SurfacePoint& source, const Options& options) {
  if (std::isnan(options.radius) || options.radius < 0) {
    throw InvalidInput(ErrorCode::BadRadius,
                       "the radius of an exponential map must be a number >= 0");
  }
  if (options.mode == ExponentialMapMode::Graph && query_ == nullptr) {
    throw InvalidInput(ErrorCode::NoGraph,
                       "the graph mode of the exponential map needs a proximity graph");
  }
  const auto [computed_source, offset] = on_computed_mesh(source);
  const TangentFrame frame(*mesh_, *geometry_, computed_source);
  ExponentialMapResult out = options.mode == ExponentialMapMode::Exact
                                 ? compute_exact(frame.source(), frame, options)
                                 : compute_graph(frame.source(), frame, options);
  if (refined_ == nullptr) return out;
  // On the given mesh: its vertices (the refinement's first ones, with their ids) and its frame.
  const TriangleMesh& given = refined_->input();
  out.source = canonical_surface_point(given, source);
  std::erase_if(out.vertices, [&](const ExponentialMapVertex& v) {
    return v.vertex >= given.num_vertices();
  });
  for (ExponentialMapVertex& v : out.vertices) {
    if (offset == 0 || v.distance == 0) continue;
    v = polar(v.vertex, v.distance, wrap_angle(v.angle - offset));
  }
  return out;
}

std::pair<SurfacePoint, double> ExponentialMap::on_computed_mesh(
    const SurfacePoint& source) const {
  if (refined_ == nullptr) return {source, 0};
  const TriangleMesh& given = refined_->input();
  const SurfacePoint canonical = canonical_surface_point(given, source);
  const SurfacePoint computed = refined_->map().to_refined(canonical);
  // A boundary vertex's angle 0 is its boundary edge's direction on both meshes.
  if (canonical.kind == SurfacePoint::Kind::Vertex && given.is_boundary_vertex(canonical.id)) {
    return {computed, 0};
  }
  // The direction of the given frame's x axis in a face f holding the source (corner 0 to 1),
  // in the frame of the refined face g inside f that holds it too: both frames are the faces'
  // orthonormal in-plane frames (a refinement is of the mesh's own lengths).
  const auto [f, b] = canonical.in_face(given);
  const std::uint32_t g = refined_->map().to_refined(SurfacePoint::face(f, b[0], b[1], b[2])).id;
  const TangentFrame given_frame(given, *given_geometry_, canonical);
  const Vec3 u = given.position(given.face(f)[1]) - given.position(given.face(f)[0]);
  const TriangleMesh& fine = *mesh_;
  const Vec3 q0 = fine.position(fine.face(g)[0]);
  const Vec3 x = fine.position(fine.face(g)[1]) - q0, side = fine.position(fine.face(g)[2]) - q0;
  const Vec3 ex = (1 / norm(x)) * x;
  const Vec3 across = side - dot(side, ex) * ex;
  const Vec3 ey = (1 / norm(across)) * across;
  const double ux = dot(u, ex), uy = dot(u, ey), length = std::hypot(ux, uy);
  const TangentFrame computed_frame(fine, *geometry_, computed);
  const double offset = computed_frame.angle(FaceDirection{g, ux / length, uy / length}) -
                        given_frame.angle(FaceDirection{f, 1, 0});
  return {computed, offset};
}

namespace {


/// Angle of the exact path to `vertex` in a finished solve (0 at the source itself).
double exact_angle(const ExactGeodesicSolver& solver, const TangentFrame& frame,
                   std::uint32_t vertex, double distance) {
  if (distance == 0) return 0;
  return frame.angle(solver.path_to(SurfacePoint::vertex(vertex)).direction_at_source);
}

}  // namespace

ExponentialMapResult ExponentialMap::compute_exact(const SurfacePoint& source,
                                                   const TangentFrame& frame,
                                                   const Options& options) {
  ExactGeodesicOptions solve;
  solve.max_distance = options.radius;
  solve.interrupt = options.interrupt;
  solver_.solve(source, solve);
  std::vector<std::uint32_t> inside;
  for (std::uint32_t v : solver_.touched_vertices()) {
    if (solver_.distance(v) <= options.radius) inside.push_back(v);
  }
  std::sort(inside.begin(), inside.end());
  ExponentialMapResult out;
  out.source = source;
  out.vertices.reserve(inside.size());
  for (std::size_t k = 0; k < inside.size(); ++k) {
    if (options.interrupt && k % 256 == 255) options.interrupt->check();
    const double d = solver_.distance(inside[k]);
    out.vertices.push_back(polar(inside[k], d, exact_angle(solver_, frame, inside[k], d)));
  }
  return out;
}

// Graph labels from the linked samples; each sample remembers the first sample of its path at
// a positive distance from s (its root), or the graph edge that leaves s when s is a sample.
void ExponentialMap::label_samples(double rho, double radius, const QueryInterrupt* interrupt) {
  const ProximityGraphView& graph = query_->graph();
  const std::uint32_t ns = graph.num_samples;
  label_.assign(ns, kInfinity);
  root_.assign(ns, -1);
  root_edge_.assign(ns, -1);
  root_angle_.assign(ns, std::numeric_limits<double>::quiet_NaN());
  using Entry = std::pair<double, std::uint32_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> heap;
  for (std::uint32_t i = 0; i < ns; ++i) {
    const double d = solver_.distance(graph.sample_vertex[i]);
    if (d <= rho) {
      label_[i] = d;
      root_[i] = d > 0 ? static_cast<std::int32_t>(i) : -1;
      heap.emplace(d, i);
    }
  }
  std::size_t pops = 0;
  while (!heap.empty()) {
    const auto [key, i] = heap.top();
    heap.pop();
    if (interrupt && ++pops % 256 == 0) interrupt->check();
    if (key > radius) break;
    if (key > label_[i]) continue;
    for (std::uint32_t e = graph.edge_offsets[i]; e < graph.edge_offsets[i + 1]; ++e) {
      const std::uint32_t j = graph.edge_target[e];
      const double d = key + graph.edge_distance[e];
      if (d < label_[j]) {
        label_[j] = d;
        root_[j] = root_[i] >= 0 ? root_[i] : static_cast<std::int32_t>(j);
        root_edge_[j] = root_[i] >= 0 ? root_edge_[i] : static_cast<std::int32_t>(e);
        heap.emplace(d, j);
      }
    }
  }
}

// The exact region inside rho, the graph's labels beyond it, then every vertex's angle from the
// root of its path. Over 100 lines: the angle helpers are lambdas sharing this call's caches.
ExponentialMapResult ExponentialMap::compute_graph(const SurfacePoint& source,
                                                   const TangentFrame& frame,
                                                   const Options& options) {
  const ProximityGraphView& graph = query_->graph();
  const std::size_t nv = mesh_->num_vertices();
  const double rho = query_->link_radius();
  const double bound = std::min(rho, options.radius);
  const bool beyond = options.radius > bound;
  label_.clear();
  if (graph.cover_sample.empty()) {
    throw InvalidInput(ErrorCode::NoCoverTable,
                       "this graph has no per-vertex cover table (imported from the paper's text "
                       "format?): the graph mode of the exponential map needs a graph built by "
                       "geoprox");
  }

  // The exact region: a solve bounded by rho, whose paths give the angles inside rho and whose
  // distances to the samples link s to the graph.
  ExactGeodesicOptions solve;
  solve.max_distance = bound;
  solve.interrupt = options.interrupt;
  solver_.solve(source, solve);
  std::vector<double>& exact = exact_;
  exact.assign(nv, kInfinity);
  for (std::uint32_t v : solver_.touched_vertices()) {
    const double d = solver_.distance(v);
    if (d <= bound) exact[v] = d;
  }

  if (beyond) label_samples(rho, options.radius, options.interrupt);

  // A full exact solve from s, only when a direction is not known otherwise (a stored direction
  // that is unknown, or s being a sample whose cover reaches past rho).
  bool fallback_solved = false;
  auto fallback_angle = [&](std::uint32_t vertex) {
    if (!fallback_) fallback_ = std::make_unique<ExactGeodesicSolver>(*mesh_, *geometry_);
    if (!fallback_solved) {
      ExactGeodesicOptions full;
      full.max_distance = options.radius;  // graph distances are upper bounds of exact ones
      full.interrupt = options.interrupt;
      fallback_->solve(source, full);
      fallback_solved = true;
    }
    const double d = fallback_->distance(vertex);
    return d < kInfinity ? exact_angle(*fallback_, frame, vertex, d) : 0.0;
  };

  auto root_angle = [&](std::uint32_t root) {
    double& cached = root_angle_[root];
    if (!std::isnan(cached)) return cached;
    const std::uint32_t root_vertex = graph.sample_vertex[root];
    if (root_edge_[root] < 0) {
      cached = frame.angle(
          solver_.path_to(SurfacePoint::vertex(root_vertex)).direction_at_source);
    } else {
      const GraphDirection& stored =
          graph.edge_direction[static_cast<std::size_t>(root_edge_[root])];
      const double length = std::hypot(double{stored.x}, double{stored.y});
      cached = length > 0 ? frame.angle(FaceDirection{stored.face, stored.x / length,
                                                      stored.y / length})
                          : fallback_angle(root_vertex);
    }
    return cached;
  };

  // Distances: the graph's distance field (exact inside the link region, as every query).
  DistanceFieldOptions field_options;
  field_options.max_distance = options.radius;
  scratch_->set_interrupt(options.interrupt);
  const DistanceField field =
      query_->field(std::span<const SurfacePoint>(&source, 1), *scratch_, field_options);
  scratch_->set_interrupt(nullptr);

  ExponentialMapResult out;
  out.source = source;
  for (std::uint32_t v = 0; v < nv; ++v) {
    const double d = field.distances[v];
    if (!(d <= options.radius)) continue;
    if (exact[v] < kInfinity) {
      out.vertices.push_back(polar(v, d, exact_angle(solver_, frame, v, exact[v])));
      continue;
    }
    // The path's first sample: the root of v's best covering sample.
    double best = kInfinity;
    std::int32_t via = -1;
    for (std::uint32_t c = graph.cover_offsets[v]; c < graph.cover_offsets[v + 1]; ++c) {
      const std::uint32_t j = graph.cover_sample[c];
      const double through =
          label_.empty() ? kInfinity : label_[j] + static_cast<double>(graph.cover_distance[c]);
      if (through < best) {
        best = through;
        via = static_cast<std::int32_t>(j);
      }
    }
    const std::int32_t root = via >= 0 ? root_[static_cast<std::size_t>(via)] : -1;
    // No root: v is reached straight from s (a sample) through its cover row, or not through
    // the samples at all.
    const double angle =
        root >= 0 ? root_angle(static_cast<std::uint32_t>(root)) : fallback_angle(v);
    out.vertices.push_back(polar(v, d, angle));
  }
  return out;
}

ExponentialMapResult exponential_map(const GeodesicQuery& query, const SurfacePoint& source,
                                     const ExponentialMapOptions& options) {
  ExponentialMap map(query);
  return map.compute(source, options);
}

ExponentialMapResult exact_exponential_map(const TriangleMesh& mesh,
                                           const IntrinsicGeometry& geometry,
                                           const SurfacePoint& source, double radius) {
  ExponentialMap map(mesh, geometry);
  ExponentialMapOptions options;
  options.radius = radius;
  options.mode = ExponentialMapMode::Exact;
  return map.compute(source, options);
}

}  // namespace geoprox
