// Point-to-point answers: linking a pair, near pairs' exact disks and their joining, exact
// answers under exact_within, and distance().
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "core/base/errors.h"
#include "core/query/query_engine.h"

namespace geoprox::detail {

// ---------------------------------------------------------------------------------------------
// Point to point.


// Links both points; returns the exact distance when they are within the link radius (then the
// links are not needed), else kInfinity. Exactness is decided by one solve out to rho from s,
// skipped when the straight line already says the points are farther apart. `solved_s` /
// `solved_t` say that an exact answer comes from solver_s / solver_t.
double QueryEngine::link_pair(const SurfacePoint& s, const SurfacePoint& t, QueryScratch::Impl& w,
                              bool& solved_s, bool& solved_t) const {
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
// Directed at the pair's other point `toward` (near_disks_directed(); `pair_bound` the pair's
// graph answer), the disk keeps only the points x with d(p, x) + |x toward| within that answer
// (ExactGeodesicOptions::goal_limit). Every route shorter than the answer that the wide links
// or the join could take stays inside it: the rest of the disk cannot improve the answer. That
// part costs a fraction of the disk, so it reaches farther on a smaller budget
// (kDirectedNearWork).
void QueryEngine::solve_near(const SurfacePoint& p, ExactGeodesicSolver& solver,
                             const QueryInterrupt* interrupt, const SurfacePoint* toward,
                             double pair_bound) const {
  const double scale = sparseness(p, tuning::kSparseFaceForWork);
  ExactGeodesicOptions bounded;
  bounded.min_distance = tuning::kNearRadius * link_radius_;
  bounded.max_distance = tuning::kNearReach * bounded.min_distance;
  // At least as far as p's link solve would go without its vertex limit
  // (link_solve_vertices): the wide links then take every path such links would. Only where
  // that limit applies: not to vertices (cover rows), nor to exact links (link_solve_edges 0).
  if (tuning_.link_solve_vertices > 0 && tuning_.link_solve_edges > 0 &&
      p.kind != SurfacePoint::Kind::Vertex) {
    bounded.min_distance = std::max(bounded.min_distance, link_solve_radius(p).radius);
  }
  double work = scale * static_cast<double>(near_windows_);
  bounded.interrupt = interrupt;
  if (toward != nullptr) {
    work *= tuning::kDirectedNearWork;
    bounded.goal = toward->position(*mesh_);
    bounded.goal_limit = pair_bound * (1 + tuning::kRelativeSlack);
  }
  bounded.max_windows_propagated = static_cast<std::size_t>(work);
  solver.solve(p, bounded);
}

// Whether near disks are directed at the pair's other point (solve_near): where straight lines
// bound geodesics from below, under the mesh's own lengths.
bool QueryEngine::near_disks_directed() const {
  return tuning_.directed_near_disks && geometry_->lengths_are_chords();
}

// p's links (`narrow`, as link_pair() made them), improved through every vertex of its near
// disk (solver holds that solve, solve_near()); keeps the disk's distances for joining with the
// other point's disk.
void QueryEngine::wide_links(const ExactGeodesicSolver& solver, QueryScratch::Impl& s,
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
// Over 100 lines: the three stages share the best point so far and the stamps of one scan.
double QueryEngine::join_disks(QueryScratch::Impl& s, const ExactGeodesicSolver& a,
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
  // edges around the best common vertex miss it (a pair could be answered twice too long).
  // Such a crossing may cover a small part of the edge: it is bracketed by a scan
  // before the golden-section search.
  const double long_edge = tuning::kNearRadius * link_radius_;
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
// positions are set, as answer() leaves them for its search; `graph_distance` is the search's
// answer). Leaves solver_s / solver_t holding the solves from s / t and links_s / links_t the
// wide links, for paths.
PairAnswer QueryEngine::answer_near(const SurfacePoint& s, const SurfacePoint& t,
                                    double graph_distance, QueryScratch::Impl& w) const {
  // Each disk afresh, the same whichever point is s. The two solves are most of a near pair's
  // time and independent: a server with an idle thread runs them at once.
  const bool directed = near_disks_directed();
  const auto near_s = [&] {
    solve_near(s, w.solver_s, w.interrupt, directed ? &t : nullptr, graph_distance);
  };
  const auto near_t = [&] {
    solve_near(t, w.solver_t, w.interrupt, directed ? &s : nullptr, graph_distance);
  };
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
PairAnswer QueryEngine::join_or_search(QueryScratch::Impl& s, const ExactGeodesicSolver& a,
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
double QueryEngine::sparseness(const SurfacePoint& p, double knee) const {
  const double ratio = mean_face_edge(p.in_face(*mesh_).first) / mean_edge_length_;
  return std::clamp(ratio / knee, 1.0, tuning::kMaxSparseness);
}

// Near pairs: the graph's answer (an upper bound of the distance, and symmetric) under
// refine_within rho, or farther for a point among large triangles, whose graph paths bend more.
bool QueryEngine::refines(const SurfacePoint& s, const SurfacePoint& t,
                          double graph_distance) const {
  return options_.refine_within > 0 &&
         graph_distance <= options_.refine_within * link_radius_ *
                               std::max(sparseness(s, tuning::kSparseFaceForRefinement),
                                        sparseness(t, tuning::kSparseFaceForRefinement));
}

PairAnswer QueryEngine::answer(const SurfacePoint& s, const SurfacePoint& t,
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
  if (refines(s, t, a.distance)) return answer_near(s, t, a.distance, w);
  return a;
}

// tuning::kFieldExactRadii rho where near pairs are answered exactly (exact_within > 0, under the
// mesh's own lengths), else rho.
double QueryEngine::field_exact_radius() const {
  const bool wide = options_.exact_within > 0 && geometry_->lengths_are_chords();
  return (wide ? tuning::kFieldExactRadii : 1.0) * link_radius_;
}

// Whether a pair with this graph answer is solved exactly: under exact_within rho, under the
// mesh's own lengths (the goal's straight-line bound needs them).
bool QueryEngine::solves_exactly(double graph_distance) const {
  return options_.exact_within > 0 && geometry_->lengths_are_chords() &&
         graph_distance < options_.exact_within * link_radius_;
}

// Such a pair's exact distance from one solve bounded by its graph answer (never below the
// distance: a real path) and directed at t, an ellipse around the geodesic. kInfinity for other
// pairs, or should the solve not reach t (it always does: the bound is a path's length, plus
// rounding's share).
double QueryEngine::solve_exactly(const SurfacePoint& s, const SurfacePoint& t,
                                  double graph_distance, ExactGeodesicSolver& solver,
                                  const QueryInterrupt* interrupt) const {
  if (!solves_exactly(graph_distance)) return kInfinity;
  solve_towards(s, t, graph_distance * (1 + tuning::kRelativeSlack), solver, interrupt);
  return solver.settled_targets().empty() ? kInfinity : solver.settled_target_distances()[0];
}

// The solver that holds the exact answer for (s, t) afterwards, with a settled target: solver_s
// (from s, towards t) or, when the query solved the pair from t, solver_t.
const ExactGeodesicSolver& QueryEngine::solve_pair_exactly(const SurfacePoint& s,
                                                           const SurfacePoint& t,
                                                           QueryScratch::Impl& w,
                                                           double& distance) const {
  // The graph's answer bounds the solve, which makes far pairs cheap. Without the
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
  if (bound < kInfinity)
    solve_towards(s, t, bound * (1 + tuning::kRelativeSlack), w.solver_s, w.interrupt);
  if (!(bound < kInfinity) || w.solver_s.settled_targets().empty()) {
    solve_towards(s, t, kInfinity, w.solver_s, w.interrupt);
  }
  if (w.solver_s.settled_targets().empty()) throw unreachable(s, t);
  distance = w.solver_s.settled_target_distances()[0];
  return w.solver_s;
}

DistanceResult QueryEngine::exact_distance(const SurfacePoint& s, const SurfacePoint& t,
                                           QueryScratch& scratch) const {
  s.validate(*mesh_);
  t.validate(*mesh_);
  DistanceResult result;
  result.exact = true;
  solve_pair_exactly(s, t, *scratch.impl_, result.distance);
  return result;
}

PathResult QueryEngine::exact_path(const SurfacePoint& s, const SurfacePoint& t,
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

DistanceResult QueryEngine::distance(const SurfacePoint& s, const SurfacePoint& t,
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

}  // namespace geoprox::detail
