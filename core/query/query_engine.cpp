// The query engine's construction, snapping and the linking of query points to the graph.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "core/base/errors.h"
#include "core/base/quaternary_heap.h"
#include "core/query/query_engine.h"

namespace geoprox::detail {

namespace {

double bounding_box_diagonal(const TriangleMesh& mesh) {
  Vec3 lo{kInfinity, kInfinity, kInfinity}, hi{-kInfinity, -kInfinity, -kInfinity};
  for (const Vec3& p : mesh.positions()) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  return norm(hi - lo);
}

}  // namespace

QueryEngine::QueryEngine(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                         const ProximityGraphView& graph, const Options& options,
                         const QueryTuning& tuning)
    : mesh_(&mesh), geometry_(&geometry), graph_(graph), options_(options), tuning_(tuning) {
  if (graph.num_vertices != mesh.num_vertices()) {
    throw InvalidInput(ErrorCode::GraphMismatch,
                       "the graph was built for " + std::to_string(graph.num_vertices) +
                           " vertices, the mesh has " + std::to_string(mesh.num_vertices()));
  }
  if (graph.num_samples == 0)
    throw InvalidInput(ErrorCode::GraphMismatch, "the graph has no samples");
  link_radius_ = graph.link_radius;
  if (!(link_radius_ > 0)) {  // an imported graph: the radius a build would have chosen
    double area = 0;
    for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) area += geometry.face_area(f);
    link_radius_ = link_radius_for(area, graph.num_samples, graph.neighbors);
  }
  sample_of_vertex_.assign(mesh.num_vertices(), -1);
  sample_points_.reserve(graph.num_samples);
  for (std::uint32_t i = 0; i < graph.num_samples; ++i) {
    sample_of_vertex_[graph.sample_vertex[i]] = static_cast<std::int32_t>(i);
    sample_points_.push_back(SurfacePoint::vertex(graph.sample_vertex[i]));
  }
  sample_targets_.emplace(geometry, sample_points_);
  bbox_diagonal_ = bounding_box_diagonal(mesh);
  mean_edge_length_ = geometry.mean_edge_length();
  for (const double length : geometry.edge_lengths()) {
    longest_edge_length_ = std::max(longest_edge_length_, length);
  }
  // The work of a near disk (see solve_near): the median of a solve out to near_radius rho
  // from 15 samples taken at even steps of their order (not the first ones: farthest-point
  // sampling starts at the extremities).
  if (options_.refine_within > 0) {
    ExactGeodesicSolver solver(mesh, geometry);
    ExactGeodesicOptions bounded;
    bounded.max_distance = tuning::kNearRadius * link_radius_;
    std::vector<std::size_t> windows;
    const std::uint32_t n = graph.num_samples,
                        probes = std::min<std::uint32_t>(n, tuning::kNearProbeSamples);
    for (std::uint32_t k = 0; k < probes; ++k) {
      solver.solve(sample_points_[(2 * k + 1) * n / (2 * probes)], bounded);
      windows.push_back(solver.stats().windows_propagated);
    }
    std::nth_element(windows.begin(), windows.begin() + windows.size() / 2, windows.end());
    near_windows_ = std::max<std::size_t>(windows[windows.size() / 2], 1);
  }
  sample_positions_.reserve(graph.num_samples);
  for (std::uint32_t i = 0; i < graph.num_samples; ++i) {
    sample_positions_.push_back(mesh.position(graph.sample_vertex[i]));
  }
  choose_landmarks();
}

