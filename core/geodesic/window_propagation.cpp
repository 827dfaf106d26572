// The exact solver's window propagation: pseudo-sources' windows, windows unfolded across faces,
// trimmed against the vertices and against the other windows of their edge, listed and queued;
// targets' estimates updated as windows and vertices reach their faces.
#include "core/geodesic/window_propagation.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <span>
#include <string>
#include <tuple>

#include "core/base/errors.h"
#include "core/base/nearly_sorted.h"

namespace geoprox::detail {

// The functions that create windows (propagate, and the two that call it or emit a
// pseudo-source's windows) have everything they call inlined: creating, trimming, listing and
// queueing a child, relaxing a corner. Every XMM register is caller-saved, so each of those
// calls would spill and reload the caller's live doubles. This is why window creation,
// trimming, propagation and the targets' updates share this one source file: flatten inlines
// only what the translation unit defines. Flattening the solve's main loop as well is slower.
#if defined(__GNUC__)
#define GEOPROX_INLINE_CALLEES [[gnu::flatten]]
#else
#define GEOPROX_INLINE_CALLEES
#endif

void WindowPropagation::touch_face(std::uint32_t f) {
  if (face_stamp_[f] != generation_) {
    face_stamp_[f] = generation_;
    face_first_seed_[f] = -1;
  }
}

void WindowPropagation::relax_vertex(std::uint32_t v, double distance, std::int32_t via_window,
                                     std::int32_t via_vertex, std::uint32_t source_index) {
  if (!(distance < vertex_distance_[v])) return;
  if (vertex_distance_[v] == kInfinity) {  // first reached in this solve
    touched_vertices_.push_back(v);
    vertex_emitted_[v] = 0;
  }
  vertex_distance_[v] = distance;
  vertex_via_window_[v] = via_window;
  vertex_via_vertex_[v] = via_vertex;
  vertex_source_[v] = source_index;
  if (!vertex_emitted_[v] &&
      (geometry_->is_pseudo_source(v) || via_vertex == kViaSourceVertex)) {
    push(distance, kVertexItem | v);
    // Emitting reads v's fan from the mesh, which no window brought into cache: start now,
    // long before the vertex is popped (the list itself is requested when it is next; see run).
    mesh_->prefetch_outgoing_index(v);
    geometry_->prefetch_vertex(v);
  }
  if (targets_) update_targets_at_vertex(v);
}

double WindowPropagation::incoming_angle(std::uint32_t v, std::uint32_t& fan_start) const {
  // Angular coordinate around interior vertex v (0 at the halfedge fan_start, counter-clockwise,
  // up to angle_sum(v)) of the direction in which its shortest path arrives, pointing back to
  // the source; NaN when unknown (then v emits in every direction).
  const IntrinsicGeometry& g = *geometry_;
  constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();
  const std::int32_t via_vertex = vertex_via_vertex_[v];
  const std::int32_t via_window = vertex_via_window_[v];
  std::uint32_t corner_halfedge;  // outgoing halfedge of v starting the corner holding it
  double angle_in_corner;
  if (via_vertex >= 0) {
    corner_halfedge = UINT32_MAX;
    for (std::uint32_t h : mesh_->outgoing_halfedges(v)) {
      if (mesh_->target(h) == static_cast<std::uint32_t>(via_vertex)) corner_halfedge = h;
    }
    if (corner_halfedge == UINT32_MAX) return kUnknown;
    angle_in_corner = 0;
  } else if (via_window >= 0) {
    const Window& w = windows_[static_cast<std::size_t>(via_window)];
    const HalfedgeCrossing& crossing = g.crossing(w.halfedge);
    if (crossing.opposite != v) return kUnknown;
    const HalfedgeLayout& lay = crossing.layout;
    corner_halfedge = TriangleMesh::prev(w.halfedge);  // c -> a
    const double ax = -lay.cx, ay = -lay.cy, qx = w.sx - lay.cx, qy = w.sy - lay.cy;
    angle_in_corner = std::atan2(cross2(ax, ay, qx, qy), ax * qx + ay * qy);
    angle_in_corner = std::clamp(angle_in_corner, 0.0, g.corner_angle(corner_halfedge));
  } else if (via_vertex <= kViaSeedBase) {
    const Seed& seed = seeds_[static_cast<std::size_t>(kViaSeedBase - via_vertex)];
    int corner = 0;
    while (mesh_->face(seed.face)[corner] != v) ++corner;
    corner_halfedge = 3 * seed.face + static_cast<std::uint32_t>(corner);
    const Vec2 c = geometry_->face_corner(seed.face, corner);
    const Vec2 n = geometry_->face_corner(seed.face, (corner + 1) % 3);
    const double ax = n.x - c.x, ay = n.y - c.y, qx = seed.point.x - c.x, qy = seed.point.y - c.y;
    angle_in_corner = std::max(0.0, std::atan2(cross2(ax, ay, qx, qy), ax * qx + ay * qy));
  } else {
    return kUnknown;
  }
  fan_start = corner_halfedge;
  return angle_in_corner;
}

GEOPROX_INLINE_CALLEES
void WindowPropagation::emit_pseudo_source(std::uint32_t v) {
  vertex_emitted_[v] = 1;
  const double d = vertex_distance_[v];
  const std::uint32_t source_index = vertex_source_[v];
  const IntrinsicGeometry& g = *geometry_;
  for (std::uint32_t h : mesh_->outgoing_halfedges(v)) {
    // h = v -> a in face (v, a, b): the neighbours a and b.
    g.prefetch_corner_angle(h);  // read when the shadow is walked, below
    const HalfedgeCrossing& crossing = g.crossing(h);
    // The windows go beyond the far edge a -> b, on halfedges that rarely hold any yet: what
    // creating them reads there starts loading now.
    if (crossing.twin_next >= 0) {
      prefetch_window_creation(static_cast<std::uint32_t>(crossing.twin_next));
    }
    const auto via = static_cast<std::int32_t>(v);
    relax_vertex(crossing.target, d + crossing.layout.length, -1, via, source_index);
    relax_vertex(crossing.opposite, d + g.layout(TriangleMesh::prev(h)).length, -1, via,
                 source_index);
  }

  // A shortest path bends at a saddle only into its shadow: the directions at least pi away
  // from the incoming direction on both sides. Everything else is reached straight past v by
  // the windows that reached v, so v emits windows only into the shadow.
  std::uint32_t fan_start = 0;
  const bool interior = !mesh_->is_boundary_vertex(v) &&
                        vertex_via_vertex_[v] != kViaSourceVertex && !g.is_degenerate_vertex(v);
  const double incoming = interior ? incoming_angle(v, fan_start) : std::nan("");
  if (std::isnan(incoming)) {
    for (std::uint32_t h : mesh_->outgoing_halfedges(v)) emit_into_corner(v, h, 0, kInfinity);
    return;
  }
  constexpr double kPi = 3.14159265358979323846;
  constexpr double kAngleSlack = 1e-9;
  const double total = g.angle_sum(v);
  const double shadow_begin = incoming + kPi - kAngleSlack;
  const double shadow_end = incoming + total - kPi + kAngleSlack;
  if (shadow_end < shadow_begin) return;
  double phi = 0;
  std::uint32_t h = fan_start;
  do {
    const double corner = g.corner_angle(h);
    // The corner spans [phi, phi + corner]; the shadow may wrap once around the vertex.
    for (double shift : {0.0, total}) {
      const double lo = std::max(phi, shadow_begin - shift);
      const double hi = std::min(phi + corner, shadow_end - shift);
      if (lo <= hi) emit_into_corner(v, h, lo - phi, hi - phi);
    }
    phi += corner;
    const std::int32_t t = g.crossing(h).twin_prev;  // the next outgoing halfedge of v
    GEOPROX_ASSERT(t >= 0, "interior vertex fan is open");
    h = static_cast<std::uint32_t>(t);
  } while (h != fan_start);
}

void WindowPropagation::emit_into_corner(std::uint32_t v, std::uint32_t h, double angle_begin,
                                         double angle_end) {
  // Face of h = v -> a, with third corner b; the window goes on the far side of edge a -> b,
  // covering the rays from v at angles [angle_begin, angle_end] from v -> a towards v -> b.
  const IntrinsicGeometry& g = *geometry_;
  // -1 on a boundary and across a short side (see propagate): a and b, v's neighbours, are
  // reached already.
  const std::int32_t t = g.crossing(h).twin_next;  // across a -> b
  if (t < 0) return;
  // In the frame of a -> b: a = (0,0), b = (L,0), v = (cx, cy).
  const HalfedgeLayout& lay = g.layout(TriangleMesh::next(h));
  const double L = lay.length;
  if (L <= 0) return;
  double x0 = 0, x1 = L;
  if (angle_begin > 0 || angle_end < kInfinity) {
    const double ax = -lay.cx, ay = -lay.cy;
    const double alen = length2(ax, ay);
    auto hit = [&](double angle) {
      const double c = std::cos(angle), s = std::sin(angle);
      const double dx = (ax * c - ay * s) / alen, dy = (ax * s + ay * c) / alen;
      if (dy >= 0) return angle <= 0 ? 0.0 : L;
      return std::clamp(lay.cx + (-lay.cy / dy) * dx, 0.0, L);
    };
    x0 = angle_begin > 0 ? hit(angle_begin) : 0.0;
    x1 = angle_end < kInfinity ? hit(angle_end) : L;
    if (x1 < x0) std::swap(x0, x1);
  }
  create_window(static_cast<std::uint32_t>(t), L - x1, L - x0, {L - lay.cx, -lay.cy},
                vertex_distance_[v], -1, static_cast<std::int32_t>(v), vertex_source_[v]);
}

bool WindowPropagation::trim_window(Window& w, double& key) const {
  const HalfedgeCrossing& crossing = geometry_->crossing(w.halfedge);
  const HalfedgeLayout& lay = crossing.layout;
  const double L = lay.length;
  const double scale = w.sigma + std::abs(w.sx) + std::abs(w.sy) + L;
  const double slack = tuning::kPruneSlack * scale;
  // The distances at the interval's ends, recomputed only when an end moves.
  double d0 = w.distance_at(w.b0), d1 = w.distance_at(w.b1);

  // Through vertex a (x = 0): D(x) - x is non-increasing, so a dominates a prefix [b0, x*].
  const double da = vertex_estimate(crossing.origin);
  if (da < kInfinity) {
    if (d1 - w.b1 > da + slack) return false;
    if (d0 - w.b0 > da + slack) {
      const double kk = da + slack - w.sigma;
      const double denom = 2 * (kk + w.sx);
      if (denom > 0) {
        const double x = (w.sx * w.sx + w.sy * w.sy - kk * kk) / denom;
        w.b0 = std::clamp(x, w.b0, w.b1);
        d0 = w.distance_at(w.b0);
      }
    }
  }
  // Through vertex b (x = L): D(x) - (L - x) is non-decreasing: b dominates a suffix.
  const double db = vertex_estimate(crossing.target);
  if (db < kInfinity) {
    if (d0 - (L - w.b0) > db + slack) return false;
    if (d1 - (L - w.b1) > db + slack) {
      const double kk = db + slack - w.sigma + L;
      const double denom = 2 * (kk - w.sx);
      if (denom > 0) {
        const double x = (kk * kk - w.sx * w.sx - w.sy * w.sy) / denom;
        w.b1 = std::clamp(x, w.b0, w.b1);
        d1 = w.distance_at(w.b1);
      }
    }
  }
  if (w.b1 < w.b0) return false;
  // Through the opposite vertex c of the face the window enters.
  const double dc = vertex_estimate(crossing.opposite);
  if (dc < kInfinity) {
    const double c0 = length2(lay.cx - w.b0, lay.cy);
    const double c1 = length2(lay.cx - w.b1, lay.cy);
    if (dc >= w.sigma) {
      // {q : |Sq| - |cq| > dc - sigma} is convex when dc >= sigma (inside a hyperbola branch).
      if (d0 > dc + c0 + slack && d1 > dc + c1 + slack) return false;
    } else {
      double lowest = std::min(d0, d1);
      if (w.sx > w.b0 && w.sx < w.b1) lowest = w.sigma - w.sy;
      if (lowest > dc + std::max(c0, c1) + slack) return false;
    }
  }
  // The key from the end distances already at hand (window_key without its square roots).
  key = w.sx < w.b0 ? d0 : (w.sx > w.b1 ? d1 : w.sigma - w.sy);
  return true;
}

double WindowPropagation::goal_bound(const Window& w) const {
  // The straight-line distance from the goal to the window's interval, on the chord from the
  // halfedge's origin to its target (the edge lengths being the chords, b0 and b1 map onto it
  // by their fraction of the length). Computed on the points themselves, not from the sides of
  // the triangle (a, b, goal): that loses half the digits where the goal is near the line.
  const HalfedgeCrossing& crossing = geometry_->crossing(w.halfedge);
  const Vec3& a = mesh_->position(crossing.origin);
  const Vec3 ab = mesh_->position(crossing.target) - a;
  const double L = crossing.layout.length;
  const double chord2 = dot(ab, ab);
  double t = chord2 > 0 ? dot(*goal_ - a, ab) / chord2 : 0.0;
  if (L > 0) t = std::clamp(t, w.b0 / L, w.b1 / L);
  return norm(a + t * ab - *goal_);
}

double WindowPropagation::window_key(const Window& w) {
  if (w.sx < w.b0) return w.sigma + length2(w.b0 - w.sx, w.sy);
  if (w.sx > w.b1) return w.sigma + length2(w.sx - w.b1, w.sy);
  return w.sigma - w.sy;
}

namespace {

// Distance along an edge through one window, in the frame of one halfedge of that edge:
// sigma + sqrt((x - a)^2 + hsq) for x in [lo, hi].
struct EdgeDistance {
  double a, hsq, sigma, lo, hi;
  double at(double x) const { return sigma + std::sqrt((x - a) * (x - a) + hsq); }
};

// Up to two x where f(x) = g(x), from squaring the equation twice; spurious roots of the squared
// equation are harmless because callers only use them to cut [lo, hi] into pieces of constant
// sign and test each piece at its midpoint.
int crossings(const EdgeDistance& f, const EdgeDistance& g, double origin, double roots[2]) {
  // Work relative to `origin` (inside the overlap) to keep the squared terms small.
  const double fa = f.a - origin, ga = g.a - origin;
  const double delta = g.sigma - f.sigma;
  const double p = 2 * (ga - fa);
  const double r = fa * fa + f.hsq - ga * ga - g.hsq - delta * delta;
  const double d2 = 4 * delta * delta;
  const double qa = p * p - d2;
  const double qb = 2 * p * r + 2 * d2 * ga;
  const double qc = r * r - d2 * (ga * ga + g.hsq);
  const double scale = std::abs(qa) + std::abs(qb) + std::abs(qc);
  if (scale == 0) return 0;
  int n = 0;
  if (std::abs(qa) <= 1e-14 * scale) {
    if (qb == 0) return 0;
    roots[n++] = -qc / qb;
  } else {
    const double disc = qb * qb - 4 * qa * qc;
    // A slightly negative discriminant is a rounded double root: keep it as a cut.
    const double sq = disc > 0 ? std::sqrt(disc) : 0.0;
    const double q = -0.5 * (qb + (qb >= 0 ? sq : -sq));
    roots[n++] = q / qa;
    if (q != 0) roots[n++] = qc / q;
  }
  for (int i = 0; i < n; ++i) roots[i] += origin;
  return n;
}

// Compares two windows' distances over the overlap of their intervals and shrinks each one to
// drop a prefix and/or suffix where the other is shorter by more than `slack` (a stretch in the
// middle stays: a window is one interval). Sets mine_alive / theirs_alive to false when nothing
// of that window is left.
void trim_pair(EdgeDistance& mine, EdgeDistance& theirs, double slack, bool& mine_alive,
               bool& theirs_alive) {
  mine_alive = theirs_alive = true;
  const double lo = std::max(mine.lo, theirs.lo), hi = std::min(mine.hi, theirs.hi);
  if (!(hi > lo)) return;
  double cuts[4] = {lo, 0, 0, 0};
  int n = 1;
  double roots[2];
  const int nr = crossings(mine, theirs, 0.5 * (lo + hi), roots);
  for (int i = 0; i < nr; ++i) {
    if (roots[i] > lo && roots[i] < hi) cuts[n++] = roots[i];
  }
  if (n == 3 && cuts[1] > cuts[2]) std::swap(cuts[1], cuts[2]);
  cuts[n++] = hi;
  const int pieces = n - 1;
  // Between consecutive crossings the sign of the difference is constant: test the middle.
  int winner[3];  // +1: theirs shorter there, -1: mine shorter, 0: tie within slack
  for (int i = 0; i < pieces; ++i) {
    const double mid = 0.5 * (cuts[i] + cuts[i + 1]);
    const double dm = mine.at(mid), dt = theirs.at(mid);
    winner[i] = dt + slack < dm ? 1 : (dm + slack < dt ? -1 : 0);
  }
  auto shrink = [&](EdgeDistance& w, int loser_sign, bool& alive) {
    double new_lo = w.lo, new_hi = w.hi;
    if (lo <= w.lo) {
      for (int i = 0; i < pieces && winner[i] == loser_sign; ++i) new_lo = cuts[i + 1];
    }
    if (hi >= w.hi) {
      for (int i = pieces - 1; i >= 0 && winner[i] == loser_sign; --i) new_hi = cuts[i];
    }
    if (new_lo >= new_hi) {
      alive = false;
      return;
    }
    w.lo = new_lo;
    w.hi = new_hi;
  };
  shrink(mine, 1, mine_alive);
  shrink(theirs, -1, theirs_alive);
}

}  // namespace

bool WindowPropagation::trim_against_edge_windows(Window& w) {
  // Windows entering the same face through the same edge reach the same edge points; where
  // another is strictly shorter, every path through this one could be shortened by switching
  // to it. Windows crossing the edge the other way (on the twin halfedge) are left to the
  // vertex filters of the face they enter: they rarely overlap a new window, and walking them
  // costs more time than the few windows it would save.
  const std::uint32_t h = w.halfedge;
  const double L = geometry_->layout(h).length;
  EdgeDistance mine{w.sx, w.sy * w.sy, w.sigma, w.b0, w.b1};
  const double slack = tuning::kPruneSlack * (w.sigma + std::abs(w.sx) + std::abs(w.sy) + L);
  bool alive = true;
  // Listed spans are rounded outwards to float; the query interval is widened by a margin
  // that exceeds float rounding of anything in [0, L] (2^-24 L), so plain conversion keeps the
  // screen conservative. The exact overlap test follows on the window itself. The screen is
  // taken once, with the interval before this walk trims it: a superset of what overlaps later.
  const double margin = 1e-6 * L;
  const auto qlo = static_cast<float>(mine.lo - margin);
  const auto qhi = static_cast<float>(mine.hi + margin);
  // Only the newest chunk (the last one to five windows listed): comparing with every
  // overlapping window of the edge prunes a few more windows but costs far more time.
  if (const std::int32_t c = first_chunk(h); c >= 0) {
    SpanChunk& chunk = chunks_[c];
    // Sliver overlaps (see tuning::kSliverOverlap) are judged on the listed spans, which contain
    // the windows' intervals, before any window is loaded (a cache miss), and all at once: tested
    // slot by slot, that branch mispredicted about once in three.
    const unsigned slivers = chunk.sliver_mask(static_cast<float>(mine.lo),
                                               static_cast<float>(mine.hi),
                                               static_cast<float>(tuning::kSliverOverlap * L));
    for (unsigned mask = chunk.overlap_mask(qlo, qhi) & ~slivers; mask != 0; mask &= mask - 1) {
      const int slot = std::countr_zero(mask);
      Window& o = windows_[static_cast<std::size_t>(chunk.window[slot] & kListedIndex)];
      if (o.key == kInfinity) {  // dropped since it was listed
        chunk.empty_slot(slot);
        continue;
      }
      if (!(std::min(mine.hi, o.b1) > std::max(mine.lo, o.b0))) continue;
      EdgeDistance theirs{o.sx, o.sy * o.sy, o.sigma, o.b0, o.b1};
      bool mine_alive, theirs_alive;
      trim_pair(mine, theirs, slack, mine_alive, theirs_alive);
      if (!mine_alive) {
        alive = false;
        break;
      }
      // Already unfolded, it keeps what it covered. One whose source lies on the edge's line
      // keeps it too: see keep_source_point.
      if (o.propagated || o.sy == 0) continue;
      // The new window may also cut an ending off a window still waiting in the queue.
      if (!theirs_alive) {
        o.key = kInfinity;
        ++stats_.windows_pruned;
      } else {
        o.b0 = theirs.lo;
        o.b1 = theirs.hi;
      }
    }
  }
  if (w.sy == 0) [[unlikely]] {
    if (const auto kept = keep_source_point(w, mine.lo, mine.hi, alive)) {
      std::tie(mine.lo, mine.hi) = *kept;
      alive = true;
    }
  }
  if (!alive) return false;
  w.b0 = mine.lo;
  w.b1 = mine.hi;
  return true;
}

// Out of line and by value: rare (sources on an edge's line only). Tested inside the walk
// above, or given the walk's interval by reference, it would make the walk keep its values in
// memory rather than registers.
[[gnu::noinline]] std::optional<std::pair<double, double>> WindowPropagation::keep_source_point(
    const Window& w, double lo, double hi, bool alive) const {
  // A window whose source S lies on its edge's line, inside the edge, sees the whole face
  // ahead from S (propagate, sees_face). Along the line its distance and another window's
  // grow at nearly the same rate, so where they tie near S the crossing trim_pair cuts at is
  // ill-conditioned: it can fall a hair short of S, the face ahead then gets nothing from S, and
  // a vertex across it is reached round a corner, too long. So S stays in the interval unless a
  // window of the edge is shorter there.
  const double L = geometry_->layout(w.halfedge).length, s = w.sx;
  if (!strictly_inside_edge(s, L)) return std::nullopt;
  const double kept = std::clamp(s, w.b0, w.b1);  // w's interval before the walk
  if (alive && kept >= lo && kept <= hi) return std::nullopt;
  const double slack =
      tuning::kPruneSlack * (w.sigma + std::abs(s) + L);  // as in the walk (sy = 0)
  bool beaten = false;
  for_each_live_window(w.halfedge, [&](std::int32_t, const Window& o) {
    const bool covers = s >= o.b0 && s <= o.b1;
    beaten = beaten || (covers && o.sigma + length2(s - o.sx, o.sy) + slack < w.sigma);
  });
  if (beaten) return std::nullopt;
  if (!alive) return std::pair{kept, kept};
  return std::pair{std::min(lo, kept), std::max(hi, kept)};
}

void WindowPropagation::create_window(std::uint32_t halfedge, double b0, double b1, Vec2 source,
                                      double sigma, std::int32_t parent, std::int32_t root,
                                      std::uint32_t source_index) {
  const double L = geometry_->layout(halfedge).length;
  b0 = std::clamp(b0, 0.0, L);
  b1 = std::clamp(b1, 0.0, L);
  if (!(b1 >= b0)) return;
  // The source must lie behind the edge. One on the edge's line (a vertex on the far side of a
  // zero-area face) still sees the whole face ahead if it lies within the interval; one on the
  // line outside it only grazes the edge, and the points of the edge itself are reached through
  // its end vertices.
  if (!(source.y < -tuning::kOnLineTolerance * (L + std::abs(source.x)))) {
    const double slack = tuning::kVisibilitySlack * L;
    if (!(source.x >= b0 - slack && source.x <= b1 + slack)) {
      ++stats_.windows_pruned;
      return;
    }
    source.y = 0;
    if (source_at_pseudo_source_end(halfedge, source, sigma, parent)) {
      ++stats_.windows_pruned;
      return;
    }
  }
  Window w{b0, b1, 0, source.x, source.y, sigma, halfedge, parent, root, source_index, 0};
  double key;
  if (!trim_window(w, key)) {
    ++stats_.windows_pruned;
    return;
  }
  // Trimming against the edge's windows only raises the key: beyond the limit already, the
  // window would never be popped.
  if (key > store_limit_) {
    skipped_min_key_ = std::min(skipped_min_key_, key);
    ++stats_.windows_beyond_stop;
    return;
  }
  // Not skipped_min_key_: other points nearer than the stop lose their windows here too, but
  // only the target's distance counts in a goal-directed solve.
  if (goal_ && off_goal(key, goal_bound(w))) {
    ++stats_.windows_beyond_stop;
    return;
  }
  const double b0_trimmed = w.b0, b1_trimmed = w.b1;
  if (!trim_against_edge_windows(w)) {
    ++stats_.windows_pruned;
    return;
  }
  // The key trim_window computed holds unless the other windows cut the interval further.
  w.key = w.b0 == b0_trimmed && w.b1 == b1_trimmed ? key : window_key(w);
  const auto index = static_cast<std::uint32_t>(windows_.size());
  GEOPROX_ASSERT(index <= static_cast<std::uint32_t>(kListedIndex), "window index overflow");
  if (windows_.size() >= window_limit_) [[unlikely]] throw_window_limit();
  windows_.push_back(w);
  list_window(halfedge, index, w.b0, w.b1);
  ++stats_.windows_created;
  if (parent < 0) ++stats_.pseudo_source_windows;
  if (!batch_halfedges_) {
    push(w.key, index, halfedge);
  } else if (QueuedHalfedge& queued = halfedge_queued_[halfedge]; queued.key == kInfinity) {
    // One entry per halfedge, keyed by its nearest waiting window.
    queued.key = w.key;
    push(w.key, kHalfedgeItem | index, halfedge);
  } else if (w.key < queued.key) {
    // A nearer newcomer lowers the entry's key in place. Pushing a new entry instead would
    // leave many stale ones (newcomers are mostly a little nearer than the waiting windows),
    // each costing as much as a useful pop.
    queued.key = w.key;
    queue_.decrease(queued.bucket, queued.index,
                    QueueEntry{w.key, kHalfedgeItem | index, halfedge});
  }
  // A window reaches only points of the face it enters (vertex targets hear from relax_vertex).
  if (targets_ && targets_->face_targets_ > 0) {
    update_targets_in_face(TriangleMesh::face_of(halfedge));
  }
}

[[gnu::noinline, noreturn]] void WindowPropagation::throw_window_limit() const {
  throw ResourceExhausted(
      "an exact solve stored " + std::to_string(windows_.size()) + " windows (" +
      std::to_string((windows_.size() * sizeof(Window)) >> 20) + " MiB), the most allowed on a " +
      "mesh of " + std::to_string(mesh_->num_faces()) + " faces (" +
      std::to_string(tuning::kWindowsPerHalfedge) + " per halfedge): a degenerate mesh or a bug");
}

// Out of line: rare, and inlined into every flattened caller of create_window it would cost the
// common path instructions.
[[gnu::noinline]] bool WindowPropagation::source_at_pseudo_source_end(std::uint32_t halfedge,
                                                                        Vec2 source, double sigma,
                                                                        std::int32_t parent) {
  // A source on the edge's line at one of its ends (to rounding: a cluster of coincident
  // vertices) is that corner's own view of the faces around it. Kept, such windows went round
  // the corner from face to face at an unchanging key, for ever: each one's source is again at
  // the end of the next side. A corner that emits in every direction (degenerate, boundary or
  // a source vertex) and is reached at least as near does all their work.
  const HalfedgeCrossing& crossing = geometry_->crossing(halfedge);
  const double L = crossing.layout.length;
  const double coincident = tuning::kCoincident * (geometry_->mean_edge_length() + L);
  for (const auto& [v, x] : {std::pair{crossing.origin, 0.0}, std::pair{crossing.target, L}}) {
    const double gap = std::abs(source.x - x);
    if (!(gap <= coincident)) continue;
    // The parent entered the face this side bounds, so v is one of its corners.
    if (parent >= 0) relax_corner_through(windows_[static_cast<std::size_t>(parent)], parent, v);
    if (!(vertex_distance_[v] <= (sigma + gap) * (1 + tuning::kPruneSlack))) continue;
    if (geometry_->is_degenerate_vertex(v) || mesh_->is_boundary_vertex(v) ||
        vertex_via_vertex_[v] == kViaSourceVertex) {
      return true;
    }
  }
  return false;
}

void WindowPropagation::list_window(std::uint32_t halfedge, std::uint32_t index, double b0,
                                    double b1) {
  HalfedgeState& state = halfedge_state_[halfedge];
  if (state.stamp != generation_) {
    state.stamp = generation_;
    state.first_chunk = -1;
    if (batch_halfedges_) halfedge_queued_[halfedge].key = kInfinity;
    // The faces beyond, which propagating this halfedge will enter, start loading now, long
    // before it is popped: propagate_halfedge then finds their records and can prefetch
    // their far corners' distances, which it needs those records to find.
    const HalfedgeCrossing& crossing = geometry_->crossing(halfedge);
    for (const std::int32_t t : {crossing.twin_prev, crossing.twin_next}) {
      if (t >= 0) __builtin_prefetch(&geometry_->crossing(static_cast<std::uint32_t>(t)));
    }
  }
  std::int32_t head = state.first_chunk;
  int slot = head >= 0 ? chunks_[head].used() : SpanChunk::kCapacity;
  if (slot == SpanChunk::kCapacity) {
    SpanChunk chunk;
    for (int i = 0; i < SpanChunk::kCapacity; ++i) {
      chunk.empty_slot(i);
      chunk.window[i] = -1;
    }
    chunk.next = head;
    head = static_cast<std::int32_t>(chunks_.size());
    chunks_.push_back(chunk);
    state.first_chunk = head;
    slot = 0;
  }
  SpanChunk& chunk = chunks_[head];
  chunk.lo[slot] = round_down_to_float(b0);
  chunk.hi[slot] = round_up_to_float(b1);
  chunk.window[slot] = static_cast<std::int32_t>(index);
}

GEOPROX_INLINE_CALLEES
void WindowPropagation::propagate_halfedge(std::uint32_t h, double key) {
  GEOPROX_ASSERT(halfedge_queued_[h].key == key, "a halfedge's queue entry is out of date");
  halfedge_queued_[h].key = kInfinity;
  // Every window waiting on the halfedge goes now, not only the nearest (the key), as VTP
  // organises its propagation (Qin et al. 2016): the others are no nearer than the key, so
  // the queue stays monotone and whatever is reported final still is, while the face's
  // records, the children's window lists and the corners' estimates are read once for all of
  // them, and the queue holds a fifth as many entries. Their children land on the other two
  // halfedges of the face, never on this one: what creating them reads starts loading now,
  // before the batch is collected and sorted (the same loop as in propagate(), written out
  // again: a shared helper, inlined, was slower). The waiting windows were stored long ago:
  // all of them start loading before the first is propagated (below).
  const HalfedgeCrossing& crossing = geometry_->crossing(h);
  for (const std::int32_t t : {crossing.twin_prev, crossing.twin_next}) {
    if (t >= 0) {
      const auto into = static_cast<std::uint32_t>(t);
      // The face's record was requested when the halfedge got its first window (list_window);
      // its far corner's distance, which trimming the children reads, is requested now.
      __builtin_prefetch(&vertex_distance_[geometry_->crossing(into).opposite]);
      __builtin_prefetch(&halfedge_state_[into]);
      __builtin_prefetch(&halfedge_queued_[into]);
    }
  }
  const std::int32_t first = first_chunk(h);
  for (std::int32_t c = first; c >= 0; c = chunks_[c].next) {
    const SpanChunk& chunk = chunks_[c];
    for (int i = 0, n = chunk.used(); i < n; ++i) {
      if (!(chunk.window[i] & kListedTaken)) __builtin_prefetch(&windows_[chunk.window[i]]);
    }
  }
  // Nearest first, as the window queue would take them: fewer windows and less time than in
  // list order.
  batch_.clear();
  for (std::int32_t c = first; c >= 0; c = chunks_[c].next) {
    SpanChunk& chunk = chunks_[c];
    for (int i = 0, n = chunk.used(); i < n; ++i) {
      if (chunk.window[i] & kListedTaken) continue;
      const auto index = static_cast<std::uint32_t>(chunk.window[i]);
      chunk.window[i] |= kListedTaken;
      if (windows_[index].key == kInfinity) {
        chunk.empty_slot(i);
        continue;
      }
      batch_.emplace_back(windows_[index].key, index);
    }
  }
  // Listed nearly in key order (core/base/nearly_sorted.h).
  sort_nearly_sorted(std::span(batch_));
  for (const auto& entry : batch_) propagate(entry.second);
}

// Unfolds one window into the face beyond its edge: its children on the two far sides, and the
// far corner. Kept whole (over 100 lines): it is the hot path, flattened into one function.
GEOPROX_INLINE_CALLEES
void WindowPropagation::propagate(std::uint32_t index) {
  Window w = windows_[index];
  if (w.key == kInfinity) return;  // dropped since it was queued (it is queued only once)
  // The target's estimate may have fallen since the window was stored (a goal_limit stays).
  if (goal_ && goal_limit_ == kInfinity && off_goal(w.key, goal_bound(w))) return;
  // Not trimmed again against its corners: that rarely changes a popped window and costs much
  // of a solve. A window that a newer one trimmed keeps its
  // old key, a lower bound of its distance: it is propagated a little early, which keeps the
  // queue monotone (its children and vertices are no nearer than its true key) and creates
  // fewer windows than re-queueing it did.
  ++stats_.windows_propagated;
  windows_[index].propagated = 1;

  const HalfedgeCrossing& crossing = geometry_->crossing(w.halfedge);
  // The children land in the neighbouring faces, rarely near this one in memory: start
  // loading what creating them reads while this face's vertices are relaxed.
  for (const std::int32_t t : {crossing.twin_prev, crossing.twin_next}) {
    if (t >= 0) prefetch_window_creation(static_cast<std::uint32_t>(t));
  }
  const HalfedgeLayout& lay = crossing.layout;
  const double L = lay.length, cx = lay.cx, cy = lay.cy;
  const double sx = w.sx, sy = w.sy;
  const auto self = static_cast<std::int32_t>(index);
  const double end_slack = tuning::kVisibilitySlack * L;

  // The window may reach its own end vertices.
  // (Through the interval's end and along the edge, so that the value is a real path.)
  if (w.b0 <= end_slack) {
    relax_vertex(crossing.origin, w.distance_at(w.b0) + w.b0, self, kViaNone, w.source_index);
  }
  if (w.b1 >= L - end_slack) {
    relax_vertex(crossing.target, w.distance_at(w.b1) + (L - w.b1), self, kViaNone,
                 w.source_index);
  }

  if (!(cy - sy > 0)) {
    // Source on the line of a zero-area face (cy = sy = 0): the face is a piece of that line.
    relax_vertex(crossing.opposite, w.sigma + length2(cx - sx, cy - sy), self, kViaNone,
                 w.source_index);
    propagate_along_line(w, self, crossing);
    return;
  }
  // Where the ray from S through the opposite corner c crosses the edge line.
  const double xc = w.crossing_x(cx, cy);
  // A corner not reached yet whose ray passes just outside the interval is reached through
  // its nearer end (a real path, longer by a second-order amount), by a margin on the mesh's
  // scale: windows reaching an edge from different parents agree on their common end only to
  // rounding, and around needles that is coarse (their layouts are good to ~1e-10 of the
  // mesh), so a corner passed by a hair on both sides was left unreachable or reached the long
  // way round. Only a corner not reached yet: one reached already has a value from a ray that
  // hit, or will get one, and an early bent value would only queue a pseudo-source twice.
  const bool seen = xc >= w.b0 - end_slack && xc <= w.b1 + end_slack;
  if (seen || (xc >= w.b0 - end_slack - near_miss_ && xc <= w.b1 + end_slack + near_miss_ &&
               vertex_distance_[crossing.opposite] == kInfinity)) {
    relax_vertex(crossing.opposite, through_window(w, xc, cx, cy), self, kViaNone,
                 w.source_index);
  }

  // Parameter along segment P0 -> P1 where the ray from S through (x, 0) crosses it.
  auto exit_parameter = [&](double x, double p0x, double p0y, double p1x, double p1y) {
    const double dx = x - sx, dy = -sy;
    const double den = cross2(dx, dy, p1x - p0x, p1y - p0y);
    if (den == 0) return x <= xc ? 0.0 : 1.0;
    return std::clamp(cross2(dx, dy, sx - p0x, sy - p0y) / den, 0.0, 1.0);
  };

  // Entry points [b0, xc] go out through edge a -> c, [xc, b1] through c -> b. (Chen & Han's
  // "one angle one split" pruning is subsumed here by trimming windows against the other
  // windows on their edge when they are created.)
  const double left_end = std::min(w.b1, xc), right_begin = std::max(w.b0, xc);
  // A short side (tuning::kShortEdgeRatio) lets no window through: the frame
  // beyond it is unreliable, and its crossing record names no halfedge beyond it, so that the
  // common path tests nothing more (testing the short-side flags here costs the common path
  // instructions).
  // Its ends, corners of a thin face and so pseudo-sources, are reached through this window
  // instead.
  // A source on the edge's line (sy = 0: create_window keeps one only within the interval) is
  // a point of the edge, and from there it sees the whole face: both sides get a child over
  // their whole length. Its rays through the interval run along the line, so without this a
  // side got nothing once trimming had cut the interval down to S itself (a pseudo-source on
  // the long side of a thin face; the points across it were then reached round a corner, too
  // long). With S inside the interval the children below are
  // whole sides anyway. Not at a corner of the face: that corner's own view is its business
  // (source_at_pseudo_source_end), and windows carrying it went round the corner for ever.
  // Tested for every window: tested lazily, or in a cold branch widening the interval, it cost
  // more.
  const bool sees_face = sy == 0 && strictly_inside_edge(sx, L) && sx >= w.b0 - end_slack &&
                         sx <= w.b1 + end_slack;
  // Left child: edge a -> c, entered through twin(prev(h)).
  if (w.b0 < left_end || sees_face) {
    const std::int32_t t = crossing.twin_prev;
    const double lc = geometry_->layout(TriangleMesh::prev(w.halfedge)).length;
    if (t >= 0 && lc > 0) {
      const double t0 = sees_face ? 0.0 : exit_parameter(w.b0, 0, 0, cx, cy);
      const double t1 =
          sees_face || left_end >= xc ? 1.0 : exit_parameter(left_end, 0, 0, cx, cy);
      // Unit vector along a -> c; its length is that edge's length.
      const double ex = cx / lc, ey = cy / lc;
      create_window(static_cast<std::uint32_t>(t), t0 * lc, t1 * lc,
                    {sx * ex + sy * ey, cross2(ex, ey, sx, sy)}, w.sigma, self, w.root,
                    w.source_index);
    } else if (crossing.short_sides & HalfedgeCrossing::kShortPrev) [[unlikely]] {
      reach_short_side_ends(w, self, crossing.origin);
    }
  }
  // Right child: edge c -> b, entered through twin(next(h)).
  if (w.b1 > right_begin || sees_face) {
    const std::int32_t t = crossing.twin_next;
    const double lc = geometry_->layout(TriangleMesh::next(w.halfedge)).length;
    if (t >= 0 && lc > 0) {
      const double t0 =
          sees_face || right_begin <= xc ? 0.0 : exit_parameter(right_begin, cx, cy, L, 0);
      const double t1 = sees_face ? 1.0 : exit_parameter(w.b1, cx, cy, L, 0);
      const double ex = (L - cx) / lc, ey = -cy / lc;  // unit vector along c -> b
      const double rx = sx - cx, ry = sy - cy;
      create_window(static_cast<std::uint32_t>(t), t0 * lc, t1 * lc,
                    {rx * ex + ry * ey, cross2(ex, ey, rx, ry)}, w.sigma, self, w.root,
                    w.source_index);
    } else if (crossing.short_sides & HalfedgeCrossing::kShortNext) [[unlikely]] {
      reach_short_side_ends(w, self, crossing.target);
    }
  }
}

// Out of line: rare (short sides only).
[[gnu::noinline]] void WindowPropagation::reach_short_side_ends(const Window& w, std::int32_t self,
                                                                 std::uint32_t end) {
  // The side runs from the far corner c to `end` (a or b).
  relax_corner_through(w, self, geometry_->crossing(w.halfedge).opposite);
  relax_corner_through(w, self, end);
}

void WindowPropagation::relax_corner_through(const Window& w, std::int32_t index, std::uint32_t v) {
  // As path_to traces it: straight through the interval, or by its nearer end. A corner on the
  // edge is its own crossing point.
  const HalfedgeCrossing& crossing = geometry_->crossing(w.halfedge);
  const HalfedgeLayout& lay = crossing.layout;
  double distance;
  if (v == crossing.opposite) {
    distance = through_window(w, w.crossing_x(lay.cx, lay.cy), lay.cx, lay.cy);
  } else if (v == crossing.origin || v == crossing.target) {
    const double x = v == crossing.origin ? 0.0 : lay.length;
    distance = through_window(w, x, x, 0);
  } else {
    return;  // not a corner of w's face
  }
  relax_vertex(v, distance, index, kViaNone, w.source_index);
}

// Out of line: rare (zero-area faces only), and flattened into propagate() it cost the common
// path registers.
[[gnu::noinline]] void WindowPropagation::propagate_along_line(const Window& w, std::int32_t self,
                                                                const HalfedgeCrossing& crossing) {
  // The window's source S lies on the line of the zero-area face it enters, and so do the
  // face's other two sides: its rays run along the line and go on through them, into the faces
  // beyond, where S lies on the entry edge's line again (create_window keeps such a window if S
  // lies within its interval: it then sees the whole face ahead, as a source on that edge; else
  // the rays only graze that face). Without this a path from a point of a zero-area fin (a
  // face folded onto a boundary edge, or a column of faces between coincident vertices) had to
  // bend at one of the line's vertices. Along the line the rays reach, from S, every point past
  // the interval; when S lies within it, the whole line.
  const HalfedgeLayout& lay = crossing.layout;
  const double L = lay.length, cx = lay.cx, sx = w.sx;
  const double slack = tuning::kVisibilitySlack * L;
  const double mean_edge = geometry_->mean_edge_length();
  double reach_lo = -kInfinity, reach_hi = kInfinity;
  if (sx < w.b0 - slack) reach_lo = w.b0;
  if (sx > w.b1 + slack) reach_hi = w.b1;
  // One child per side: its points run from `from` to `to` on the line (in this halfedge's
  // frame), in the frame of halfedge t whose origin is `from`.
  auto child = [&](std::int32_t t, double from, double to) {
    const double lc = std::abs(to - from);
    if (t < 0 || !(lc > 0)) return;
    const double dir = to > from ? 1.0 : -1.0;
    // Line coordinate x = from + dir * u for u in [0, lc].
    double u0 = dir > 0 ? reach_lo - from : from - reach_hi;
    double u1 = dir > 0 ? reach_hi - from : from - reach_lo;
    u0 = std::max(u0, 0.0);
    u1 = std::min(u1, lc);
    if (!(u1 >= u0)) return;
    const auto h = static_cast<std::uint32_t>(t);
    const double new_sx = dir * (sx - from);
    const double same = 1e-9 * (lc + std::abs(new_sx) + w.sigma) + 1e-12 * mean_edge;
    // S at an end of that side is a corner of this zero-area face, a pseudo-source reached at
    // this distance (below): it emits into the faces around it itself. A window standing for
    // it would carry the corner's view from face to face around a cluster of coincident
    // vertices, with nothing to stop it coming round again.
    if (std::abs(new_sx) <= same || std::abs(new_sx - lc) <= same) return;
    // Along a line of zero-area faces the rays can come back to a side they crossed (a fan of
    // such faces around a vertex): the same window again, no longer and not pruned by the ties
    // it makes. A window there from the same source, over at least this interval, already did
    // the work.
    // (`same` is against the mesh's scale too: in a cluster of coincident vertices the lengths
    // are rounding, and so are the differences between the copies. Windows dropped since count
    // too: a copy of one would only be dropped again.)
    for (std::int32_t c = first_chunk(h); c >= 0; c = chunks_[c].next) {
      const SpanChunk& chunk = chunks_[c];
      for (int i = 0; i < SpanChunk::kCapacity && chunk.window[i] >= 0; ++i) {
        const Window& o = windows_[static_cast<std::size_t>(chunk.window[i] & kListedIndex)];
        if (o.sy == 0 && std::abs(o.sx - new_sx) <= same && std::abs(o.sigma - w.sigma) <= same &&
            o.source_index == w.source_index && o.b0 <= u0 + same && o.b1 >= u1 - same) {
          return;
        }
      }
    }
    create_window(h, u0, u1, {new_sx, 0.0}, w.sigma, self, w.root, w.source_index);
  };
  // The edge's own ends, straight along the line when the rays reach them (the far corner c
  // is relaxed by the caller).
  for (const auto& [v, x] : {std::pair{crossing.origin, 0.0}, std::pair{crossing.target, L}}) {
    if (x >= reach_lo && x <= reach_hi) {
      relax_vertex(v, w.sigma + std::abs(x - sx), self, kViaNone, w.source_index);
    }
  }
  // (None through a short side, whose record names no halfedge: see propagate.)
  child(crossing.twin_prev, 0, cx);  // side a -> c
  child(crossing.twin_next, cx, L);  // side c -> b
}

// ---------------------------------------------------------------------------------------------
// Targets: estimates updated whenever a window or vertex of their face improves.

void WindowPropagation::improve_target(std::uint32_t index, double estimate) {
  TargetState& t = target_state_[index];
  if (t.settled || !(estimate < t.estimate)) return;
  if (t.estimate == kInfinity) touched_targets_.push_back(index);
  t.estimate = estimate;
  target_queue_.push_back({estimate, index});
  std::push_heap(target_queue_.begin(), target_queue_.end(), std::greater<>{});
  if (nearest_wanted_ > 0) track_nearest(index);
}

void WindowPropagation::track_nearest(std::uint32_t index) {
  // nearest_targets_ holds the nearest_wanted_ targets of smallest estimate (distinct targets;
  // estimates only fall, so one outside the set never drops below the set's largest without
  // entering it). Once full, its largest estimate bounds where the solve stops.
  TargetState& t = target_state_[index];
  auto worst = [&] { return target_state_[nearest_targets_[nearest_worst_]].estimate; };
  if (t.in_nearest) {
    // Until the set is full there is no bound (and nearest_worst_ is not maintained).
    if (nearest_targets_.size() < nearest_wanted_ || index != nearest_targets_[nearest_worst_]) {
      return;
    }
  } else if (nearest_targets_.size() < nearest_wanted_) {
    t.in_nearest = true;
    nearest_targets_.push_back(index);
    if (nearest_targets_.size() < nearest_wanted_) return;
  } else if (t.estimate < worst()) {
    target_state_[nearest_targets_[nearest_worst_]].in_nearest = false;
    t.in_nearest = true;
    nearest_targets_[nearest_worst_] = index;
  } else {
    return;
  }
  nearest_worst_ = 0;
  for (std::size_t i = 1; i < nearest_targets_.size(); ++i) {
    if (target_state_[nearest_targets_[i]].estimate > worst()) nearest_worst_ = i;
  }
  // The solve stops once the queue reaches that estimate (or min_distance, or the radius).
  store_limit_ = std::min(max_distance_, std::max(worst(), min_distance_));
}

void WindowPropagation::update_targets_in_face(std::uint32_t face) {
  const std::vector<GeodesicTargets::Entry>& entries = targets_->entries_;
  for (std::int32_t i = targets_->face_first_[face]; i >= 0; i = entries[i].next) {
    improve_target(static_cast<std::uint32_t>(i), best_in_face(face, entries[i].point).distance);
  }
}

void WindowPropagation::update_targets_at_vertex(std::uint32_t v) {
  const std::vector<GeodesicTargets::Entry>& entries = targets_->entries_;
  for (std::int32_t i = targets_->vertex_first_[v]; i >= 0; i = entries[i].next) {
    improve_target(static_cast<std::uint32_t>(i), vertex_distance_[v]);
  }
  if (targets_->face_targets_ == 0) return;
  for (std::uint32_t h : mesh_->outgoing_halfedges(v)) update_targets_in_face(h / 3);
}

// ---------------------------------------------------------------------------------------------
// Queries after a solve.

}  // namespace geoprox::detail
