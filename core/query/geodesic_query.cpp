#include "core/query/geodesic_query.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <string>
#include <utility>

#include "core/base/errors.h"
#include "core/geodesic/geodesic_tracing.h"
#include "core/base/quaternary_heap.h"

namespace geoprox {

namespace {

struct HeapEntry {
  double key;
  std::uint32_t node;
  std::uint32_t side;  // 0: from s, 1: from t (meet-in-the-middle shares one heap)
};

double bounding_box_diagonal(const TriangleMesh& mesh) {
  Vec3 lo{kInfinity, kInfinity, kInfinity}, hi{-kInfinity, -kInfinity, -kInfinity};
  for (const Vec3& p : mesh.positions()) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  return norm(hi - lo);
}

constexpr std::int32_t kFromQueryPoint = -1;  // parent of a sample linked directly
constexpr std::uint32_t kDirect = UINT32_MAX;  // QueryLinks::via of a link not through a vertex
// A distance field's exact disk around each source, in link radii: fields are exact out to it,
// and every sample inside links the source to the graph. Its solve is most of a field's time;
// 2 (as point-to-point queries) buys little accuracy for its cost (docs/queries.md, "Distance
// fields and matrices").
constexpr double kFieldExactRadii = 1.75;

}  // namespace

// Links of one query point: its nearest samples with exact distances, and what its local solve
// found out about the other query point(s).
struct QueryLinks {
  std::vector<std::pair<std::uint32_t, double>> samples;
  /// Parallel to samples: the vertex a link passes through and the exact distance to it
  /// (links through covers), or {kDirect, 0} for a link straight from a solve or a cover row.
  std::vector<std::pair<std::uint32_t, double>> via;
  double longest = 0;
  /// The exact distances of the local solve to every vertex it settled (fields, near pairs).
  std::vector<std::pair<std::uint32_t, double>> region;
};

/// A point-to-point answer and where it came from (paths are rebuilt from it).
struct PairAnswer {
  enum class From : std::uint8_t {
    Graph,   ///< a search over the augmented graph; halves meet at sample `meet`
    SolveS,  ///< exact, from solver_s's solve from s
    SolveT,  ///< exact, from solver_t's solve from t
    Join,    ///< near pair: through `join_point`, in both solvers' disks
  };
  double distance = kInfinity;
  From from = From::Graph;
  std::uint32_t meet = UINT32_MAX;
  SurfacePoint join_point;
  std::uint32_t settled = 0;
};

struct QueryScratch::Impl {
  Impl(const TriangleMesh& mesh, const IntrinsicGeometry& geometry, std::uint32_t num_samples)
      : solver_s(mesh, geometry),
        solver_t(mesh, geometry),
        stamp(num_samples, 0),
        label{std::vector<double>(num_samples), std::vector<double>(num_samples)},
        parent{std::vector<std::int32_t>(num_samples), std::vector<std::int32_t>(num_samples)},
        parent_edge{std::vector<std::uint32_t>(num_samples),
                    std::vector<std::uint32_t>(num_samples)},
        settled_stamp{std::vector<std::uint32_t>(num_samples, 0),
                      std::vector<std::uint32_t>(num_samples, 0)},
        potential(num_samples),
        origin(num_samples),
        link_stamp(num_samples, 0),
        link_slot(num_samples, 0),
        join_stamp(mesh.num_vertices(), 0),
        join_distance(mesh.num_vertices()),
        join_edge_stamp(mesh.num_edges(), 0) {}

  // Lazily resets sample i's labels for this search.
  void touch(std::uint32_t i) {
    if (stamp[i] != generation) {
      stamp[i] = generation;
      label[0][i] = label[1][i] = kInfinity;
      parent[0][i] = parent[1][i] = kFromQueryPoint;
      potential[i] = kNoPotential;
    }
  }
  static constexpr double kNoPotential = -kInfinity;  ///< not computed yet in this search
  double get(int side, std::uint32_t i) const {
    return stamp[i] == generation ? label[side][i] : kInfinity;
  }
  bool is_settled(int side, std::uint32_t i) const {
    return settled_stamp[side][i] == generation;
  }
  void new_search() {
    if (++generation == 0) {
      std::fill(stamp.begin(), stamp.end(), 0);
      std::fill(settled_stamp[0].begin(), settled_stamp[0].end(), 0);
      std::fill(settled_stamp[1].begin(), settled_stamp[1].end(), 0);
      generation = 1;
    }
    heap[0].clear();
    heap[1].clear();
  }

  ExactGeodesicSolver solver_s, solver_t;
  std::uint32_t generation = 0;
  std::vector<std::uint32_t> stamp;
  std::vector<double> label[2];
  std::vector<std::int32_t> parent[2];        ///< previous sample, or kFromQueryPoint
  std::vector<std::uint32_t> parent_edge[2];  ///< graph edge it came through
  std::vector<std::uint32_t> settled_stamp[2];
  std::vector<double> potential;  ///< goal direction: p(i), kNoPotential until computed
  std::vector<std::uint32_t> origin;  ///< fields: which source's links the label comes from
  std::vector<double> dense_label;    ///< fields: every sample's label, kInfinity if untouched
  std::vector<GeodesicSource> field_sources;  ///< fields: the sources of the disks' solve
  std::vector<char> field_linked;     ///< fields: a source has a sample within rho
  std::vector<HeapEntry> heap[2];
  QueryLinks links_s, links_t;
  std::vector<QueryLinks> many;  ///< fields and matrices: one per point
  GeodesicTrace trace, trace_back;
  std::vector<PathPoint> piece;
  const QueryInterrupt* interrupt = nullptr;
  QueryScratch::RunBoth run_both;  ///< empty: one after the other
  Vec3 source_position, target_position;  ///< of the current point-to-point query
  std::uint32_t pops = 0;  ///< graph-search pops, for polling the interrupt
  /// Linking through covers: slot of sample i in the links being assembled, valid when
  /// link_stamp[i] == link_generation.
  std::uint32_t link_generation = 0;
  std::vector<std::uint32_t> link_stamp;
  std::vector<std::uint32_t> link_slot;
  std::vector<double> link_distances;  ///< nearest_vertices_radius: settled vertices' distances
  /// Joining two near points' disks: one side's distance at vertex v, valid when
  /// join_stamp[v] == join_generation.
  std::uint32_t join_generation = 0;
  std::vector<std::uint32_t> join_stamp;
  std::vector<double> join_distance;
  QueryLinks wide_s, wide_t;     ///< near pairs: wide links (see wide_links)
  std::vector<QueryLinks> wide;  ///< matrices: wide links of each target of a near pair
  std::vector<char> has_wide;    ///< parallel to `wide`: computed for this matrix
  std::vector<std::uint32_t> join_edges;  ///< join_disks: the edges it searches
  /// join_disks: long edges one disk crossed (== join_generation), to find those both did.
  std::vector<std::uint32_t> join_edge_stamp;