// The bidirectional search's landmarks, farthest-point on the graph: each next one is the
// sample farthest from those chosen (a sample no landmark reaches comes first: other components
// get theirs), starting from the sample farthest from sample 0. Landmarks on the graph's
// periphery bound the most pairs well. One Dijkstra search from each.
void QueryEngine::choose_landmarks() {
  const std::uint32_t n = graph_.num_samples;
  if (tuning_.search != GraphSearch::Bidirectional) return;
  landmarks_ = std::min({n, tuning_.search_landmarks, tuning::kSearchLandmarks});
  if (landmarks_ == 0) return;
  landmark_distance_.assign(static_cast<std::size_t>(n) * landmarks_, kInfinity);
  std::vector<double> distance(n), nearest_landmark(n, kInfinity);
  std::vector<HeapEntry> heap;
  auto dijkstra = [&](std::uint32_t from) {
    std::fill(distance.begin(), distance.end(), kInfinity);
    distance[from] = 0;
    heap.assign(1, HeapEntry{0.0, from, 0});
    while (!heap.empty()) {
      const HeapEntry top = quaternary_heap_pop(heap);
      if (top.key > distance[top.node]) continue;
      for (std::uint32_t e = graph_.edge_offsets[top.node]; e < graph_.edge_offsets[top.node + 1];
           ++e) {
        const std::uint32_t j = graph_.edge_target[e];
        const double through = top.key + graph_.edge_distance[e];
        if (through < distance[j]) {
          distance[j] = through;
          quaternary_heap_push(heap, HeapEntry{through, j, 0});
        }
      }
    }
  };
  auto farthest = [&](const std::vector<double>& from) {
    std::uint32_t best = 0;
    for (std::uint32_t i = 1; i < n; ++i) {
      if (from[i] > from[best]) best = i;
    }
    return best;
  };
  dijkstra(0);
  // Unreachable samples count as nearer than every reached one here: start in sample 0's part.
  for (double& d : distance) {
    if (d == kInfinity) d = -1;
  }
  std::uint32_t next = farthest(distance);
  for (std::uint32_t k = 0; k < landmarks_; ++k) {
    dijkstra(next);
    for (std::uint32_t i = 0; i < n; ++i) {
      landmark_distance_[static_cast<std::size_t>(i) * landmarks_ + k] = distance[i];
      nearest_landmark[i] = std::min(nearest_landmark[i], distance[i]);
    }
    next = farthest(nearest_landmark);
  }
}

QueryScratch QueryEngine::make_scratch() const {
  return QueryScratch(std::make_unique<QueryScratch::Impl>(*mesh_, *geometry_, graph_.num_samples));
}

SurfacePoint QueryEngine::sample_point(std::uint32_t sample) const {
  if (sample >= graph_.num_samples) {
    throw InvalidInput(ErrorCode::SampleOutOfRange,
                       "sample " + std::to_string(sample) + " out of range (the graph has " +
                           std::to_string(graph_.num_samples) + " samples)");
  }
  return sample_points_[sample];
}

SnapResult QueryEngine::snap(const Vec3& position) const {
  std::call_once(snap_index_once_,
                 [this] { snap_index_ = std::make_unique<ClosestPointIndex>(*mesh_); });
  const ClosestPointResult closest = snap_index_->closest(position);
  if (closest.distance > tuning::kSnapTolerance * bbox_diagonal_) {
    throw InvalidInput(ErrorCode::TooFarFromSurface,
                       "position is " + std::to_string(closest.distance) +
                           " from the surface, more than the tolerance " +
                           std::to_string(tuning::kSnapTolerance * bbox_diagonal_) + " (" +
                           std::to_string(tuning::kSnapTolerance) +
                           " of the bounding-box diagonal)");
  }
  return {closest.point, closest.position, closest.distance};
}

// ---------------------------------------------------------------------------------------------
// Linking (Algorithm 1, lines 1-6): every sample within the link radius, with its exact
// distance.

bool QueryEngine::link_by_covers(const SurfacePoint& p, Links& out) const {
  if (p.kind != SurfacePoint::Kind::Vertex) return false;
  const std::uint32_t begin = graph_.cover_offsets[p.id], end = graph_.cover_offsets[p.id + 1];
  if (begin == end) return false;  // no cover table (imported graph) or an uncovered vertex
  out.samples.clear();
  out.via.clear();
  out.region.clear();
  out.longest = 0;
  for (std::uint32_t c = begin; c < end; ++c) {
    const double d = graph_.cover_distance[c];
    out.samples.emplace_back(graph_.cover_sample[c], d);
    out.via.emplace_back(kDirect, 0.0);
    out.longest = std::max(out.longest, d);
  }
  return true;
}

double QueryEngine::mean_face_edge(std::uint32_t face) const {
  double edges = 0;
  for (std::uint32_t i = 0; i < 3; ++i) edges += geometry_->layout(3 * face + i).length;
  return edges / 3;
}

