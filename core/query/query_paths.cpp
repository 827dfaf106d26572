// Paths: the graph path's sample-to-sample segments traced from stored directions (or solved
// exactly), and the links' pieces at both ends.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "core/base/errors.h"
#include "core/query/query_engine.h"

namespace geoprox::detail {

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

void QueryEngine::append_segment(QueryScratch::Impl& s, std::uint32_t from_sample,
                                 std::uint32_t to_sample, std::uint32_t edge,
                                 PathResult& out) const {
  // The edge runs from one of the two samples to the other; orient it from `a` to `b`.
  const std::uint32_t a = graph_.edge_target[edge] == to_sample ? from_sample : to_sample;
  const std::uint32_t b = a == from_sample ? to_sample : from_sample;
  const double length = graph_.edge_distance[edge];
  const double tolerance = tuning::kTraceTolerance * length;
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
                      rest * (1 + tuning::kRelativeSlack) + tolerance, s.solver_s, s.interrupt);
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
std::vector<PathPoint> QueryEngine::link_piece(const SurfacePoint& p, const Links& links,
                                               std::uint32_t sample, QueryScratch::Impl& s,
                                               ExactGeodesicSolver& solver) const {
  std::size_t k = 0;
  while (k < links.samples.size() && links.samples[k].first != sample) ++k;
  GEOPROX_ASSERT(k < links.samples.size(), "path through a sample that is not linked");
  const SurfacePoint& target = sample_points_[sample];
  const auto [vertex, to_vertex] = links.via[k];
  if (vertex == kDirect)
    return exact_piece(p, target, links.samples[k].second, solver, s.interrupt);
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

PathResult QueryEngine::path(const SurfacePoint& s, const SurfacePoint& t,
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

}  // namespace geoprox::detail