  void poll() {
    if (interrupt && (++pops & 255) == 0) interrupt->check();
  }
};

QueryScratch::QueryScratch(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
void QueryScratch::set_interrupt(const QueryInterrupt* interrupt) { impl_->interrupt = interrupt; }
void QueryScratch::set_run_both(RunBoth run_both) { impl_->run_both = std::move(run_both); }
QueryScratch::QueryScratch(QueryScratch&&) noexcept = default;
QueryScratch& QueryScratch::operator=(QueryScratch&&) noexcept = default;
QueryScratch::~QueryScratch() = default;

GeodesicQuery::GeodesicQuery(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                             const ProximityGraphView& graph, const Options& options)
    : mesh_(&mesh), geometry_(&geometry), graph_(graph), options_(options) {
  if (graph.num_vertices != mesh.num_vertices()) {
    throw InvalidInput(ErrorCode::GraphMismatch, "the graph was built for " +
                                            std::to_string(graph.num_vertices) +
                                            " vertices, the mesh has " +
                                            std::to_string(mesh.num_vertices()));
  }
  if (graph.num_samples == 0) throw InvalidInput(ErrorCode::GraphMismatch, "the graph has no samples");
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
  if (options_.near_radius > 0 && options_.refine_within > 0) {
    ExactGeodesicSolver solver(mesh, geometry);
    ExactGeodesicOptions bounded;
    bounded.max_distance = options_.near_radius * link_radius_;
    bounded.queue_halfedges = true;
    std::vector<std::size_t> windows;
    const std::uint32_t n = graph.num_samples, probes = std::min<std::uint32_t>(n, 15);
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
}

GeodesicQuery::~GeodesicQuery() = default;

QueryScratch GeodesicQuery::make_scratch() const {
  return QueryScratch(std::make_unique<QueryScratch::Impl>(*mesh_, *geometry_, graph_.num_samples));
}

SurfacePoint GeodesicQuery::sample_point(std::uint32_t sample) const {
  if (sample >= graph_.num_samples) {
    throw InvalidInput(ErrorCode::SampleOutOfRange, "sample " + std::to_string(sample) +
                                               " out of range (the graph has " +
                                               std::to_string(graph_.num_samples) + " samples)");
  }
  return sample_points_[sample];
}

SnapResult GeodesicQuery::snap(const Vec3& position) const {
  std::call_once(snap_index_once_,
                 [this] { snap_index_ = std::make_unique<ClosestPointIndex>(*mesh_); });
  const ClosestPointResult closest = snap_index_->closest(position);
  if (closest.distance > options_.snap_tolerance * bbox_diagonal_) {
    throw InvalidInput(ErrorCode::TooFarFromSurface,
                       "position is " + std::to_string(closest.distance) +
                           " from the surface, more than the tolerance " +
                           std::to_string(options_.snap_tolerance * bbox_diagonal_) + " (" +
                           std::to_string(options_.snap_tolerance) +
                           " of the bounding-box diagonal)");
  }
  return {closest.point, closest.position, closest.distance};
}

// ---------------------------------------------------------------------------------------------
// Linking (Algorithm 1, lines 1-6): every sample within the link radius, with its exact
// distance.

bool GeodesicQuery::link_by_covers(const SurfacePoint& p, Links& out) const {
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

double GeodesicQuery::mean_face_edge(std::uint32_t face) const {
  double edges = 0;
  for (std::uint32_t i = 0; i < 3; ++i) edges += geometry_->layout(3 * face + i).length;
  return edges / 3;
}

GeodesicQuery::LinkSolveRadius GeodesicQuery::link_solve_radius(const SurfacePoint& p) const {
  if (!(options_.link_solve_edges > 0)) return {link_radius_, link_radius_};
  const auto [face, bary] = p.in_face(*mesh_);
  const Vec2 q = geometry_->face_point(face, bary.data());
  double corners = 0;
  for (int i = 0; i < 3; ++i) {
    const Vec2 c = geometry_->face_corner(face, i);
    // At least out to the corners, so that some vertex is settled.
    corners = std::max(corners, std::hypot(q.x - c.x, q.y - c.y) * (1 + 1e-9));
  }
  corners = std::min(corners, link_radius_);
  return {std::min(std::max(options_.link_solve_edges * mean_face_edge(face), corners),
                   link_radius_),
          corners};
}

// How far p links through the vertices `solver` settled around it: the distance of the
// link_solve_vertices-th nearest of those within r.radius (at least r.corners), or r.radius.
// It depends on p alone: a solve that went farther (out to rho) gives the same radius.
double GeodesicQuery::nearest_vertices_radius(const ExactGeodesicSolver& solver,
                                              const LinkSolveRadius& r,
                                              QueryScratch::Impl& s) const {
  const std::uint32_t n = options_.link_solve_vertices;
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

bool GeodesicQuery::link_through_covers(const ExactGeodesicSolver& solver, double radius,
                                        QueryScratch::Impl& s, Links& out,
                                        const Links* base) const {
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

bool GeodesicQuery::may_be_within_link_radius(const SurfacePoint& s, const SurfacePoint& t) const {
  if (!geometry_->lengths_are_chords()) return true;
  // The straight line is never longer than the geodesic when lengths are the embedding's.
  return norm(s.position(*mesh_) - t.position(*mesh_)) <= link_radius_ * (1 + 1e-9);
}

void GeodesicQuery::solve_within_link_radius(const SurfacePoint& p, ExactGeodesicSolver& solver,
                                             const QueryInterrupt* interrupt) const {
  ExactGeodesicOptions bounded;
  bounded.max_distance = link_radius_;
  bounded.queue_halfedges = true;  // as wide as rho: 9% faster (docs/exact_geodesic.md)
  bounded.interrupt = interrupt;
  solver.solve(p, bounded);
}

// From p until `to` is settled, out to `radius` at most: only that point's distance (and path)
// is wanted. Where straight lines bound geodesics from below the solve is goal-directed
// (ExactGeodesicOptions::goal): it explores only the points x with d(p, x) + |x to| under the
// radius, or under the estimate of d(p, to) once there is one, an ellipse around the geodesic
// rather than a disk. Returns whether, when `to` lies beyond the radius, every point within the
// radius is final (no goal), so that the solve can link p.
bool GeodesicQuery::solve_towards(const SurfacePoint& p, const SurfacePoint& to, double radius,
                                  ExactGeodesicSolver& solver,
                                  const QueryInterrupt* interrupt) const {
  ExactGeodesicOptions bounded;
  bounded.max_distance = radius;
  bounded.stop_after_targets = 1;
  bounded.queue_halfedges = true;
  bounded.interrupt = interrupt;
  if (geometry_->lengths_are_chords()) bounded.goal = to.position(*mesh_);
  const GeodesicSource source{p, 0.0};
  solver.solve(std::span<const GeodesicSource>(&source, 1), std::span<const SurfacePoint>(&to, 1),
               bounded);
  return !bounded.goal;
}

namespace {

// A link solve's distance as point-to-point queries take it: exact out to `exact_within` (what
// link_by_solve returns), else none.
double exact_up_to(double d, double exact_within) { return d <= exact_within ? d : kInfinity; }

}  // namespace

// A bounded solve settles a little beyond its radius (out to the nearest window it did not
// store), by an amount that rounding decides: exact answers from it stop at rho, so that
// fields, matrices and point-to-point queries take the same ones.
double GeodesicQuery::link_by_solve(const SurfacePoint& p, ExactGeodesicSolver& solver,
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
      bounded.stop_after_vertices = options_.link_solve_vertices;
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

double GeodesicQuery::link_solved(const SurfacePoint& p, ExactGeodesicSolver& solver,
                                  QueryScratch::Impl& s, Links& out) const {
  return link_by_covers(p, out) ? link_radius_ : link_by_solve(p, solver, s, out, true);
}

std::vector<PathPoint> GeodesicQuery::exact_piece(const SurfacePoint& from, const SurfacePoint& to,
                                                  double length, ExactGeodesicSolver& solver,
                                                  const QueryInterrupt* interrupt) const {
  solve_towards(from, to, length * (1 + 1e-9) + 1e-300, solver, interrupt);
  return solver.path_to(to).points;
}

// ---------------------------------------------------------------------------------------------
// Searches on the augmented graph. Each returns the best s-t distance (or `best` if the graph
// does not improve on it) and the sample where the two halves meet (-1 cast: none).

double GeodesicQuery::search(QueryScratch::Impl& s, const Links& from_s, const Links& from_t,
                             double upper_bound, std::uint32_t& meet,
                             std::uint32_t& settled) const {
  s.new_search();
  meet = UINT32_MAX;
  settled = 0;
  switch (options_.search) {
    case GraphSearch::Bidirectional:
      return search_bidirectional(s, from_s, from_t, upper_bound, meet, settled);
    case GraphSearch::MeetInTheMiddle:
      return search_meet_in_the_middle(s, from_s, from_t, upper_bound, meet, settled);
    case GraphSearch::Dijkstra:
      return search_dijkstra(s, from_s, from_t, upper_bound, meet, settled);
  }
  return upper_bound;
}

namespace {

// Seeds one side's labels from a query point's links and records meetings with the other side.
template <class Meet, class Potential>
void seed_side(QueryScratch::Impl& s, int side, std::span<const std::pair<std::uint32_t, double>>
                                                    links,
               bool push, Meet&& on_label, Potential&& potential) {
  for (const auto& [i, d] : links) {
    s.touch(i);
    if (d < s.label[side][i]) {
      s.label[side][i] = d;
      s.parent[side][i] = kFromQueryPoint;
      if (push)
        quaternary_heap_push(s.heap[side],
                             HeapEntry{d + potential(i), i, static_cast<std::uint32_t>(side)});
      on_label(i);
    }
  }
}

template <class Meet>
void seed_side(QueryScratch::Impl& s, int side, std::span<const std::pair<std::uint32_t, double>>
                                                    links,
               bool push, Meet&& on_label) {
  seed_side(s, side, links, push, on_label, [](std::uint32_t) { return 0.0; });
}

}  // namespace

namespace {

/// The best s-t total found so far and the sample where it was found.
struct Meeting {
  double best;
  std::uint32_t& meet;
  void check(const QueryScratch::Impl& s, std::uint32_t i) {
    const double total = s.label[0][i] + s.label[1][i];
    if (total < best) {
      best = total;
      meet = i;
    }
  }
};

/// Dijkstra's step for a popped entry of side top.side: false for a stale entry; otherwise
/// settles the sample and relaxes its graph edges into `heap`, reporting each improved sample.
template <class OnLabel, class Potential>
bool settle_and_relax(QueryScratch::Impl& s, const ProximityGraphView& graph, const HeapEntry& top,
                      std::vector<HeapEntry>& heap, OnLabel&& on_label, Potential&& potential) {
  const auto side = top.side;
  if (top.key > s.label[side][top.node] + potential(top.node) ||
      s.is_settled(static_cast<int>(side), top.node)) {
    return false;
  }
  s.settled_stamp[side][top.node] = s.generation;
  const double here = s.label[side][top.node];  // the key may include a potential
  for (std::uint32_t e = graph.edge_offsets[top.node]; e < graph.edge_offsets[top.node + 1]; ++e) {
    const std::uint32_t j = graph.edge_target[e];
    const double d = here + graph.edge_distance[e];
    s.touch(j);
    if (d < s.label[side][j]) {
      s.label[side][j] = d;
      s.parent[side][j] = static_cast<std::int32_t>(top.node);
      s.parent_edge[side][j] = e;
      quaternary_heap_push(heap, HeapEntry{d + potential(j), j, side});
      on_label(j);
    }
  }
  return true;
}

template <class OnLabel>
bool settle_and_relax(QueryScratch::Impl& s, const ProximityGraphView& graph, const HeapEntry& top,
                      std::vector<HeapEntry>& heap, OnLabel&& on_label) {
  return settle_and_relax(s, graph, top, heap, on_label, [](std::uint32_t) { return 0.0; });
}

}  // namespace

double GeodesicQuery::search_bidirectional(QueryScratch::Impl& s, const Links& from_s,
                                           const Links& from_t, double best,
                                           std::uint32_t& meet, std::uint32_t& settled) const {
  Meeting m{best, meet};
  auto check = [&](std::uint32_t i) { m.check(s, i); };
  // Goal direction (bidirectional A* with average potentials, Ikeda et al. 1994): when the
  // lengths are the embedding's, the straight-line distance is a lower bound of every graph
  // edge, so p(v) = (|v t| - |v s|) / 2 keeps every reduced edge length non-negative for the
  // forward front (keys label + p) and the backward one (keys label - p), and the usual stop
  // rule (top keys summing to the best meeting) stays exact. Otherwise p = 0: plain Dijkstra.
  const bool directed = geometry_->lengths_are_chords();
  auto potential = [&](std::uint32_t i) {
    if (!directed) return 0.0;
    // Callers touch i first (seed_side, settle_and_relax), which resets the cached value.
    double& p = s.potential[i];  // two square roots, once per sample and search
    if (p == QueryScratch::Impl::kNoPotential) {
      const Vec3& x = sample_positions_[i];
      p = 0.5 * (norm(x - s.target_position) - norm(x - s.source_position));
    }
    return p;
  };
  auto forward = [&](std::uint32_t i) { return potential(i); };
  auto backward = [&](std::uint32_t i) { return -potential(i); };
  seed_side(s, 0, from_s.samples, true, check, forward);
  seed_side(s, 1, from_t.samples, true, check, backward);
  while (!s.heap[0].empty() || !s.heap[1].empty()) {
    const double top0 = s.heap[0].empty() ? kInfinity : s.heap[0].front().key;
    const double top1 = s.heap[1].empty() ? kInfinity : s.heap[1].front().key;
    // No s-t path through an unsettled sample can be shorter than top0 + top1 (the potentials
    // cancel along any path).
    if (top0 + top1 >= m.best) break;
    const int side = top0 <= top1 ? 0 : 1;
    const HeapEntry top = quaternary_heap_pop(s.heap[side]);
    s.poll();
    const bool fresh = side == 0 ? settle_and_relax(s, graph_, top, s.heap[0], check, forward)
                                 : settle_and_relax(s, graph_, top, s.heap[1], check, backward);
    if (fresh) ++settled;
  }
  return m.best;
}

double GeodesicQuery::search_meet_in_the_middle(QueryScratch::Impl& s, const Links& from_s,
                                                const Links& from_t, double best,
                                                std::uint32_t& meet,
                                                std::uint32_t& settled) const {
  // R of the augmented graph: its longest edge, links included.
  const double R = std::max({graph_.longest_edge, from_s.longest, from_t.longest});
  Meeting m{best, meet};
  auto check = [&](std::uint32_t i) { m.check(s, i); };
  std::vector<HeapEntry>& heap = s.heap[0];  // one queue for both fronts, as in Algorithm 1
  for (int side = 0; side < 2; ++side) {
    const Links& links = side == 0 ? from_s : from_t;
    seed_side(s, side, links.samples, false, check);
    for (const auto& [i, d] : links.samples) {
      if (s.label[side][i] == d)
        quaternary_heap_push(heap, HeapEntry{d, i, static_cast<std::uint32_t>(side)});
    }
  }
  while (!heap.empty()) {
    const HeapEntry top = quaternary_heap_pop(heap);
    s.poll();
    // Theorem 3.1: some sample on the best path has both labels <= (best + R) / 2.
    if (top.key > 0.5 * (m.best + R)) break;
    if (settle_and_relax(s, graph_, top, heap, check)) ++settled;
  }
  return m.best;
}

double GeodesicQuery::search_dijkstra(QueryScratch::Impl& s, const Links& from_s,
                                      const Links& from_t, double best, std::uint32_t& meet,
                                      std::uint32_t& settled) const {
  // t is one more node, reached from each of its linked samples: side 1 holds those link
  // lengths and is never propagated.
  Meeting m{best, meet};
  auto check = [&](std::uint32_t i) { m.check(s, i); };
  seed_side(s, 1, from_t.samples, false, [](std::uint32_t) {});
  seed_side(s, 0, from_s.samples, true, check);
  while (!s.heap[0].empty()) {
    const HeapEntry top = quaternary_heap_pop(s.heap[0]);
    s.poll();
    if (top.key >= m.best) break;  // t is settled
    if (settle_and_relax(s, graph_, top, s.heap[0], check)) ++settled;
  }
  return m.best;
}

// ---------------------------------------------------------------------------------------------
// Point to point.

namespace {

Unreachable unreachable(const SurfacePoint& s, const SurfacePoint& t) {
  return Unreachable(ErrorCode::Unreachable, "no path between " + s.to_string() + " and " + t.to_string() +
                                        ": they lie in different connected components");
}

}  // namespace

// Links both points; returns the exact distance when they are within the link radius (then the
// links are not needed), else kInfinity. Exactness is decided by one solve out to rho from s,
// skipped when the straight line already says the points are farther apart. `solved_s` /
// `solved_t` say that an exact answer comes from solver_s / solver_t.
double GeodesicQuery::link_pair(const SurfacePoint& s, const SurfacePoint& t,
                                QueryScratch::Impl& w, bool& solved_s, bool& solved_t) const {
  solved_s = solved_t = false;
  if (may_be_within_link_radius(s, t)) {
    // Stopped once t is settled: a pair closer than rho needs only the disk out to its own
    // distance, or the ellipse around its geodesic.
    const bool whole_disk = solve_towards(s, t, link_radius_, w.solver_s, w.interrupt);
    const double exact = w.solver_s.distance(t);
    if (exact < kInfinity) {
      solved_s = true;
      return exact;
    }
    solved_s = whole_disk;  // then it links s as well
  }
  // A link solve may reach the other point too (a point with no sample within rho links
  // through a solve out to its nearest sample): then that exact answer stands, as in fields.
  if (!link_by_covers(s, w.links_s)) {
    const double exact_within = link_by_solve(s, w.solver_s, w, w.links_s, solved_s);
    solved_s = true;
    const double exact = exact_up_to(w.solver_s.distance(t), exact_within);
    if (exact < kInfinity) return exact;
  }
  if (!link_by_covers(t, w.links_t)) {
    const double exact_within = link_by_solve(t, w.solver_t, w, w.links_t);
    const double exact = exact_up_to(w.solver_t.distance(s), exact_within);
    if (exact < kInfinity) {
      solved_t = true;
      return exact;
    }
  }
  return kInfinity;
}

// A near pair's disk around p: out to near_radius rho, and farther while it takes less work
// (windows propagated) than such a disk takes on average (near_windows_), up to three times
// that radius. Among large triangles (a statue's flat base) a disk of the usual radius holds a
// handful of vertices, too few to link or join through; there the same work reaches much
// farther, and p's face being large (its edges longer than the mean) buys it up to three times
// that work, as such regions border on denser ones. A face or edge point's disk also reaches
// as far as its link solve would without the vertex limit.
void GeodesicQuery::solve_near(const SurfacePoint& p, ExactGeodesicSolver& solver,
                               const QueryInterrupt* interrupt) const {
  const double scale = sparseness(p, 2);
  ExactGeodesicOptions bounded;
  bounded.min_distance = options_.near_radius * link_radius_;
  bounded.max_distance = 3 * bounded.min_distance;
  // At least as far as p's link solve would go without its vertex limit
  // (link_solve_vertices): the wide links then take every path such links would. Only where
  // that limit applies: not to vertices (cover rows), nor to exact links (link_solve_edges 0).
  if (options_.link_solve_vertices > 0 && options_.link_solve_edges > 0 &&
      p.kind != SurfacePoint::Kind::Vertex) {
    bounded.min_distance = std::max(bounded.min_distance, link_solve_radius(p).radius);
  }
  bounded.max_windows_propagated =
      static_cast<std::size_t>(scale * static_cast<double>(near_windows_));
  bounded.queue_halfedges = true;
  bounded.interrupt = interrupt;
  solver.solve(p, bounded);
}

// p's links (`narrow`, as link_pair() made them), improved through every vertex of its near
// disk (solver holds that solve, solve_near()); keeps the disk's distances for joining with the
// other point's disk.
void GeodesicQuery::wide_links(const ExactGeodesicSolver& solver, QueryScratch::Impl& s,
                               const Links& narrow, Links& out) const {
  const double radius = solver.radius_reached();
  if (!link_through_covers(solver, radius, s, out, &narrow)) {  // no cover table
    out.samples = narrow.samples;
    out.via = narrow.via;
    out.longest = narrow.longest;
  }
  out.region.clear();
  for (std::uint32_t v : solver.touched_vertices()) {
    const double d = solver.distance(v);
    if (d <= radius) out.region.emplace_back(v, d);
  }
}

// The shortest path through a point of both disks (solver a holds one, solver b the other;
// `a_disk` / `b_disk` their regions). First through a vertex: min over v of d_a(v) + d_b(v).
// Then along the edges of the faces around the best two vertices, where the geodesic crosses
// (among large triangles the best vertex can be far off it): d_a + d_b along an edge is smooth
// and has one minimum near the crossing, found by golden-section search. An upper bound of the
// distance (a real path through that point) and symmetric in a, b: the same sums throughout.
double GeodesicQuery::join_disks(QueryScratch::Impl& s, const ExactGeodesicSolver& a,
                                 const Links& a_disk, const ExactGeodesicSolver& b,
                                 const Links& b_disk, SurfacePoint& at) const {
  if (++s.join_generation == 0) {
    std::fill(s.join_stamp.begin(), s.join_stamp.end(), 0);
    std::fill(s.join_edge_stamp.begin(), s.join_edge_stamp.end(), 0);
    s.join_generation = 1;
  }
  for (const auto& [v, d] : a_disk.region) {
    s.join_stamp[v] = s.join_generation;
    s.join_distance[v] = d;
  }
  double best = kInfinity, second = kInfinity;
  std::uint32_t best_vertex = UINT32_MAX, second_vertex = UINT32_MAX;
  for (const auto& [v, d] : b_disk.region) {
    if (s.join_stamp[v] != s.join_generation) continue;
    const double total = s.join_distance[v] + d;
    if (total < best) {
      second = best;
      second_vertex = best_vertex;
      best = total;
      best_vertex = v;
    } else if (total < second) {
      second = total;
      second_vertex = v;
    }
  }
  std::vector<std::uint32_t>& edges = s.join_edges;
  edges.clear();
  if (best_vertex != UINT32_MAX) at = SurfacePoint::vertex(best_vertex);
  for (const std::uint32_t v : {best_vertex, second_vertex}) {
    if (v == UINT32_MAX) continue;
    for (const std::uint32_t h : mesh_->outgoing_halfedges(v)) {
      const std::uint32_t f = TriangleMesh::face_of(h);
      for (std::uint32_t i = 0; i < 3; ++i) {
        const std::uint32_t e = mesh_->edge_of(3 * f + i);
        if (std::find(edges.begin(), edges.end(), e) == edges.end()) edges.push_back(e);
      }
    }
  }
  const std::size_t around_best = edges.size();
  // Edges longer than a disk's radius that both disks crossed: where large faces fan out, the
  // geodesic may cross such edges in the disks' overlap far from every vertex of both, and the
  // edges around the best common vertex miss it (vase-lion.off: a pair 1.26 rho apart answered
  // 111% long). Such a crossing may cover a small part of the edge: it is bracketed by a scan
  // before the golden-section search.
  const double long_edge = options_.near_radius * link_radius_;
  if (longest_edge_length_ > long_edge) {  // most meshes have none: no pass over the windows
    a.for_each_window_halfedge([&](std::uint32_t h) {
      const std::uint32_t e = mesh_->edge_of(h);
      if (geometry_->edge_length(e) > long_edge) s.join_edge_stamp[e] = s.join_generation;
    });
    // Unstamped: the edges already listed, and each long edge once listed.
    for (const std::uint32_t e : edges) s.join_edge_stamp[e] = 0;
    b.for_each_window_halfedge([&](std::uint32_t h) {
      const std::uint32_t e = mesh_->edge_of(h);
      if (s.join_edge_stamp[e] != s.join_generation) return;
      s.join_edge_stamp[e] = 0;
      edges.push_back(e);
    });
  }
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const std::uint32_t e = edges[k];
    auto sum = [&](double t) {
      const SurfacePoint x = SurfacePoint::edge(e, t);
      const double total = a.distance(x) + b.distance(x);
      if (total < best) {
        best = total;
        at = x;
      }
      return total;
    };
    constexpr double kGolden = 0.38196601125010515;  // (3 - sqrt 5) / 2
    double lo = 0, hi = 1;
    if (k >= around_best) {  // a long edge: bracket the best of a scan
      constexpr int kScan = 64;
      int best_step = -1;
      double best_scan = kInfinity;
      for (int i = 0; i <= kScan; ++i) {
        const double total = sum(static_cast<double>(i) / kScan);
        if (total < best_scan) {
          best_scan = total;
          best_step = i;
        }
      }
      if (best_step < 0) continue;
      lo = std::max(0.0, static_cast<double>(best_step - 1) / kScan);
      hi = std::min(1.0, static_cast<double>(best_step + 1) / kScan);
    }
    double x1 = lo + kGolden * (hi - lo), x2 = hi - kGolden * (hi - lo);
    double f1 = sum(x1), f2 = sum(x2);
    if (f1 == kInfinity && f2 == kInfinity) continue;
    for (int iteration = 0; iteration < 28; ++iteration) {  // to 1.4e-6 of the bracket
      if (f1 <= f2) {
        hi = x2;
        x2 = x1;
        f2 = f1;
        x1 = lo + kGolden * (hi - lo);
        f1 = sum(x1);
      } else {
        lo = x1;
        x1 = x2;
        f1 = f2;
        x2 = hi - kGolden * (hi - lo);
        f2 = sum(x2);
      }
    }
  }
  return best;
}

// A near pair (see the file comment): the better of the join of both disks and a search from
// their wide links (links_s / links_t hold the pair's links from link_pair(), and the pair's
// positions are set, as answer() leaves them for its search). Leaves solver_s /
// solver_t holding the solves from s / t and links_s / links_t the wide links, for paths.
PairAnswer GeodesicQuery::answer_near(const SurfacePoint& s, const SurfacePoint& t,
                                      QueryScratch::Impl& w) const {
  // Afresh for s, as for t (the same disk either way). The two solves are most of a near
  // pair's time and independent: a server with an idle thread runs them at once.
  const auto near_s = [&] { solve_near(s, w.solver_s, w.interrupt); };
  const auto near_t = [&] { solve_near(t, w.solver_t, w.interrupt); };
  if (w.run_both) {
    w.run_both(near_s, near_t);
  } else {
    near_s();
    near_t();
  }
  wide_links(w.solver_s, w, w.links_s, w.wide_s);
  wide_links(w.solver_t, w, w.links_t, w.wide_t);
  std::swap(w.links_s, w.wide_s);  // paths read links_s / links_t
  std::swap(w.links_t, w.wide_t);
  return join_or_search(w, w.solver_s, w.links_s, w.solver_t, w.links_t);
}

// The better of the join of two near disks (solvers a and b, their wide links and regions in
// a_wide / b_wide) and a search from their wide links, bounded by the join. The pair's
// positions must already be in s.source_position / s.target_position (the search's potential).
PairAnswer GeodesicQuery::join_or_search(QueryScratch::Impl& s, const ExactGeodesicSolver& a,
                                         const Links& a_wide, const ExactGeodesicSolver& b,
                                         const Links& b_wide) const {
  PairAnswer answer;
  answer.distance = join_disks(s, a, a_wide, b, b_wide, answer.join_point);
  answer.from = PairAnswer::From::Join;
  answer.distance = search(s, a_wide, b_wide, answer.distance, answer.meet, answer.settled);
  if (answer.meet != UINT32_MAX) answer.from = PairAnswer::From::Graph;
  return answer;
}

// 1, or for a point among large triangles (its face's edges more than `knee` times the mesh's
// mean), that ratio over `knee`, at most 3. Random points fall on larger-than-mean faces more
// often than not (by area), and on an ordinary mesh those are no sparser than the rest: only
// outliers count.
double GeodesicQuery::sparseness(const SurfacePoint& p, double knee) const {
  const double ratio = mean_face_edge(p.in_face(*mesh_).first) / mean_edge_length_;
  return std::clamp(ratio / knee, 1.0, 3.0);
}

// Near pairs: the graph's answer (an upper bound of the distance, and symmetric) under
// refine_within rho, or farther for a point among large triangles, whose graph paths bend more.
bool GeodesicQuery::refines(const SurfacePoint& s, const SurfacePoint& t,
                            double graph_distance) const {
  return options_.refine_within > 0 && options_.near_radius > 0 &&
         graph_distance <= options_.refine_within * link_radius_ *
                               std::max(sparseness(s, 4), sparseness(t, 4));
}

PairAnswer GeodesicQuery::answer(const SurfacePoint& s, const SurfacePoint& t,
                                 QueryScratch::Impl& w) const {
  PairAnswer a;
  bool solved_s = false, solved_t = false;
  a.distance = link_pair(s, t, w, solved_s, solved_t);
  if (a.distance < kInfinity) {
    a.from = solved_t ? PairAnswer::From::SolveT : PairAnswer::From::SolveS;
    return a;
  }
  w.source_position = s.position(*mesh_);
  w.target_position = t.position(*mesh_);
  a.distance = search(w, w.links_s, w.links_t, kInfinity, a.meet, a.settled);
  // Decided by the graph's answer, an upper bound of the distance (and symmetric).
  if (const double exact = solve_exactly(s, t, a.distance, w.solver_s, w.interrupt);
      exact < kInfinity) {
    a.distance = exact;
    a.from = PairAnswer::From::SolveS;
    return a;
  }
  if (refines(s, t, a.distance)) return answer_near(s, t, w);
  return a;
}

// kFieldExactRadii rho where near pairs are answered exactly (exact_within > 0, under the
// mesh's own lengths), else rho.
double GeodesicQuery::field_exact_radius() const {
  const bool wide = options_.exact_within > 0 && geometry_->lengths_are_chords();
  return (wide ? kFieldExactRadii : 1.0) * link_radius_;
}

// Whether a pair with this graph answer is solved exactly: under exact_within rho, under the
// mesh's own lengths (the goal's straight-line bound needs them).
bool GeodesicQuery::solves_exactly(double graph_distance) const {
  return options_.exact_within > 0 && geometry_->lengths_are_chords() &&
         graph_distance < options_.exact_within * link_radius_;
}

// Such a pair's exact distance from one solve bounded by its graph answer (never below the
// distance: a real path) and directed at t, an ellipse around the geodesic. kInfinity for other
// pairs, or should the solve not reach t (it always does: the bound is a path's length, plus
// rounding's share).
double GeodesicQuery::solve_exactly(const SurfacePoint& s, const SurfacePoint& t,
                                    double graph_distance, ExactGeodesicSolver& solver,
                                    const QueryInterrupt* interrupt) const {
  if (!solves_exactly(graph_distance)) return kInfinity;
  solve_towards(s, t, graph_distance * (1 + 1e-9), solver, interrupt);
  return solver.settled_targets().empty() ? kInfinity : solver.settled_target_distances()[0];
}

// The solver that holds the exact answer for (s, t) afterwards, with a settled target: solver_s
// (from s, towards t) or, when the query solved the pair from t, solver_t.
const ExactGeodesicSolver& GeodesicQuery::solve_pair_exactly(const SurfacePoint& s,
                                                             const SurfacePoint& t,
                                                             QueryScratch::Impl& w,
                                                             double& distance) const {
  // On lucy.obj, pairs 4 to 5 rho apart: 24 -> 2.3 ms, the graph query included. Without the
  // bound (another metric), or should the bounded solve not reach t (a bug in the graph), the
  // solve runs unbounded.
  double bound = kInfinity;
  if (geometry_->lengths_are_chords()) {
    const PairAnswer a = answer(s, t, w);
    if (a.from == PairAnswer::From::SolveS || a.from == PairAnswer::From::SolveT) {
      // The query solved it exactly already (a close pair, or one under exact_within rho).
      distance = a.distance;
      return a.from == PairAnswer::From::SolveS ? w.solver_s : w.solver_t;
    }
    bound = a.distance;
  }
  if (bound < kInfinity) solve_towards(s, t, bound * (1 + 1e-9), w.solver_s, w.interrupt);
  if (!(bound < kInfinity) || w.solver_s.settled_targets().empty()) {
    solve_towards(s, t, kInfinity, w.solver_s, w.interrupt);
  }
  if (w.solver_s.settled_targets().empty()) throw unreachable(s, t);
  distance = w.solver_s.settled_target_distances()[0];
  return w.solver_s;
}

DistanceResult GeodesicQuery::exact_distance(const SurfacePoint& s, const SurfacePoint& t,
                                             QueryScratch& scratch) const {
  s.validate(*mesh_);
  t.validate(*mesh_);
  DistanceResult result;
  result.exact = true;
  solve_pair_exactly(s, t, *scratch.impl_, result.distance);
  return result;
}

PathResult GeodesicQuery::exact_path(const SurfacePoint& s, const SurfacePoint& t,
                                     QueryScratch& scratch) const {
  s.validate(*mesh_);
  t.validate(*mesh_);
  QueryScratch::Impl& w = *scratch.impl_;
  PathResult result;
  result.exact = true;
  const ExactGeodesicSolver& solver = solve_pair_exactly(s, t, w, result.distance);
  if (&solver == &w.solver_s) {
    result.points = solver.path_to(t).points;
  } else {
    result.points = solver.path_to(s).points;
    std::reverse(result.points.begin(), result.points.end());
  }
  return result;
}

DistanceResult GeodesicQuery::distance(const SurfacePoint& s, const SurfacePoint& t,
                                       QueryScratch& scratch) const {
  s.validate(*mesh_);
  t.validate(*mesh_);
  const PairAnswer a = answer(s, t, *scratch.impl_);
  if (a.distance == kInfinity) throw unreachable(s, t);
  DistanceResult result;
  result.distance = a.distance;
  result.exact = a.from == PairAnswer::From::SolveS || a.from == PairAnswer::From::SolveT;
  result.joined = a.from == PairAnswer::From::Join;
  result.samples_settled = a.settled;
  return result;
}

// ---------------------------------------------------------------------------------------------
// Paths (paper Fig. 5): the link pieces come from the local solves' backtraces; each sample to
// sample piece is traced along the graph's stored direction and checked against the next
// sample, or solved exactly when tracing cannot be trusted.

namespace {

void append_points(std::vector<PathPoint>& out, std::span<const PathPoint> points) {
  for (const PathPoint& p : points) {
    if (!out.empty()) {
      const SurfacePoint& q = out.back().point;
      if (q.kind == p.point.kind && q.id == p.point.id && q.t == p.point.t &&
          q.bary == p.point.bary) {
        continue;
      }
    }
    out.push_back(p);
  }
}

}  // namespace

namespace {

/// The stored direction as a unit face direction; false when it is unknown (zero).
bool stored_direction(const GraphDirection& d, FaceDirection& out) {
  if (d.x == 0 && d.y == 0) return false;
  const double len = std::hypot(double{d.x}, double{d.y});
  out = {d.face, d.x / len, d.y / len};
  return true;
}

}  // namespace

void GeodesicQuery::append_segment(QueryScratch::Impl& s, std::uint32_t from_sample,
                                   std::uint32_t to_sample, std::uint32_t edge,
                                   PathResult& out) const {
  // The edge runs from one of the two samples to the other; orient it from `a` to `b`.
  const std::uint32_t a = graph_.edge_target[edge] == to_sample ? from_sample : to_sample;
  const std::uint32_t b = a == from_sample ? to_sample : from_sample;
  const double length = graph_.edge_distance[edge];
  const double tolerance = options_.trace_tolerance * length;
  const std::uint32_t a_vertex = graph_.sample_vertex[a], b_vertex = graph_.sample_vertex[b];

  // Traces from `sample` along graph edge `e` for the edge's length; false if the direction
  // is unknown or not usable.
  auto trace = [&](std::uint32_t sample, std::uint32_t e, GeodesicTrace& into) {
    FaceDirection direction;
    if (!stored_direction(graph_.edge_direction[e], direction)) return false;
    try {
      // Passing within 1e-6 of an edge's length of a vertex counts as hitting it: stored
      // directions are floats (~1e-7), and a trace that grazes a saddle on the wrong side
      // diverges, while one that stops there can be joined (below).
      GeodesicTraceOptions options;
      options.vertex_tolerance = 1e-6;
      trace_geodesic(*mesh_, *geometry_, SurfacePoint::vertex(graph_.sample_vertex[sample]),
                     direction, length, options, into);  // reuses into's buffer
    } catch (const InvalidInput&) {
      return false;  // a stored direction a hair outside its face's wedge
    }
    return true;
  };
  auto ends_at = [&](const GeodesicTrace& t, std::uint32_t vertex) {
    if (t.stop == TraceStop::HitVertex) {
      return static_cast<std::uint32_t>(t.stop_vertex) == vertex &&
             std::abs(t.length - length) <= tolerance;
    }
    return t.stop == TraceStop::Completed &&
           norm(t.points.back().position - mesh_->position(vertex)) <= tolerance;
  };

  std::vector<PathPoint>& piece = s.piece;
  piece.clear();
  // The trace back from b, reversed, ends the piece exactly at b's vertex.
  auto append_trace_back = [&] {
    piece.insert(piece.end(), s.trace_back.points.rbegin() + 1, s.trace_back.points.rend());
    piece.back() = {SurfacePoint::vertex(b_vertex), mesh_->position(b_vertex)};
  };
  bool done = false;
  if (trace(a, edge, s.trace)) {
    if (ends_at(s.trace, b_vertex)) {
      piece.assign(s.trace.points.begin(), s.trace.points.end());
      piece.back() = {SurfacePoint::vertex(b_vertex), mesh_->position(b_vertex)};
      done = true;
    } else if (s.trace.stop == TraceStop::HitVertex) {
      // The geodesic bends at a vertex (a saddle): trace back from b along the reverse edge;
      // if both traces meet at that vertex with the right total length, join them.
      std::uint32_t reverse = graph_.edge_offsets[b];
      while (reverse < graph_.edge_offsets[b + 1] && graph_.edge_target[reverse] != a) ++reverse;
      const bool back = reverse < graph_.edge_offsets[b + 1] && trace(b, reverse, s.trace_back) &&
                        s.trace_back.stop == TraceStop::HitVertex;
      if (back && s.trace_back.stop_vertex == s.trace.stop_vertex &&
          std::abs(s.trace.length + s.trace_back.length - length) <= tolerance) {
        piece.assign(s.trace.points.begin(), s.trace.points.end());
        append_trace_back();
        done = true;
      } else {
        // Several bends: the traced parts up to the first bend from each end, and between
        // those two vertices an exact solve bounded by the remaining length (the geodesic
        // passes through both). Without a trace back, the solve runs from the first bend to b.
        const bool both = back && s.trace.length + s.trace_back.length < length;
        const auto bend = static_cast<std::uint32_t>(s.trace.stop_vertex);
        const std::uint32_t end =
            both ? static_cast<std::uint32_t>(s.trace_back.stop_vertex) : b_vertex;
        const double rest = length - s.trace.length - (both ? s.trace_back.length : 0.0);
        solve_towards(SurfacePoint::vertex(bend), SurfacePoint::vertex(end),
                      rest * (1 + 1e-9) + tolerance, s.solver_s, s.interrupt);
        const double found = s.solver_s.distance(end);
        if (found < kInfinity && std::abs(found - rest) <= tolerance) {
          piece.assign(s.trace.points.begin(), s.trace.points.end());
          const GeodesicPath middle = s.solver_s.path_to(SurfacePoint::vertex(end));
          piece.insert(piece.end(), middle.points.begin() + 1, middle.points.end());
          if (both) append_trace_back();
          done = true;
          ++out.exact_segments;
        }
      }
    }
  }
  if (!done) {
    piece = exact_piece(SurfacePoint::vertex(a_vertex), SurfacePoint::vertex(b_vertex), length,
                        s.solver_s, s.interrupt);
    ++out.exact_segments;
  }
  if (a != from_sample) std::reverse(piece.begin(), piece.end());
  append_points(out.points, piece);
}

// The geodesic along one link of p: through the link's vertex when it has one (exact path to
// the vertex, then the exact path from the vertex to the sample, whose length is the cover
// entry), else straight to the sample. Its length is the link's distance (the cover table holds
// floats: to about 1e-7 relative).
std::vector<PathPoint> GeodesicQuery::link_piece(const SurfacePoint& p, const Links& links,
                                                 std::uint32_t sample, QueryScratch::Impl& s,
                                                 ExactGeodesicSolver& solver) const {
  std::size_t k = 0;
  while (k < links.samples.size() && links.samples[k].first != sample) ++k;
  GEOPROX_ASSERT(k < links.samples.size(), "path through a sample that is not linked");
  const SurfacePoint& target = sample_points_[sample];
  const auto [vertex, to_vertex] = links.via[k];
  if (vertex == kDirect) return exact_piece(p, target, links.samples[k].second, solver, s.interrupt);
  // `solver` still holds the solve from p that the link came from: the piece to the vertex is
  // its backtrace (checked, in case it has been reused since).
  std::vector<PathPoint> piece =
      solver.distance(vertex) == to_vertex
          ? solver.path_to(SurfacePoint::vertex(vertex)).points
          : exact_piece(p, SurfacePoint::vertex(vertex), to_vertex, solver, s.interrupt);
  const std::vector<PathPoint> rest =
      exact_piece(SurfacePoint::vertex(vertex), target, links.samples[k].second - to_vertex,
                  solver, s.interrupt);
  append_points(piece, rest);
  return piece;
}

PathResult GeodesicQuery::path(const SurfacePoint& s, const SurfacePoint& t,
                               QueryScratch& scratch) const {
  s.validate(*mesh_);
  t.validate(*mesh_);
  QueryScratch::Impl& w = *scratch.impl_;
  PathResult result;
  const PairAnswer a = answer(s, t, w);
  if (a.distance == kInfinity) throw unreachable(s, t);
  result.distance = a.distance;
  switch (a.from) {
    case PairAnswer::From::SolveS:
      result.exact = true;
      result.points = w.solver_s.path_to(t).points;
      return result;
    case PairAnswer::From::SolveT:
      result.exact = true;
      result.points = w.solver_t.path_to(s).points;
      std::reverse(result.points.begin(), result.points.end());
      return result;
    case PairAnswer::From::Join: {
      result.joined = true;
      result.points = w.solver_s.path_to(a.join_point).points;
      std::vector<PathPoint> tail = w.solver_t.path_to(a.join_point).points;
      std::reverse(tail.begin(), tail.end());
      append_points(result.points, tail);
      return result;
    }
    case PairAnswer::From::Graph:
      break;
  }
  const std::uint32_t meet = a.meet;
  GEOPROX_ASSERT(meet != UINT32_MAX, "a graph answer without a meeting sample");
  std::vector<std::uint32_t> edges;  // graph edge of each hop (parallel to samples[1..])
  // Sample sequence: s-side parents back from the meeting sample, then t-side parents.
  for (std::int32_t i = static_cast<std::int32_t>(meet); i != kFromQueryPoint;
       i = w.parent[0][static_cast<std::uint32_t>(i)]) {
    result.samples.push_back(static_cast<std::uint32_t>(i));
  }
  std::reverse(result.samples.begin(), result.samples.end());
  for (std::size_t k = 1; k < result.samples.size(); ++k) {
    edges.push_back(w.parent_edge[0][result.samples[k]]);
  }
  for (std::int32_t i = w.parent[1][meet]; i != kFromQueryPoint;
       i = w.parent[1][static_cast<std::uint32_t>(i)]) {
    edges.push_back(w.parent_edge[1][result.samples.back()]);
    result.samples.push_back(static_cast<std::uint32_t>(i));
  }
  // The end pieces, before solver_s is reused for exact segments.
  const std::uint32_t first = result.samples.front(), last = result.samples.back();
  std::vector<PathPoint> tail = link_piece(t, w.links_t, last, w, w.solver_t);  // t -> last
  std::reverse(tail.begin(), tail.end());
  result.points = link_piece(s, w.links_s, first, w, w.solver_s);
  for (std::size_t k = 0; k + 1 < result.samples.size(); ++k) {
    append_segment(w, result.samples[k], result.samples[k + 1], edges[k], result);
  }
  append_points(result.points, tail);
  return result;
}

// ---------------------------------------------------------------------------------------------
// Distance field (§3.2): one multi-source search over the graph from the sources' links, then
// each vertex takes the best of its covering samples; vertices inside a source's own exact
// region keep their exact distance.

void GeodesicQuery::graph_distances_from(QueryScratch::Impl& s,
                                         std::span<const Links* const> sources,
                                         double max_distance) const {
  s.new_search();
  for (std::uint32_t k = 0; k < sources.size(); ++k) {
    for (const auto& [i, d] : sources[k]->samples) {
      s.touch(i);
      if (d < s.label[0][i]) {
        s.label[0][i] = d;
        s.origin[i] = k;
        quaternary_heap_push(s.heap[0], HeapEntry{d, i, 0});
      }
    }
  }
  while (!s.heap[0].empty()) {
    const HeapEntry top = quaternary_heap_pop(s.heap[0]);
    s.poll();
    if (top.key > max_distance) break;
    if (top.key > s.label[0][top.node] || s.is_settled(0, top.node)) continue;
    s.settled_stamp[0][top.node] = s.generation;
    for (std::uint32_t e = graph_.edge_offsets[top.node]; e < graph_.edge_offsets[top.node + 1];
         ++e) {
      const std::uint32_t j = graph_.edge_target[e];
      const double d = top.key + graph_.edge_distance[e];
      s.touch(j);
      if (d < s.label[0][j]) {
        s.label[0][j] = d;
        s.origin[j] = s.origin[top.node];
        quaternary_heap_push(s.heap[0], HeapEntry{d, j, 0});
      }
    }
  }
}

// The exact values a field takes from `solver`: every vertex it settled within `exact_within`
// (and max_distance).
void GeodesicQuery::add_field_region(const ExactGeodesicSolver& solver, double exact_within,
                                     double max_distance, Links& out) const {
  for (std::uint32_t v : solver.touched_vertices()) {
    const double d = solver.distance(v);
    if (d <= max_distance && d <= exact_within) out.region.emplace_back(v, d);
  }
}

// One exact solve from all sources at once out to `radius`: every vertex inside is exact (its
// nearest source's), and every sample inside links its nearest source to the graph at its exact
// distance, so that the graph starts from the whole disks and vertices just beyond them are not
// answered through a path of few hops, where the paper's answers err most. The usual links of
// a point are all inside (a cover row or a link solve's covers reach rho), except for a point
// with no sample within rho, which is linked as point-to-point queries link it.
void GeodesicQuery::link_field_disks(std::span<const SurfacePoint> sources, double radius,
                                     double max_distance, QueryScratch::Impl& w) const {
  w.field_sources.clear();
  for (const SurfacePoint& p : sources) w.field_sources.push_back({p, 0.0});
  ExactGeodesicOptions bounded;
  bounded.max_distance = radius;
  bounded.queue_halfedges = true;
  bounded.interrupt = w.interrupt;
  w.solver_s.solve(w.field_sources, {}, bounded);
  w.field_linked.assign(sources.size(), 0);
  for (std::size_t k = 0; k < sources.size(); ++k) {
    Links& l = w.many[k];
    l.samples.clear();
    l.via.clear();
    l.region.clear();
    l.longest = 0;
  }
  for (std::uint32_t v : w.solver_s.touched_vertices()) {
    const double d = w.solver_s.distance(v);
    if (!(d <= radius)) continue;
    const auto k = static_cast<std::size_t>(w.solver_s.nearest_source(v));
    Links& l = w.many[k];
    if (d <= max_distance) l.region.emplace_back(v, d);
    if (sample_of_vertex_[v] < 0) continue;
    l.samples.emplace_back(static_cast<std::uint32_t>(sample_of_vertex_[v]), d);
    l.via.emplace_back(kDirect, 0.0);
    l.longest = std::max(l.longest, d);
    if (d <= link_radius_) w.field_linked[k] = 1;
  }
  for (std::size_t k = 0; k < sources.size(); ++k) {
    if (w.field_linked[k]) continue;
    Links& extra = w.links_s;
    solve_within_link_radius(sources[k], w.solver_s, w.interrupt);
    const double exact_within = link_solved(sources[k], w.solver_s, w, extra);
    Links& l = w.many[k];
    l.samples.insert(l.samples.end(), extra.samples.begin(), extra.samples.end());
    l.via.insert(l.via.end(), extra.via.begin(), extra.via.end());
    // With no sample within rho, the solver holds the solve out to the nearest one: exact.
    if (exact_within == kInfinity) add_field_region(w.solver_s, exact_within, max_distance, l);
  }
}

DistanceField GeodesicQuery::field(std::span<const SurfacePoint> sources, QueryScratch& scratch,
                                   const DistanceFieldOptions& options) const {
  if (sources.empty()) throw InvalidInput(ErrorCode::NoSources, "a distance field needs a source");
  if (graph_.cover_sample.empty()) {
    throw InvalidInput(ErrorCode::NoCoverTable,
                       "this graph has no per-vertex cover table (imported from the paper's text "
                       "format?): distance fields need a graph built by geoprox");
  }
  if (std::isnan(options.max_distance) || options.max_distance < 0) {
    throw InvalidInput(ErrorCode::BadRadius, "max_distance must be a non-negative number");
  }
  for (const SurfacePoint& p : sources) p.validate(*mesh_);
  QueryScratch::Impl& w = *scratch.impl_;
  if (w.many.size() < sources.size()) w.many.resize(sources.size());
  std::vector<const Links*> links(sources.size());
  const double exact_radius = field_exact_radius();
  if (exact_radius > link_radius_) {
    link_field_disks(sources, exact_radius, options.max_distance, w);
  } else {
    for (std::size_t k = 0; k < sources.size(); ++k) {
      // The paper's field: links as for point-to-point queries, from the solve out to rho that
      // the exact region needs anyway.
      Links& l = w.many[k];
      solve_within_link_radius(sources[k], w.solver_s, w.interrupt);
      add_field_region(w.solver_s, link_solved(sources[k], w.solver_s, w, l),
                       options.max_distance, l);
    }
  }
  for (std::size_t k = 0; k < sources.size(); ++k) links[k] = &w.many[k];
  graph_distances_from(w, links, options.max_distance);

  const auto nv = static_cast<std::int64_t>(mesh_->num_vertices());
  DistanceField out;
  out.distances.assign(static_cast<std::size_t>(nv), kInfinity);
  out.nearest_source.assign(static_cast<std::size_t>(nv), -1);
  // Every sample's label in one dense array (the cover rows read it once per entry, the stamps
  // only once per sample).
  w.dense_label.resize(graph_.num_samples);
  for (std::uint32_t i = 0; i < graph_.num_samples; ++i) w.dense_label[i] = w.get(0, i);
  const double* label = w.dense_label.data();
  const std::uint32_t* cover_sample = graph_.cover_sample.data();
  const float* cover_distance = graph_.cover_distance.data();
  const QueryScratch::Impl& labels = w;
  const int threads = options.threads > 0 ? options.threads : omp_get_max_threads();
#pragma omp parallel for num_threads(threads) schedule(static, 4096) if (threads > 1)
  for (std::int64_t v = 0; v < nv; ++v) {
    double best = kInfinity;
    std::uint32_t best_entry = 0;
    const std::uint32_t end = graph_.cover_offsets[static_cast<std::size_t>(v) + 1];
    for (std::uint32_t c = graph_.cover_offsets[static_cast<std::size_t>(v)]; c < end; ++c) {
      const double d = label[cover_sample[c]] + static_cast<double>(cover_distance[c]);
      best_entry = d < best ? c : best_entry;
      best = d < best ? d : best;
    }
    if (best <= options.max_distance && best < kInfinity) {
      out.distances[static_cast<std::size_t>(v)] = best;
      out.nearest_source[static_cast<std::size_t>(v)] =
          static_cast<std::int32_t>(labels.origin[cover_sample[best_entry]]);
    }
  }
  for (std::size_t k = 0; k < sources.size(); ++k) {
    for (const auto& [v, d] : w.many[k].region) {
      if (d < out.distances[v]) {
        out.distances[v] = d;
        out.nearest_source[v] = static_cast<std::int32_t>(k);
      }
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Matrix: every point is linked once; one graph search per source serves all targets.

std::vector<double> GeodesicQuery::matrix(std::span<const SurfacePoint> sources,
                                          std::span<const SurfacePoint> targets,
                                          QueryScratch& scratch) const {
  for (const SurfacePoint& p : sources) p.validate(*mesh_);
  for (const SurfacePoint& p : targets) p.validate(*mesh_);
  QueryScratch::Impl& w = *scratch.impl_;
  const std::size_t S = sources.size(), T = targets.size();
  std::vector<double> out(S * T, kInfinity);
  if (S == 0 || T == 0) return out;
  if (w.many.size() < S + T) w.many.resize(S + T);
  // Pairs that distance() answers from the exact solves of link_pair (then not refined).
  std::vector<char> exact(S * T, 0);
  auto take_exact = [&](std::size_t k, double d) {
    if (d < kInfinity) exact[k] = 1;
    out[k] = std::min(out[k], d);
  };
  // Links as for point-to-point queries. Sources are always solved out to the link radius, so
  // that every pair closer than it gets its exact distance, as distance() does.
  for (std::size_t j = 0; j < T; ++j) {
    if (!link_by_covers(targets[j], w.many[S + j])) {
      const double exact_within = link_by_solve(targets[j], w.solver_t, w, w.many[S + j]);
      for (std::size_t i = 0; i < S; ++i) {  // as in distance(): exact when reached
        take_exact(i * T + j, exact_up_to(w.solver_t.distance(sources[i]), exact_within));
      }
    }
  }
  if (w.wide.size() < T) w.wide.resize(T);
  w.has_wide.assign(T, 0);
  std::vector<std::size_t> near;  // targets of source i that distance() refines
  std::size_t solver_t_holds = SIZE_MAX;  // the target whose near disk solver_t holds
  for (std::size_t i = 0; i < S; ++i) {
    Links& l = w.many[i];
    solve_within_link_radius(sources[i], w.solver_s, w.interrupt);
    const double exact_within = link_solved(sources[i], w.solver_s, w, l);
    for (std::size_t j = 0; j < T; ++j) {
      take_exact(i * T + j, exact_up_to(w.solver_s.distance(targets[j]), exact_within));
    }
    const Links* one[] = {&l};
    // The search only needs to run until every target's links are settled; the largest
    // current estimate bounds how far that can be.
    double farthest = 0;
    bool unbounded = false;
    for (std::size_t j = 0; j < T; ++j) {
      if (out[i * T + j] == kInfinity) unbounded = true;
      farthest = std::max(farthest, out[i * T + j]);
    }
    graph_distances_from(w, one, unbounded ? kInfinity : farthest);
    near.clear();
    for (std::size_t j = 0; j < T; ++j) {
      double best = out[i * T + j];
      for (const auto& [sample, d] : w.many[S + j].samples) best = std::min(best, w.get(0, sample) + d);
      if (!exact[i * T + j]) {
        // As answer() does. The solve reuses solver_t, which then holds no target's near disk
        // (also should it not reach the target and the pair be refined after all).
        if (solves_exactly(best)) solver_t_holds = SIZE_MAX;
        if (const double d = solve_exactly(sources[i], targets[j], best, w.solver_t, w.interrupt);
            d < kInfinity) {
          best = d;
        } else if (refines(sources[i], targets[j], best)) {
          near.push_back(j);
        }
      }
      out[i * T + j] = best;
    }
    if (near.empty()) continue;
    // Near pairs, as answer_near() does them: the source's near disk and wide links, and each
    // target's, solved once per matrix.
    solve_near(sources[i], w.solver_s, w.interrupt);
    wide_links(w.solver_s, w, l, w.wide_s);
    w.source_position = sources[i].position(*mesh_);
    for (std::size_t j : near) {
      if (solver_t_holds != j) {  // the join reads the target's solve too
        solve_near(targets[j], w.solver_t, w.interrupt);
        solver_t_holds = j;
      }
      if (!w.has_wide[j]) {
        wide_links(w.solver_t, w, w.many[S + j], w.wide[j]);
        w.has_wide[j] = 1;
      }
      w.target_position = targets[j].position(*mesh_);
      out[i * T + j] = join_or_search(w, w.solver_s, w.wide_s, w.solver_t, w.wide[j]).distance;
    }
  }
  return out;
}

}  // namespace geoprox