QueryEngine::LinkSolveRadius QueryEngine::link_solve_radius(const SurfacePoint& p) const {
  if (!(tuning_.link_solve_edges > 0)) return {link_radius_, link_radius_};
  const auto [face, bary] = p.in_face(*mesh_);
  const Vec2 q = geometry_->face_point(face, bary.data());
  double corners = 0;
  for (int i = 0; i < 3; ++i) {
    const Vec2 c = geometry_->face_corner(face, i);
    // At least out to the corners, so that some vertex is settled.
    corners = std::max(corners, std::hypot(q.x - c.x, q.y - c.y) * (1 + tuning::kRelativeSlack));
  }
  corners = std::min(corners, link_radius_);
  return {std::min(std::max(tuning_.link_solve_edges * mean_face_edge(face), corners),
                   link_radius_),
          corners};
}

// How far p links through the vertices `solver` settled around it: the distance of the
// link_solve_vertices-th nearest of those within r.radius (at least r.corners), or r.radius.
// It depends on p alone: a solve that went farther (out to rho) gives the same radius.
double QueryEngine::nearest_vertices_radius(const ExactGeodesicSolver& solver,
                                            const LinkSolveRadius& r, QueryScratch::Impl& s) const {
  const std::uint32_t n = tuning_.link_solve_vertices;
  if (n == 0) return r.radius;
  std::vector<double>& near = s.link_distances;
  near.clear();
  for (std::uint32_t v : solver.touched_vertices()) {
    const double d = solver.distance(v);
    if (d <= r.radius) near.push_back(d);
  }
  if (near.size() <= n) return r.radius;
  std::nth_element(near.begin(), near.begin() + (n - 1), near.end());
  return std::max(near[n - 1], r.corners);
}

bool QueryEngine::link_through_covers(const ExactGeodesicSolver& solver, double radius,
                                      QueryScratch::Impl& s, Links& out, const Links* base) const {
  if (graph_.cover_sample.empty()) return false;
  out.samples.clear();
  out.via.clear();
  out.longest = 0;
  if (++s.link_generation == 0) {
    std::fill(s.link_stamp.begin(), s.link_stamp.end(), 0);
    s.link_generation = 1;
  }
  if (base != nullptr) {  // start from these links, improve them
    out.samples = base->samples;
    out.via = base->via;
    for (std::uint32_t k = 0; k < out.samples.size(); ++k) {
      s.link_stamp[out.samples[k].first] = s.link_generation;
      s.link_slot[out.samples[k].first] = k;
    }
  }
  // Each settled vertex v offers d(p, v) + d(v, sample) for the samples in its cover row; the
  // best over v is within a fraction of an edge of d(p, sample) (the geodesic passes near some
  // settled vertex) and is the length of a real path.
  for (std::uint32_t v : solver.touched_vertices()) {
    const double dv = solver.distance(v);
    if (!(dv <= radius)) continue;
    for (std::uint32_t c = graph_.cover_offsets[v]; c < graph_.cover_offsets[v + 1]; ++c) {
      // Rows reach rho beyond v, so links reach up to rho plus the solve's radius: more
      // samples than the paper's disk, which shortens the graph paths of pairs just beyond rho.
      const double d = dv + static_cast<double>(graph_.cover_distance[c]);
      const std::uint32_t i = graph_.cover_sample[c];
      if (s.link_stamp[i] != s.link_generation) {
        s.link_stamp[i] = s.link_generation;
        s.link_slot[i] = static_cast<std::uint32_t>(out.samples.size());
        out.samples.emplace_back(i, d);
        out.via.emplace_back(v, dv);
      } else if (d < out.samples[s.link_slot[i]].second) {
        out.samples[s.link_slot[i]].second = d;
        out.via[s.link_slot[i]] = {v, dv};
      }
    }
  }
  for (const auto& [i, d] : out.samples) out.longest = std::max(out.longest, d);
  return !out.samples.empty();
}

bool QueryEngine::may_be_within_link_radius(const SurfacePoint& s, const SurfacePoint& t) const {
  if (!geometry_->lengths_are_chords()) return true;
  // The straight line is never longer than the geodesic when lengths are the embedding's.
  return norm(s.position(*mesh_) - t.position(*mesh_)) <=
         link_radius_ * (1 + tuning::kRelativeSlack);
}

void QueryEngine::solve_within_link_radius(const SurfacePoint& p, ExactGeodesicSolver& solver,
                                           const QueryInterrupt* interrupt) const {
  ExactGeodesicOptions bounded;
  bounded.max_distance = link_radius_;
  bounded.interrupt = interrupt;
  solver.solve(p, bounded);
}

// From p until `to` is settled, out to `radius` at most: only that point's distance (and path)
// is wanted. Where straight lines bound geodesics from below the solve is goal-directed
// (ExactGeodesicOptions::goal): it explores only the points x with d(p, x) + |x to| under the
// radius, or under the estimate of d(p, to) once there is one, an ellipse around the geodesic
// rather than a disk. Returns whether, when `to` lies beyond the radius, every point within the
// radius is final (no goal), so that the solve can link p.
bool QueryEngine::solve_towards(const SurfacePoint& p, const SurfacePoint& to, double radius,
                                ExactGeodesicSolver& solver,
                                const QueryInterrupt* interrupt) const {
  ExactGeodesicOptions bounded;
  bounded.max_distance = radius;
  bounded.stop_after_targets = 1;
  bounded.interrupt = interrupt;
  if (geometry_->lengths_are_chords()) bounded.goal = to.position(*mesh_);
  const GeodesicSource source{p, 0.0};
  solver.solve(std::span<const GeodesicSource>(&source, 1), std::span<const SurfacePoint>(&to, 1),
               bounded);
  return !bounded.goal;
}

// A bounded solve settles a little beyond its radius (out to the nearest window it did not
// store), by an amount that rounding decides: exact answers from it stop at rho, so that
// fields, matrices and point-to-point queries take the same ones.
double QueryEngine::link_by_solve(const SurfacePoint& p, ExactGeodesicSolver& solver,
                                  QueryScratch::Impl& s, Links& out,
                                  bool solved_to_link_radius) const {
  out.region.clear();
  const LinkSolveRadius radius = link_solve_radius(p);
  if (radius.radius < link_radius_ && !graph_.cover_sample.empty()) {
    if (!solved_to_link_radius) {
      ExactGeodesicOptions bounded;
      bounded.max_distance = radius.radius;
      bounded.interrupt = s.interrupt;
      // The nearest vertices are all the linking needs (nearest_vertices_radius).
      bounded.stop_after_vertices = tuning_.link_solve_vertices;
      bounded.min_distance = radius.corners;
      solver.solve(p, bounded);
    }
    if (link_through_covers(solver, nearest_vertices_radius(solver, radius, s), s, out)) {
      return link_radius_;
    }
    // No sample within rho through the covers (a sparse spot): link as below.
  }
  out.samples.clear();
  out.via.clear();
  out.longest = 0;
  if (!solved_to_link_radius || solver.radius_reached() < link_radius_) {
    solve_within_link_radius(p, solver, s.interrupt);
  }
  for (std::uint32_t v : solver.touched_vertices()) {
    const std::int32_t sample = sample_of_vertex_[v];
    if (sample < 0) continue;
    const double d = solver.distance(v);  // finite only within the final radius
    if (d < kInfinity) {
      out.samples.emplace_back(static_cast<std::uint32_t>(sample), d);
      out.via.emplace_back(kDirect, 0.0);
      out.longest = std::max(out.longest, d);
    }
  }
  if (out.samples.empty()) {
    // No sample within rho (a sparse spot): link to the nearest one instead.
    ExactGeodesicOptions nearest;
    nearest.stop_after_targets = 1;
    nearest.interrupt = s.interrupt;
    const GeodesicSource source{p, 0.0};
    solver.solve(std::span<const GeodesicSource>(&source, 1), *sample_targets_, nearest);
    for (std::size_t k = 0; k < solver.settled_targets().size(); ++k) {
      const double d = solver.settled_target_distances()[k];
      out.samples.emplace_back(solver.settled_targets()[k], d);
      out.via.emplace_back(kDirect, 0.0);
      out.longest = std::max(out.longest, d);
    }
    return kInfinity;
  }
  return link_radius_;
}

double QueryEngine::link_solved(const SurfacePoint& p, ExactGeodesicSolver& solver,
                                QueryScratch::Impl& s, Links& out) const {
  return link_by_covers(p, out) ? link_radius_ : link_by_solve(p, solver, s, out, true);
}

std::vector<PathPoint> QueryEngine::exact_piece(const SurfacePoint& from, const SurfacePoint& to,
                                                double length, ExactGeodesicSolver& solver,
                                                const QueryInterrupt* interrupt) const {
  solve_towards(from, to, length * (1 + tuning::kRelativeSlack) + 1e-300, solver, interrupt);
  return solver.path_to(to).points;
}

}  // namespace geoprox::detail
