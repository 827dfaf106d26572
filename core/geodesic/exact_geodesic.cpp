#include "core/geodesic/exact_geodesic.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <span>
#include <string>
#include <tuple>

#include "core/base/errors.h"
#include "core/base/nearly_sorted.h"

namespace geoprox {

namespace {

// Relative slack of the pruning tests: a window is dropped only when an alternative path is
// shorter by more than this fraction of the distances involved, so near-ties never lose the
// shortest path to rounding.
constexpr double kPruneSlack = 1e-12;
// A window's source this close to its edge's line (relative to the edge length plus the
// source's offset along it) lies on the line. A few ulps of that scale, no more: a source a
// hairline (1.3e-9) below the corner of a sliver is 2.3e-14 off the sliver's long side, known
// to 3e-17, and its window fans out through the sliver only near that corner. Taken as on the
// line at 1e-12, the window saw nothing of the sliver and the path beyond went round (3% too
// long on ugly_rectangle(2598, 9); 8000 seeds at each thinness 6, 9, 12 and 15 now all flat).
constexpr double kOnLineTolerance = 1e-14;
// A point this close (relative to the edge length) to a window's end counts as inside it.
// Windows reaching an edge from different parents agree on their common end only to rounding,
// which caps and needles amplify; a vertex in such a hairline gap must still be reached. Taking
// a point up to this far outside costs a distance error of order slack^2 (negligible).
constexpr double kVisibilitySlack = 1e-6;
// Whether x (along an edge of length L) lies inside the edge, clear of both ends by the
// visibility slack: a window's source there on the edge's line is a point of the edge, not a
// corner (propagate's sees_face and keep_source_point agree on this).
bool strictly_inside_edge(double x, double L) {
  const double slack = kVisibilitySlack * L;
  return x > slack && x < L - slack;
}
// Two windows on one halfedge that overlap by less than this (relative to the edge length),
// neither inside the other, are not compared: cutting could only remove that sliver (or, when
// the older one has shrunk inside its listed span, that tiny window). Such overlaps are
// rounding between abutting windows (children of abutting parents): on horse.ply they were
// 46% of the pairs compared, and under 1% of those comparisons changed anything.
constexpr double kSliverOverlap = 1e-5;
constexpr std::uint32_t kVertexItem = 0x80000000u;
constexpr std::uint32_t kHalfedgeItem = 0x40000000u;
// vertex_via_vertex_ codes besides a neighbour id.
constexpr std::int32_t kViaNone = -1;
constexpr std::int32_t kViaSourceVertex = -2;
// kViaSeedBase - i: reached straight from seed i (a source inside one of v's faces).
constexpr std::int32_t kViaSeedBase = -3;

double cross2(double ax, double ay, double bx, double by) { return ax * by - ay * bx; }
// Plain Euclidean length: std::hypot's overflow care costs a fifth of a solve and mesh
// coordinates are nowhere near overflow.
inline double length2(double x, double y) { return std::sqrt(x * x + y * y); }

// A float at or below / at or above x, for x in [-1e30, 1e30] (window spans, whose screens
// must contain the double interval): the nearest float moved outwards by at least two of its
// ulps (|f| 2^-22), so whichever way the conversion and the subtraction round, the result is
// past x, at most three ulps wider than needed. Branch-free: stepping the bit pattern when the
// conversion had rounded the wrong way mispredicted half the time (1-2% of a full solve).
inline float round_down_to_float(double x) {
  const auto f = static_cast<float>(x);
  return f - (std::abs(f) * 0x1p-22f + std::numeric_limits<float>::denorm_min());
}
inline float round_up_to_float(double x) { return -round_down_to_float(-x); }

}  // namespace

// The functions that create windows (propagate, and the two that call it or emit a
// pseudo-source's windows) have everything they call inlined: creating, trimming, listing and
// queueing a child, relaxing a corner. Every XMM register is caller-saved, so each of those
// calls spilled and reloaded the caller's live doubles. Alternated rounds of
// exact_geodesic_bench on lucy and horse: full solves 7-10% faster, bounded solves 6%.
// Flattening run() as well (the whole loop in one function) was slower than this.
#if defined(__GNUC__)
#define GEOPROX_INLINE_CALLEES [[gnu::flatten]]
#else
#define GEOPROX_INLINE_CALLEES
#endif

// Length of the path from a window's source to point (px, py) of the face it enters, whose
// straight line would cross the edge at `x`. Inside the interval that is the straight line; a
// point seen only within the visibility slack is reached through the interval's nearer end, so
// that the distance is always a real path and the backtraced polyline has exactly this length.
double ExactGeodesicSolver::through_window(const Window& w, double x, double px, double py) {
  if (x >= w.b0 && x <= w.b1) return w.sigma + length2(px - w.sx, py - w.sy);
  const double end = x < w.b0 ? w.b0 : w.b1;
  return w.sigma + length2(end - w.sx, w.sy) + length2(px - end, py);
}

namespace {

// Coordinates of point p (given in the frame of face f, i.e. of halfedge 3f) in the frame of
// halfedge 3f + i.
// The frame of halfedge 3f + i seen from the frame of face f: its origin and unit x axis.
struct HalfedgeAxes {
  Vec2 origin;
  double ex, ey;
};
HalfedgeAxes halfedge_axes(const IntrinsicGeometry& g, std::uint32_t f, int i) {
  if (i == 0) return {{0, 0}, 1, 0};
  const Vec2 origin = g.face_corner(f, i);
  const Vec2 to = g.face_corner(f, (i + 1) % 3);
  const double len = g.layout(3 * f + static_cast<std::uint32_t>(i)).length;
  // A zero-length side (coincident corners) has no direction: the face's own axes stand in,
  // so that nothing derived from it (end directions) is NaN.
  if (!(len > 0)) return {origin, 1, 0};
  return {origin, (to.x - origin.x) / len, (to.y - origin.y) / len};
}

Vec2 face_to_halfedge_frame(const IntrinsicGeometry& g, std::uint32_t f, int i, Vec2 p) {
  if (i == 0) return p;
  const HalfedgeAxes a = halfedge_axes(g, f, i);
  const double dx = p.x - a.origin.x, dy = p.y - a.origin.y;
  return {dx * a.ex + dy * a.ey, cross2(a.ex, a.ey, dx, dy)};
}

}  // namespace

struct ExactGeodesicSolver::Candidate {
  enum class Kind { None, Vertex, Window, Seed } kind = Kind::None;
  double distance = kInfinity;
  std::int32_t index = -1;  // vertex id, window index or seed index
  Vec2 point_in_frame{};    // the query point in the window's halfedge frame (Kind::Window)
};

ExactGeodesicSolver::ExactGeodesicSolver(const TriangleMesh& mesh,
                                         const IntrinsicGeometry& geometry)
    : mesh_(&mesh),
      geometry_(&geometry),
      near_miss_(kNearMiss * geometry.mean_edge_length()),
      window_limit_(std::max(kMinWindows, kWindowsPerHalfedge * 3 * mesh.num_faces())) {
  GEOPROX_ASSERT(&geometry.mesh() == &mesh, "geometry was built for another mesh");
  const std::size_t nv = mesh.num_vertices(), nf = mesh.num_faces();
  vertex_distance_.assign(nv, kInfinity);
  vertex_via_window_.assign(nv, -1);
  vertex_via_vertex_.assign(nv, kViaNone);
  vertex_source_.assign(nv, 0);
  vertex_emitted_.assign(nv, 0);
  halfedge_state_.assign(3 * nf, HalfedgeState{0, -1});
  face_stamp_.assign(nf, 0);
  face_first_seed_.assign(nf, -1);
  // Sized to the mesh now, so that no solve (a daemon query's) allocates in proportion to it.
  own_targets_.assign(geometry, {});
}

void ExactGeodesicSolver::reset() {
  // Distances are reset where the last solve set them (no stamp to check on every read).
  for (std::uint32_t v : touched_vertices_) vertex_distance_[v] = kInfinity;
  ++generation_;
  if (generation_ == 0) {  // wrapped: clear the stamps once every 2^32 solves
    std::fill(halfedge_state_.begin(), halfedge_state_.end(), HalfedgeState{0, -1});
    std::fill(face_stamp_.begin(), face_stamp_.end(), 0);
    generation_ = 1;
  }
  windows_.clear();
  chunks_.clear();
  queue_.clear();
  seeds_.clear();
  sources_.clear();
  targets_ = nullptr;
  for (const std::uint32_t i : touched_targets_) target_state_[i] = TargetState{};
  touched_targets_.clear();
  target_queue_.clear();
  settled_targets_.clear();
  settled_distances_.clear();
  touched_vertices_.clear();
  radius_reached_ = kInfinity;
  skipped_min_key_ = kInfinity;
  nearest_targets_.clear();
  stats_ = {};
}

void ExactGeodesicSolver::touch_face(std::uint32_t f) {
  if (face_stamp_[f] != generation_) {
    face_stamp_[f] = generation_;
    face_first_seed_[f] = -1;
  }
}

void ExactGeodesicSolver::HalfedgeEntryPlacement::operator()(const QueueEntry& entry,
                                                             std::uint32_t bucket,
                                                             std::uint32_t index) const {
  // Both bits: a vertex item's index may reach bit 30 (a mesh of 2^30 vertices).
  if ((entry.item & (kVertexItem | kHalfedgeItem)) == kHalfedgeItem) {
    QueuedHalfedge& q = queued[entry.halfedge];
    q.bucket = bucket;
    q.index = index;
  }
}

void ExactGeodesicSolver::push(double key, std::uint32_t item, std::uint32_t halfedge) {
  queue_.push(QueueEntry{key, item, halfedge});
  stats_.peak_queue = std::max(stats_.peak_queue, queue_.size());
}

void ExactGeodesicSolver::pop() {
  ++stats_.queue_pops;
  queue_.pop();
}

void ExactGeodesicSolver::relax_vertex(std::uint32_t v, double distance, std::int32_t via_window,
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

void ExactGeodesicSolver::solve(const SurfacePoint& source, const Options& options) {
  const GeodesicSource one{source, 0.0};
  solve(std::span<const GeodesicSource>(&one, 1), {}, options);
}

std::size_t ExactGeodesicSolver::vertices_within(double distance) const {
  std::size_t count = 0;
  for (const std::uint32_t v : touched_vertices_) count += vertex_distance_[v] <= distance;
  return count;
}

void ExactGeodesicSolver::check_solve_input(std::span<const GeodesicSource> sources,
                                            const Options& options) const {
  for (const GeodesicSource& s : sources) {
    s.point.validate(*mesh_);
    if (!std::isfinite(s.offset) || s.offset < 0) {
      throw InvalidInput(ErrorCode::BadOffset, "source offset " + std::to_string(s.offset) +
                                          " must be finite and non-negative");
    }
  }
  if (std::isnan(options.max_distance) || options.max_distance < 0) {
    throw InvalidInput(ErrorCode::BadRadius, "max_distance must be a non-negative number");
  }
  if (std::isnan(options.min_distance) || options.min_distance < 0) {
    throw InvalidInput(ErrorCode::BadRadius, "min_distance must be a non-negative number");
  }
  if (options.goal && !(std::isfinite(options.goal->x) && std::isfinite(options.goal->y) &&
                        std::isfinite(options.goal->z))) {
    throw InvalidInput(ErrorCode::BadGoal, "the goal position must be finite");
  }
}

void ExactGeodesicSolver::solve(std::span<const GeodesicSource> sources,
                                std::span<const SurfacePoint> targets, const Options& options) {
  check_solve_input(sources, options);
  own_targets_.assign(*geometry_, targets);  // validates the targets first
  run(sources, own_targets_, options);
}

void ExactGeodesicSolver::solve(std::span<const GeodesicSource> sources,
                                const GeodesicTargets& targets, const Options& options) {
  check_solve_input(sources, options);
  // Face targets are placed in the frames of the geometry they were prepared with: the same
  // mesh under another metric would put them elsewhere.
  if (!targets.empty() && targets.geometry_ != geometry_) {
    throw InvalidInput(ErrorCode::TargetsForAnotherGeometry,
                       "the targets were prepared for another mesh or metric than the solver's");
  }
  run(sources, targets, options);
}

void ExactGeodesicSolver::run(std::span<const GeodesicSource> sources,
                              const GeodesicTargets& targets, const Options& options) {
  if (options.goal && targets.size() != 1) {
    throw InvalidInput(ErrorCode::BadGoal, "a goal-directed solve needs exactly one target, got " +
                                      std::to_string(targets.size()));
  }
  reset();
  goal_ = options.goal;
  sources_.assign(sources.begin(), sources.end());
  // Targets are in place before seeding so that seeds already update their estimates.
  targets_ = targets.empty() ? nullptr : &targets;
  const std::size_t num_targets = targets.size();
  if (target_state_.size() < num_targets) target_state_.resize(num_targets);
  targets_wanted_ = options.stop_after_targets == 0
                        ? num_targets
                        : std::min(options.stop_after_targets, num_targets);
  max_distance_ = options.max_distance;
  min_distance_ = options.min_distance;
  store_limit_ = max_distance_;
  // Halfedges collect many waiting windows only when the wavefront is wide (a full solve on
  // horse.ply: 19 per batch; the 36 nearest of 5000 samples on lucy.obj: 3 per pop). Other
  // solves keep one queue entry per window unless asked: solves a few edges wide gain nothing.
  const bool full_solve = !targets_ && max_distance_ == kInfinity &&
                          options.max_windows_propagated == 0 && options.stop_after_vertices == 0;
  batch_halfedges_ = full_solve || options.queue_halfedges;
  // Sized at the first batched solve.
  if (batch_halfedges_ && halfedge_queued_.empty()) {
    halfedge_queued_.assign(halfedge_state_.size(), QueuedHalfedge{kInfinity, 0, 0});
  }
  queue_.placed().queued = halfedge_queued_.data();
  nearest_wanted_ = targets_wanted_ <= kMaxNearestTracked ? targets_wanted_ : 0;

  for (std::uint32_t i = 0; i < sources.size(); ++i) add_source(i, sources[i]);

  bool stopped = false;
  while (!queue_.empty()) {
    const QueueEntry top = queue_.top();
    if (targets_) {
      // Only targets within max_distance count: beyond it nothing is final.
      // Windows not stored (store_limit) start at skipped_min_key_ or farther: nothing beyond
      // that is final.
      settle_targets_up_to(std::min({top.key, options.max_distance, skipped_min_key_}));
      if (settled_targets_.size() >= targets_wanted_ && top.key >= options.min_distance) {
        // A target settled at an earlier pop may lie a few ulps beyond this key (keys are in
        // order only to rounding): it is final, and so is its vertex.
        radius_reached_ = top.key;
        for (double d : settled_distances_) radius_reached_ = std::max(radius_reached_, d);
        stopped = true;
        break;
      }
    }
    if (top.key > options.max_distance) {
      radius_reached_ = options.max_distance;
      stopped = true;
      break;
    }
    if (options.max_windows_propagated != 0 &&
        stats_.windows_propagated >= options.max_windows_propagated &&
        top.key >= options.min_distance) {
      radius_reached_ = top.key;  // every later entry starts at least this far out
      stopped = true;
      break;
    }
    // Counting is a pass over the vertices reached: not at every pop.
    if (options.stop_after_vertices != 0 && (stats_.queue_pops & 15) == 0 &&
        touched_vertices_.size() >= options.stop_after_vertices &&
        top.key >= options.min_distance &&
        vertices_within(top.key) >= options.stop_after_vertices) {
      radius_reached_ = top.key;  // no later entry lowers a distance below its key
      stopped = true;
      break;
    }
    pop();
    if (options.interrupt && (stats_.queue_pops & 1023) == 0) options.interrupt->check();
    // Start loading what the next entry reads while this one is processed.
    if (!queue_.empty() && (queue_.top().item & kVertexItem)) {
      // A pseudo-source is next: its list of outgoing halfedges (the index was requested
      // when the vertex was queued). With the hints in relax_vertex and emit_pseudo_source,
      // solves to the 36 nearest of 5000 samples on lucy.obj are 4% faster.
      mesh_->prefetch_outgoing_halfedges(queue_.top().item & ~kVertexItem);
    } else if (!queue_.empty()) {
      // The next window was stored long ago: start loading it, and its halfedge's crossing
      // record (the queue entry names the halfedge, so this does not wait for the window).
      // About 5% of a solve on lucy and horse.
      const QueueEntry& next = queue_.top();
      __builtin_prefetch(&windows_[next.item & ~kHalfedgeItem]);
      __builtin_prefetch(&geometry_->crossing(next.halfedge));
      if (next.item & kHalfedgeItem) {
        __builtin_prefetch(&halfedge_state_[next.halfedge]);
        __builtin_prefetch(&halfedge_queued_[next.halfedge]);
      }
    }
    if (top.item & kVertexItem) {
      const std::uint32_t v = top.item & ~kVertexItem;
      if (vertex_emitted_[v] || top.key != vertex_distance_[v]) continue;
      if (goal_ && off_goal(top.key, goal_bound(v))) continue;
      emit_pseudo_source(v);
    } else if (top.item & kHalfedgeItem) {
      propagate_halfedge(top.halfedge, top.key);
    } else {
      propagate(top.item);
    }
  }
  // Windows not stored start at skipped_min_key_ or farther: nothing from there on is final.
  radius_reached_ = std::min(radius_reached_, skipped_min_key_);
  // Off-goal windows were dropped against the stop as it stood then, never below its final
  // value: the target is final up to that value, and not beyond.
  if (goal_) radius_reached_ = std::min(radius_reached_, store_limit_);
  if (!stopped && targets_) settle_targets_up_to(radius_reached_);
  for (std::uint32_t v : touched_vertices_) {
    if (vertex_distance_[v] <= radius_reached_) ++stats_.vertices_reached;
  }
  // Targets are settled in order of their estimates; keep only as many as asked for, and all
  // of those within min_distance when one is given (not the default 0: a cluster of coincident
  // vertices at the source would otherwise all be kept, more than asked for).
  std::size_t keep = targets_wanted_;
  while (options.min_distance > 0 && keep < settled_targets_.size() &&
         settled_distances_[keep] <= options.min_distance) {
    ++keep;
  }
  if (settled_targets_.size() > keep) {
    settled_targets_.resize(keep);
    settled_distances_.resize(keep);
  }
}

void ExactGeodesicSolver::add_source(std::uint32_t index, const GeodesicSource& source) {
  const SurfacePoint& p = source.point;
  if (p.kind == SurfacePoint::Kind::Vertex) {
    relax_vertex(p.id, source.offset, -1, kViaSourceVertex, index);
    return;
  }
  auto [face, bary] = p.in_face(*mesh_);
  const IntrinsicGeometry& g = *geometry_;
  const Vec2 at = g.face_point(face, bary.data());
  for (int i = 0; i < 3; ++i) {
    // At a corner, or a rounding error away from it: that vertex is the source (path_to still
    // starts the path at the point). A seed there would send windows round the corner from
    // face to face for ever, each one's source again at the end of the next side.
    const Vec2 corner = g.face_corner(face, i);
    const double gap = length2(at.x - corner.x, at.y - corner.y);
    if (bary[i] >= 1 || gap <= kCoincident * g.mean_edge_length()) {
      relax_vertex(mesh_->face(face)[i], source.offset + gap, -1, kViaSourceVertex, index);
      return;
    }
  }
  seed_face_point(index, source.offset, face, bary);
  // A point on an edge is also a point of the face across it.
  for (int i = 0; i < 3; ++i) {
    if (bary[(i + 2) % 3] > 0) continue;
    const std::int32_t t = mesh_->twin(3 * face + static_cast<std::uint32_t>(i));
    if (t < 0) continue;
    const auto h = static_cast<std::uint32_t>(t);
    std::array<double, 3> across{0, 0, 0};
    across[h % 3] = bary[(i + 1) % 3];
    across[(h % 3 + 1) % 3] = bary[i];
    seed_face_point(index, source.offset, TriangleMesh::face_of(h), across);
  }
}

void ExactGeodesicSolver::seed_face_point(std::uint32_t source_index, double offset,
                                          std::uint32_t face, const std::array<double, 3>& bary) {
  const IntrinsicGeometry& g = *geometry_;
  const Vec2 p = g.face_point(face, bary.data());
  touch_face(face);
  const auto seed_index = static_cast<std::int32_t>(seeds_.size());
  seeds_.push_back({face, p, offset, source_index, face_first_seed_[face]});
  face_first_seed_[face] = seed_index;
  for (int i = 0; i < 3; ++i) {
    const Vec2 corner = g.face_corner(face, i);
    relax_vertex(mesh_->face(face)[i], offset + length2(p.x - corner.x, p.y - corner.y), -1,
                 kViaSeedBase - seed_index, source_index);
  }
  if (targets_) update_targets_in_face(face);
  for (int i = 0; i < 3; ++i) {
    const std::uint32_t h = 3 * face + static_cast<std::uint32_t>(i);
    if (bary[(i + 2) % 3] <= 0) continue;  // the point is on this edge: no window across it
    const std::int32_t t = mesh_->twin(h);
    if (t < 0) continue;
    const HalfedgeLayout& lay = g.layout(h);
    // Not through a short side (see propagate): its ends were relaxed above.
    if (lay.length <= 0 || (g.crossing(h).short_sides & HalfedgeCrossing::kShortSide)) continue;
    const Vec2 ph = face_to_halfedge_frame(g, face, i, p);
    // In the twin's frame (origin at h's target, x towards h's origin) the point lies below.
    create_window(static_cast<std::uint32_t>(t), 0, lay.length, {lay.length - ph.x, -ph.y},
                  offset, -1, -1 - seed_index, source_index);
  }
}

double ExactGeodesicSolver::incoming_angle(std::uint32_t v, std::uint32_t& fan_start) const {
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
void ExactGeodesicSolver::emit_pseudo_source(std::uint32_t v) {
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
  const bool interior = !mesh_->is_boundary_vertex(v) && vertex_via_vertex_[v] != kViaSourceVertex &&
                        !g.is_degenerate_vertex(v);
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

void ExactGeodesicSolver::emit_into_corner(std::uint32_t v, std::uint32_t h, double angle_begin,
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

bool ExactGeodesicSolver::trim_window(Window& w, double& key) const {
  const HalfedgeCrossing& crossing = geometry_->crossing(w.halfedge);
  const HalfedgeLayout& lay = crossing.layout;
  const double L = lay.length;
  const double scale = w.sigma + std::abs(w.sx) + std::abs(w.sy) + L;
  const double slack = kPruneSlack * scale;
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

double ExactGeodesicSolver::goal_bound(const Window& w) const {
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

double ExactGeodesicSolver::window_key(const Window& w) {
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

bool ExactGeodesicSolver::trim_against_edge_windows(Window& w) {
  // Windows entering the same face through the same edge reach the same edge points; where
  // another is strictly shorter, every path through this one could be shortened by switching
  // to it. Windows crossing the edge the other way (on the twin halfedge) are left to the
  // vertex filters of the face they enter: they overlap a new window in under 3% of creations
  // and dropping that walk made solves 2-4% faster with 0.1% more windows.
  const std::uint32_t h = w.halfedge;
  const double L = geometry_->layout(h).length;
  EdgeDistance mine{w.sx, w.sy * w.sy, w.sigma, w.b0, w.b1};
  const double slack = kPruneSlack * (w.sigma + std::abs(w.sx) + std::abs(w.sy) + L);
  bool alive = true;
  // Listed spans are rounded outwards to float; the query interval is widened by a margin
  // that exceeds float rounding of anything in [0, L] (2^-24 L), so plain conversion keeps the
  // screen conservative. The exact overlap test follows on the window itself. The screen is
  // taken once, with the interval before this walk trims it: a superset of what overlaps later.
  const double margin = 1e-6 * L;
  const auto qlo = static_cast<float>(mine.lo - margin);
  const auto qhi = static_cast<float>(mine.hi + margin);
  // Only the newest chunk (the last one to five windows listed): comparing with every
  // overlapping window of the edge, 20 spans screened per new window on horse.ply, pruned 2%
  // more windows there (1.6% on lucy) and cost 11% of a full solve (5% on lucy).
  if (const std::int32_t c = first_chunk(h); c >= 0) {
    SpanChunk& chunk = chunks_[c];
    // Sliver overlaps (see kSliverOverlap) are judged on the listed spans, which contain the
    // windows' intervals, before any window is loaded (a cache miss), and all at once: tested
    // slot by slot, that branch mispredicted about once in three.
    const unsigned slivers = chunk.sliver_mask(static_cast<float>(mine.lo),
                                               static_cast<float>(mine.hi),
                                               static_cast<float>(kSliverOverlap * L));
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
// above, or given the walk's interval by reference, it cost a full solve 1.7-3% of its
// instructions (armadillo, callgrind): the walk's values were kept in memory.
[[gnu::noinline]] std::optional<std::pair<double, double>> ExactGeodesicSolver::keep_source_point(
    const Window& w, double lo, double hi, bool alive) const {
  // A window whose source S lies on its edge's line, inside the edge, sees the whole face
  // ahead from S (propagate, sees_face). Along the line its distance and another window's
  // grow at nearly the same rate, so where they tie near S the crossing trim_pair cuts at is
  // ill-conditioned: it fell 7e-7 of a 0.28 edge short of S on ugly_rectangle(1935, 15), the
  // face ahead got nothing from S, and a vertex across it was reached round a corner, 5% too
  // long. So S stays in the interval unless a window of the edge is shorter there.
  const double L = geometry_->layout(w.halfedge).length, s = w.sx;
  if (!strictly_inside_edge(s, L)) return std::nullopt;
  const double kept = std::clamp(s, w.b0, w.b1);  // w's interval before the walk
  if (alive && kept >= lo && kept <= hi) return std::nullopt;
  const double slack = kPruneSlack * (w.sigma + std::abs(s) + L);  // as in the walk (sy = 0)
  bool beaten = false;
  for_each_live_window(w.halfedge, [&](std::int32_t, const Window& o) {
    const bool covers = s >= o.b0 && s <= o.b1;
    beaten = beaten || (covers && o.sigma + length2(s - o.sx, o.sy) + slack < w.sigma);
  });
  if (beaten) return std::nullopt;
  if (!alive) return std::pair{kept, kept};
  return std::pair{std::min(lo, kept), std::max(hi, kept)};
}

void ExactGeodesicSolver::create_window(std::uint32_t halfedge, double b0, double b1,
                                        Vec2 source, double sigma, std::int32_t parent,
                                        std::int32_t root, std::uint32_t source_index) {
  const double L = geometry_->layout(halfedge).length;
  b0 = std::clamp(b0, 0.0, L);
  b1 = std::clamp(b1, 0.0, L);
  if (!(b1 >= b0)) return;
  // The source must lie behind the edge. One on the edge's line (a vertex on the far side of a
  // zero-area face) still sees the whole face ahead if it lies within the interval; one on the
  // line outside it only grazes the edge, and the points of the edge itself are reached through
  // its end vertices.
  if (!(source.y < -kOnLineTolerance * (L + std::abs(source.x)))) {
    const double slack = kVisibilitySlack * L;
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
    // A nearer newcomer lowers the entry's key in place. Pushing a new entry instead left
    // 1.25M stale ones in a horse solve (8 per batch: newcomers are mostly nearer than the
    // waiting windows by under 1% of the edge), each costing as much as a useful pop.
    queued.key = w.key;
    queue_.decrease(queued.bucket, queued.index,
                    QueueEntry{w.key, kHalfedgeItem | index, halfedge});
  }
  // A window reaches only points of the face it enters (vertex targets hear from relax_vertex).
  if (targets_ && targets_->face_targets_ > 0) {
    update_targets_in_face(TriangleMesh::face_of(halfedge));
  }
}

[[gnu::noinline, noreturn]] void ExactGeodesicSolver::throw_window_limit() const {
  throw ResourceExhausted(
      "an exact solve stored " + std::to_string(windows_.size()) + " windows (" +
      std::to_string((windows_.size() * sizeof(Window)) >> 20) + " MiB), the most allowed on a " +
      "mesh of " + std::to_string(mesh_->num_faces()) + " faces (" +
      std::to_string(kWindowsPerHalfedge) + " per halfedge): a degenerate mesh or a bug");
}

// Out of line: rare, and inlined into every flattened caller of create_window it cost the
// common path 1.1% of a full solve's instructions (armadillo, callgrind).
[[gnu::noinline]] bool ExactGeodesicSolver::source_at_pseudo_source_end(std::uint32_t halfedge,
                                                                        Vec2 source, double sigma,
                                                                        std::int32_t parent) {
  // A source on the edge's line at one of its ends (to rounding: a cluster of coincident
  // vertices) is that corner's own view of the faces around it. Kept, such windows went round
  // the corner from face to face at an unchanging key, for ever: each one's source is again at
  // the end of the next side. A corner that emits in every direction (degenerate, boundary or
  // a source vertex) and is reached at least as near does all their work.
  const HalfedgeCrossing& crossing = geometry_->crossing(halfedge);
  const double L = crossing.layout.length;
  const double coincident = kCoincident * (geometry_->mean_edge_length() + L);
  for (const auto& [v, x] : {std::pair{crossing.origin, 0.0}, std::pair{crossing.target, L}}) {
    const double gap = std::abs(source.x - x);
    if (!(gap <= coincident)) continue;
    // The parent entered the face this side bounds, so v is one of its corners.
    if (parent >= 0) relax_corner_through(windows_[static_cast<std::size_t>(parent)], parent, v);
    if (!(vertex_distance_[v] <= (sigma + gap) * (1 + kPruneSlack))) continue;
    if (geometry_->is_degenerate_vertex(v) || mesh_->is_boundary_vertex(v) ||
        vertex_via_vertex_[v] == kViaSourceVertex) {
      return true;
    }
  }
  return false;
}

void ExactGeodesicSolver::list_window(std::uint32_t halfedge, std::uint32_t index, double b0,
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
void ExactGeodesicSolver::propagate_halfedge(std::uint32_t h, double key) {
  GEOPROX_ASSERT(halfedge_queued_[h].key == key, "a halfedge's queue entry is out of date");
  halfedge_queued_[h].key = kInfinity;
  // Every window waiting on the halfedge goes now, not only the nearest (the key), as VTP
  // organises its propagation (Qin et al. 2016): the others are no nearer than the key, so
  // the queue stays monotone and whatever is reported final still is, while the face's
  // records, the children's window lists and the corners' estimates are read once for all of
  // them, and the queue holds a fifth as many entries. Their children land on the other two
  // halfedges of the face, never on this one: what creating them reads starts loading now,
  // before the batch is collected and sorted (1% of a full solve on horse.ply, against
  // leaving it to propagate(); the same loop as there, written out again: a shared helper,
  // inlined, made horse's solve 4% slower). The waiting windows were stored long ago: all of
  // them start loading before the first is propagated (below).
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
  // Nearest first, as the window queue would take them: 0.8% fewer windows on horse (the
  // count of the window queue) and 7% less time than in list order.
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

GEOPROX_INLINE_CALLEES
void ExactGeodesicSolver::propagate(std::uint32_t index) {
  Window w = windows_[index];
  if (w.key == kInfinity) return;  // dropped since it was queued (it is queued only once)
  // The target's estimate may have fallen since the window was stored.
  if (goal_ && off_goal(w.key, goal_bound(w))) return;
  // Not trimmed again against its corners: on horse, lucy and armadillo that changed 0.3% of
  // popped windows and cost a tenth of a solve. A window that a newer one trimmed keeps its
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
  const double end_slack = kVisibilitySlack * L;

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
  // A short side (IntrinsicGeometryOptions::short_edge_ratio) lets no window through: the frame
  // beyond it is unreliable, and its crossing record names no halfedge beyond it, so that the
  // common path tests nothing more (testing the short-side flags here cost 1.3% of a full
  // solve's instructions on armadillo, 2.6% with the call below placed after both children).
  // Its ends, corners of a thin face and so pseudo-sources, are reached through this window
  // instead.
  // A source on the edge's line (sy = 0: create_window keeps one only within the interval) is
  // a point of the edge, and from there it sees the whole face: both sides get a child over
  // their whole length. Its rays through the interval run along the line, so without this a
  // side got nothing once trimming had cut the interval down to S itself (a pseudo-source on
  // the long side of a thin face; the points across it were then reached round a corner, 10%
  // too long on ugly_rectangle(7246, 15)). With S inside the interval the children below are
  // whole sides anyway. Not at a corner of the face: that corner's own view is its business
  // (source_at_pseudo_source_end), and windows carrying it went round the corner for ever.
  // Testing this for every window costs 0.85% of a full solve's instructions on armadillo
  // (callgrind); tested lazily, or in a cold branch widening the interval, it cost 1.0-1.9%.
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
[[gnu::noinline]] void ExactGeodesicSolver::reach_short_side_ends(const Window& w, std::int32_t self,
                                                                 std::uint32_t end) {
  // The side runs from the far corner c to `end` (a or b).
  relax_corner_through(w, self, geometry_->crossing(w.halfedge).opposite);
  relax_corner_through(w, self, end);
}

void ExactGeodesicSolver::relax_corner_through(const Window& w, std::int32_t index, std::uint32_t v) {
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
[[gnu::noinline]] void ExactGeodesicSolver::propagate_along_line(const Window& w, std::int32_t self,
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
  const double slack = kVisibilitySlack * L;
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

void GeodesicTargets::assign(const IntrinsicGeometry& geometry,
                             std::span<const SurfacePoint> points) {
  const TriangleMesh& mesh = geometry.mesh();
  for (const SurfacePoint& p : points) p.validate(mesh);
  if (points.size() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max())) {
    throw InvalidInput(ErrorCode::TooManyTargets, std::to_string(points.size()) + " targets (at most 2^31 - 1)");
  }
  // Before any change: a list head must never name an entry that a failed push left out.
  entries_.reserve(points.size());
  if (geometry_ != &geometry) {
    vertex_first_.assign(mesh.num_vertices(), -1);
    face_first_.assign(mesh.num_faces(), -1);
  } else {
    for (const Entry& e : entries_) (e.vertex >= 0 ? vertex_first_[e.vertex] : face_first_[e.face]) = -1;
  }
  geometry_ = &geometry;
  entries_.clear();
  face_targets_ = 0;
  for (const SurfacePoint& p : points) {
    const auto index = static_cast<std::int32_t>(entries_.size());
    Entry e{};
    if (p.kind == SurfacePoint::Kind::Vertex) {
      e.vertex = static_cast<std::int32_t>(p.id);
      e.next = vertex_first_[p.id];
      vertex_first_[p.id] = index;
    } else {
      const auto [face, bary] = p.in_face(mesh);
      e.vertex = -1;
      e.face = face;
      e.point = geometry.face_point(face, bary.data());
      e.next = face_first_[face];
      face_first_[face] = index;
      ++face_targets_;
    }
    entries_.push_back(e);
  }
}

void ExactGeodesicSolver::improve_target(std::uint32_t index, double estimate) {
  TargetState& t = target_state_[index];
  if (t.settled || !(estimate < t.estimate)) return;
  if (t.estimate == kInfinity) touched_targets_.push_back(index);
  t.estimate = estimate;
  target_queue_.push_back({estimate, index});
  std::push_heap(target_queue_.begin(), target_queue_.end(), std::greater<>{});
  if (nearest_wanted_ > 0) track_nearest(index);
}

void ExactGeodesicSolver::track_nearest(std::uint32_t index) {
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

void ExactGeodesicSolver::update_targets_in_face(std::uint32_t face) {
  const std::vector<GeodesicTargets::Entry>& entries = targets_->entries_;
  for (std::int32_t i = targets_->face_first_[face]; i >= 0; i = entries[i].next) {
    improve_target(static_cast<std::uint32_t>(i), best_in_face(face, entries[i].point).distance);
  }
}

void ExactGeodesicSolver::update_targets_at_vertex(std::uint32_t v) {
  const std::vector<GeodesicTargets::Entry>& entries = targets_->entries_;
  for (std::int32_t i = targets_->vertex_first_[v]; i >= 0; i = entries[i].next) {
    improve_target(static_cast<std::uint32_t>(i), vertex_distance_[v]);
  }
  if (targets_->face_targets_ == 0) return;
  for (std::uint32_t h : mesh_->outgoing_halfedges(v)) update_targets_in_face(h / 3);
}

void ExactGeodesicSolver::settle_targets_up_to(double key) {
  while (!target_queue_.empty() && target_queue_.front().first <= key) {
    const auto [estimate, index] = target_queue_.front();
    std::pop_heap(target_queue_.begin(), target_queue_.end(), std::greater<>{});
    target_queue_.pop_back();
    TargetState& t = target_state_[index];
    if (t.settled || estimate != t.estimate) continue;
    t.settled = true;
    settled_targets_.push_back(index);
    settled_distances_.push_back(estimate);
  }
}

// ---------------------------------------------------------------------------------------------
// Queries after a solve.

ExactGeodesicSolver::Candidate ExactGeodesicSolver::best_in_face(std::uint32_t face,
                                                                 Vec2 p) const {
  const IntrinsicGeometry& g = *geometry_;
  Candidate best;
  for (int i = 0; i < 3; ++i) {
    const std::uint32_t v = mesh_->face(face)[i];
    const double dv = vertex_estimate(v);
    if (dv < kInfinity) {
      const Vec2 c = g.face_corner(face, i);
      const double d = dv + length2(p.x - c.x, p.y - c.y);
      if (d < best.distance) best = {Candidate::Kind::Vertex, d, static_cast<std::int32_t>(v), {}};
    }
  }
  if (face_stamp_[face] == generation_) {
    for (std::int32_t s = face_first_seed_[face]; s >= 0; s = seeds_[s].next) {
      const Seed& seed = seeds_[s];
      const double d = seed.offset + length2(p.x - seed.point.x, p.y - seed.point.y);
      if (d < best.distance) best = {Candidate::Kind::Seed, d, s, {}};
    }
  }
  for (int i = 0; i < 3; ++i) {
    const std::uint32_t h = 3 * face + static_cast<std::uint32_t>(i);
    if (first_chunk(h) < 0) continue;
    const double L = g.layout(h).length;
    if (L <= 0) continue;
    const Vec2 q = face_to_halfedge_frame(g, face, i, p);
    const double slack = kVisibilitySlack * L;
    for_each_live_window(h, [&](std::int32_t wi, const Window& w) {
      const double qy = std::max(q.y, 0.0);
      const double x = w.crossing_x(q.x, qy);
      if (x < w.b0 - slack || x > w.b1 + slack) return;
      const double d = through_window(w, x, q.x, qy);
      if (d < best.distance) best = {Candidate::Kind::Window, d, wi, {q.x, qy}};
    });
  }
  return best;
}

double ExactGeodesicSolver::distance(std::uint32_t vertex) const {
  if (vertex >= mesh_->num_vertices()) {
    throw InvalidInput(ErrorCode::VertexOutOfRange, "vertex " + std::to_string(vertex) +
                                               " is out of range (mesh has " +
                                               std::to_string(mesh_->num_vertices()) +
                                               " vertices)");
  }
  const double d = vertex_estimate(vertex);
  return d <= radius_reached_ ? d : kInfinity;
}

double ExactGeodesicSolver::distance(const SurfacePoint& point) const {
  point.validate(*mesh_);
  if (point.kind == SurfacePoint::Kind::Vertex) return distance(point.id);
  auto [face, bary] = point.in_face(*mesh_);
  const double d = best_in_face(face, geometry_->face_point(face, bary.data())).distance;
  return d <= radius_reached_ ? d : kInfinity;
}

std::vector<double> ExactGeodesicSolver::vertex_distances() const {
  std::vector<double> out(mesh_->num_vertices());
  for (std::uint32_t v = 0; v < out.size(); ++v) {
    const double d = vertex_estimate(v);
    out[v] = d <= radius_reached_ ? d : kInfinity;
  }
  return out;
}

std::int32_t ExactGeodesicSolver::nearest_source(std::uint32_t vertex) const {
  if (distance(vertex) == kInfinity) return -1;
  return static_cast<std::int32_t>(vertex_source_[vertex]);
}

// ---------------------------------------------------------------------------------------------
// Backtracing: from the target towards the source, through the chain of windows whose unfolded
// source the path points at, and through pseudo-source vertices.

namespace {

struct PathBuilder {
  const TriangleMesh& mesh;
  std::vector<PathPoint> points;

  void add(const SurfacePoint& p) {
    const Vec3 pos = p.position(mesh);
    if (!points.empty()) {
      const PathPoint& last = points.back();
      // Only the very same point is dropped: distinct points at one position (across a
      // zero-area face) each name the face they share with their neighbours.
      if (same_point(last.point, p)) return;
      // Out and back to the very same point is a spur: dropped. Along a line of zero-area
      // faces a window's interval may start a hair past the vertex its child's ray reaches
      // (its crossing is clamped into the interval), and the polyline went there and back
      // (2.2e-7 too long on ugly_rectangle(15533, 6)).
      if (points.size() >= 2 && same_point(points[points.size() - 2].point, p)) {
        points.pop_back();
        return;
      }
    }
    points.push_back({p, pos});
  }

  static bool same_point(const SurfacePoint& q, const SurfacePoint& p) {
    return q.kind == p.kind && q.id == p.id && q.t == p.t && q.bary == p.bary;
  }
};

// Each crossing of an edge moved to where the path's two pieces beside it, each inside one of
// the edge's faces, are shortest: the straight line across the edge in those faces' unfolding,
// which an exact path already takes to rounding. Along a line of zero-area faces a crossing is
// ill-conditioned there (the edge lies along the path, every point of the overlap is a
// crossing) and came out up to 1e-7 ahead of the next one: the polyline went forward and back
// (ugly_rectangle(1374, 6): 1.8e-7 longer than the distance). Positions measure the pieces, so
// only where lengths are the positions' chords; moves that gain less than the positions'
// rounding are not made.
void straighten_crossings(const TriangleMesh& mesh, std::vector<PathPoint>& points) {
  // A move changes its neighbours' best places: a few passes, until none moves.
  for (int pass = 0; pass < 4; ++pass) {
    bool moved = false;
    for (std::size_t i = 1; i + 1 < points.size(); ++i) {
      PathPoint& b = points[i];
      if (b.point.kind != SurfacePoint::Kind::Edge) continue;
      const Vec3 a = points[i - 1].position, c = points[i + 1].position;
      const Vec3& p0 = mesh.position(mesh.edge_origin(b.point.id));
      const Vec3 along = mesh.position(mesh.edge_target(b.point.id)) - p0;
      const double length = norm(along);
      if (!(length > 0)) continue;
      const Vec3 u = (1 / length) * along;
      // a and c as (position along the edge, distance from its line): the pieces are shortest
      // on the segment from (sa, ra) to (sc, -rc), both laid out in one plane.
      const double sa = dot(a - p0, u), sc = dot(c - p0, u), sb = b.point.t * length;
      const double ra = norm(a - p0 - sa * u), rc = norm(c - p0 - sc * u);
      auto pieces = [&](double x) { return norm(a - p0 - x * u) + norm(c - p0 - x * u); };
      const double now = pieces(sb);
      // The rounding of these positions and projections.
      const double scale = norm(p0) + length + std::abs(sa) + std::abs(sc);
      double best;
      bool better;
      if (ra + rc > 1e-12 * scale) {
        best = std::clamp(sa + (sc - sa) * (ra / (ra + rc)), 0.0, length);
        better = pieces(best) < now - 1e-13 * scale;
      } else {
        // a and c on the line (to rounding): every point between them is as short, and a run
        // of such points can still go forward and back. Each joins the one before it (or
        // comes as near as its edge allows), so that the run advances monotonically.
        best = std::clamp(std::clamp(sa, 0.0, length), std::min(sa, sc), std::max(sa, sc));
        better = best != sb && pieces(best) <= now + 1e-13 * scale;
      }
      if (!better) continue;
      b.point = SurfacePoint::edge(b.point.id, best / length);
      b.position = b.point.position(mesh);
      moved = true;
    }
    if (!moved) break;
  }
}

void faces_of(const TriangleMesh& mesh, const SurfacePoint& p, std::vector<std::uint32_t>& out) {
  out.clear();
  switch (p.kind) {
    case SurfacePoint::Kind::Vertex:
      for (std::uint32_t h : mesh.outgoing_halfedges(p.id)) out.push_back(h / 3);
      break;
    case SurfacePoint::Kind::Edge: {
      const std::uint32_t h = mesh.edge_halfedge(p.id);
      out.push_back(h / 3);
      if (mesh.twin(h) >= 0) out.push_back(static_cast<std::uint32_t>(mesh.twin(h)) / 3);
      break;
    }
    case SurfacePoint::Kind::Face:
      out.push_back(p.id);
      break;
  }
}

// Unit direction (dx, dy) given in the frame of halfedge h, in the frame of h's face.
FaceDirection halfedge_direction(const IntrinsicGeometry& g, std::uint32_t h, double dx,
                                 double dy) {
  const std::uint32_t f = h / 3;
  const int i = static_cast<int>(h % 3);
  const double len = length2(dx, dy);
  if (!(len > 0)) return {f, 1, 0};
  dx /= len;
  dy /= len;
  if (i == 0) return {f, dx, dy};
  const HalfedgeAxes a = halfedge_axes(g, f, i);
  // The axes are unit only to the rounding of the side's layout, which a cap or needle makes
  // coarse: normalise the result, a unit vector by contract.
  const double x = dx * a.ex - dy * a.ey, y = dx * a.ey + dy * a.ex;
  const double norm = length2(x, y);
  if (!(norm > 0)) return {f, dx, dy};
  return {f, x / norm, y / norm};
}

FaceDirection reversed(FaceDirection d) { return {d.face, -d.x, -d.y}; }

SurfacePoint point_on_halfedge(const TriangleMesh& mesh, std::uint32_t h, double x, double L) {
  const double rel = L > 0 ? std::clamp(x / L, 0.0, 1.0) : 0.0;
  if (rel <= 1e-12) return SurfacePoint::vertex(mesh.origin(h));
  if (rel >= 1 - 1e-12) return SurfacePoint::vertex(mesh.target(h));
  const std::uint32_t e = mesh.edge_of(h);
  return SurfacePoint::edge(e, mesh.edge_halfedge(e) == h ? rel : 1 - rel);
}

}  // namespace

GeodesicPath ExactGeodesicSolver::path_to(const SurfacePoint& point) const {
  point.validate(*mesh_);
  const IntrinsicGeometry& g = *geometry_;
  GeodesicPath path;
  PathBuilder builder{*mesh_, {}};
  builder.add(point);

  std::int32_t vertex = -1;  // continue from this vertex when >= 0
  std::int32_t window = -1;  // or trace this window from `p` (in its halfedge frame)
  Vec2 p{};
  double distance_found = kInfinity;
  std::uint32_t source_index = 0;
  bool done = false;

  // End directions come from the straight pieces themselves (window geometry, edges), not from
  // consecutive polyline points, which can be arbitrarily close across slivers.
  bool have_target_direction = false;
  auto record_piece = [&](FaceDirection at_target_side, FaceDirection at_source_side) {
    if (!have_target_direction) {
      path.direction_at_target = at_target_side;
      have_target_direction = true;
    }
    path.direction_at_source = at_source_side;
  };
  // A straight piece inside face f between two points given in f's frame.
  auto record_in_face = [&](std::uint32_t f, Vec2 from, Vec2 to) {
    // A piece of (numerically) zero length has no direction: the next one decides.
    const double scale = g.layout(3 * f).length + length2(g.layout(3 * f).cx, g.layout(3 * f).cy);
    if (length2(to.x - from.x, to.y - from.y) <= 1e-12 * scale) return;
    const FaceDirection d = halfedge_direction(g, 3 * f, to.x - from.x, to.y - from.y);
    record_piece(d, reversed(d));
  };
  auto corner_of = [&](std::uint32_t f, std::uint32_t v) {
    int corner = 0;
    while (corner < 2 && mesh_->face(f)[corner] != v) ++corner;
    return g.face_corner(f, corner);
  };

  auto finish_at_seed = [&](std::int32_t seed) {
    const Seed& s = seeds_[static_cast<std::size_t>(seed)];
    builder.add(sources_[s.source_index].point);
    source_index = s.source_index;
    done = true;
  };

  if (point.kind == SurfacePoint::Kind::Vertex) {
    distance_found = distance(point.id);
    vertex = static_cast<std::int32_t>(point.id);
  } else {
    auto [face, bary] = point.in_face(*mesh_);
    const Candidate best = best_in_face(face, g.face_point(face, bary.data()));
    distance_found = best.distance <= radius_reached_ ? best.distance : kInfinity;
    if (distance_found < kInfinity) {
      const Vec2 here = g.face_point(face, bary.data());
      switch (best.kind) {
        case Candidate::Kind::Vertex:
          vertex = best.index;
          record_in_face(face, here, corner_of(face, static_cast<std::uint32_t>(vertex)));
          builder.add(SurfacePoint::vertex(static_cast<std::uint32_t>(vertex)));
          break;
        case Candidate::Kind::Seed:
          record_in_face(face, here, seeds_[static_cast<std::size_t>(best.index)].point);
          finish_at_seed(best.index);
          break;
        case Candidate::Kind::Window:
          window = best.index;
          p = best.point_in_frame;
          break;
        case Candidate::Kind::None:
          break;
      }
    }
  }
  if (distance_found == kInfinity) {
    throw Unreachable(ErrorCode::Unreachable, "point " + point.to_string() +
                                         " is not reachable from the sources" +
                                         (radius_reached_ < kInfinity ? " within the radius solved"
                                                                      : ""));
  }

  const std::size_t guard_limit = 4 * (windows_.size() + mesh_->num_vertices()) + 16;
  std::size_t guard = 0;
  bool piece_started = false;  // inside a window chain, its target-side direction is recorded
  bool p_on_edge_end = false;  // p is an end vertex of the window's edge
  // The chain's target-side point, carried into each parent's frame with p: a chain is one
  // straight segment in the unfolding, and where the crossings all lie at its source (a
  // source on a line of zero-area faces) only this point still gives its direction.
  Vec2 far{};
  while (!done) {
    GEOPROX_ASSERT(++guard < guard_limit, "backtrace does not terminate");
    if (window >= 0) {
      const Window& w = windows_[static_cast<std::size_t>(window)];
      const HalfedgeLayout& lay = g.layout(w.halfedge);
      if (!piece_started) {
        piece_started = true;
        far = p;
        // From a point inside the face the segment runs in this face; from an end vertex of
        // the window's edge it runs into the face across that edge, behind which S lies.
        const std::int32_t across = mesh_->twin(w.halfedge);
        const FaceDirection towards =
            !p_on_edge_end || across < 0
                ? halfedge_direction(g, w.halfedge, w.sx - p.x, w.sy - p.y)
                : halfedge_direction(g, static_cast<std::uint32_t>(across), p.x - w.sx, p.y - w.sy);
        if (!have_target_direction) {
          path.direction_at_target = towards;
          have_target_direction = true;
        }
      }
      // Where the segment from p towards the unfolded source crosses the window's edge.
      const double x = std::clamp(w.crossing_x(p.x, p.y), w.b0, w.b1);
      builder.add(point_on_halfedge(*mesh_, w.halfedge, x, lay.length));
      if (w.parent >= 0) {
        const Window& parent = windows_[static_cast<std::size_t>(w.parent)];
        const std::uint32_t ph = parent.halfedge;
        const HalfedgeLayout& play = g.layout(ph);
        const auto twin = static_cast<std::uint32_t>(mesh_->twin(w.halfedge));
        const double along = lay.length > 0 ? (lay.length - x) / lay.length : 0;  // on the twin
        // The parent's side from A to B is the twin of this window's edge, which runs from B.
        Vec2 a_end, b_end;
        if (twin == TriangleMesh::next(ph)) {  // b' -> c'
          p = {play.length + along * (play.cx - play.length), along * play.cy};
          a_end = {play.length, 0};
          b_end = {play.cx, play.cy};
        } else {
          GEOPROX_ASSERT(twin == TriangleMesh::prev(ph), "window chain is not adjacent");
          p = {play.cx * (1 - along), play.cy * (1 - along)};  // c' -> a'
          a_end = {play.cx, play.cy};
          b_end = {0, 0};
        }
        const double side = length2(a_end.x - b_end.x, a_end.y - b_end.y);
        if (side > 0) {
          const double ex = (a_end.x - b_end.x) / side, ey = (a_end.y - b_end.y) / side;
          far = {b_end.x + far.x * ex - far.y * ey, b_end.y + far.x * ey + far.y * ex};
        } else {
          far = p;
        }
        window = w.parent;
        continue;
      }
      // The chain's root: its source lies in the face across the root's edge. The direction at
      // the source points at the crossing, expressed in that face.
      // Measured towards the current point p rather than the crossing, which coincides with the
      // source when the source lies on the root's edge (a zero-area face behind it).
      piece_started = false;
      if (w.sy == 0) {
        const double to_far = length2(far.x - w.sx, far.y - w.sy);
        const Vec2 ahead = to_far > 1e-9 * (lay.length + std::abs(w.sx)) ? far : p;
        path.direction_at_source = halfedge_direction(g, w.halfedge, ahead.x - w.sx, ahead.y - w.sy);
      } else {
        const auto across = static_cast<std::uint32_t>(mesh_->twin(w.halfedge));
        path.direction_at_source = halfedge_direction(g, across, w.sx - p.x, w.sy - p.y);
      }
      if (w.root >= 0) {
        builder.add(SurfacePoint::vertex(static_cast<std::uint32_t>(w.root)));
        vertex = w.root;
        window = -1;
        continue;
      }
      finish_at_seed(-1 - w.root);
      continue;
    }
    // From a vertex: follow how its distance was obtained.
    const auto v = static_cast<std::uint32_t>(vertex);
    const std::int32_t via_vertex = vertex_via_vertex_[v];
    const std::int32_t via_window = vertex_via_window_[v];
    if (via_vertex == kViaSourceVertex) {
      builder.add(SurfacePoint::vertex(v));
      source_index = vertex_source_[v];
      // A source a rounding error from its vertex (add_source): the path starts at the point.
      const SurfacePoint& source = sources_[source_index].point;
      if (source.kind != SurfacePoint::Kind::Vertex &&
          norm(source.position(*mesh_) - mesh_->position(v)) > 0) {
        builder.add(source);
      }
      done = true;
    } else if (via_vertex >= 0) {
      const auto u = static_cast<std::uint32_t>(via_vertex);
      for (std::uint32_t h : mesh_->outgoing_halfedges(v)) {
        if (mesh_->target(h) == u) {
          const FaceDirection along = halfedge_direction(g, h, 1, 0);
          record_piece(along, reversed(along));
          break;
        }
        if (mesh_->origin(TriangleMesh::prev(h)) == u) {  // v <- u is prev(h): run it backwards
          const std::uint32_t back = TriangleMesh::prev(h);
          const FaceDirection along = halfedge_direction(g, back, -1, 0);
          record_piece(along, reversed(along));
          break;
        }
      }
      builder.add(SurfacePoint::vertex(u));
      vertex = via_vertex;
    } else if (via_vertex <= kViaSeedBase) {
      const Seed& seed = seeds_[static_cast<std::size_t>(kViaSeedBase - via_vertex)];
      record_in_face(seed.face, corner_of(seed.face, v), seed.point);
      finish_at_seed(kViaSeedBase - via_vertex);
    } else {
      GEOPROX_ASSERT(via_window >= 0, "reached vertex without a predecessor");
      const Window& w = windows_[static_cast<std::size_t>(via_window)];
      const HalfedgeLayout& lay = g.layout(w.halfedge);
      p_on_edge_end = v != mesh_->opposite_vertex(w.halfedge);
      if (v == mesh_->origin(w.halfedge)) {
        p = {0, 0};
      } else if (v == mesh_->target(w.halfedge)) {
        p = {lay.length, 0};
      } else {
        p = {lay.cx, lay.cy};
      }
      window = via_window;
      vertex = -1;
    }
  }

  std::reverse(builder.points.begin(), builder.points.end());
  path.points = std::move(builder.points);
  if (g.lengths_are_chords()) straighten_crossings(*mesh_, path.points);
  path.length = distance_found;
  path.source_index = source_index;
  if (!have_target_direction) {  // a path of length zero
    std::vector<std::uint32_t> faces;
    faces_of(*mesh_, point, faces);
    const std::uint32_t f = faces.empty() ? 0 : faces.front();
    path.direction_at_source = {f, 1, 0};
    path.direction_at_target = {f, 1, 0};
    return path;
  }
  // At a vertex end, give the direction in the face whose corner it points into.
  const PathPoint& first = path.points.front();
  const PathPoint& last = path.points.back();
  if (first.point.kind == SurfacePoint::Kind::Vertex) {
    path.direction_at_source = into_corner(first.point.id, path.direction_at_source);
  }
  if (last.point.kind == SurfacePoint::Kind::Vertex) {
    path.direction_at_target = into_corner(last.point.id, path.direction_at_target);
  }
  return path;
}

FaceDirection ExactGeodesicSolver::into_corner(std::uint32_t v, FaceDirection d) const {
  // Angles around v are intrinsic (sums of corner angles), so turning from one corner into the
  // next is the unfolding across the edge between them.
  const IntrinsicGeometry& g = *geometry_;
  std::uint32_t h = UINT32_MAX;  // outgoing halfedge of v in d.face
  for (int i = 0; i < 3; ++i) {
    if (mesh_->face(d.face)[i] == v) h = 3 * d.face + static_cast<std::uint32_t>(i);
  }
  if (h == UINT32_MAX) return d;
  auto edge_angle = [&](std::uint32_t halfedge) {  // direction of halfedge in its face frame
    const FaceDirection e = halfedge_direction(g, halfedge, 1, 0);
    return std::atan2(e.y, e.x);
  };
  constexpr double kTwoPi = 2 * 3.14159265358979323846;
  double theta = std::atan2(d.y, d.x) - edge_angle(h);  // from v -> a, counter-clockwise
  theta = std::remainder(theta, kTwoPi);
  const double slack = 1e-9;
  for (std::size_t step = 0; step <= mesh_->outgoing_halfedges(v).size(); ++step) {
    const double corner = g.corner_angle(h);
    if (theta >= -slack && theta <= corner + slack) break;
    if (theta > corner) {  // further counter-clockwise: the next face around v
      const std::int32_t t = mesh_->twin(TriangleMesh::prev(h));
      if (t < 0) break;
      theta -= corner;
      h = static_cast<std::uint32_t>(t);
    } else {  // clockwise: the previous face
      const std::int32_t t = mesh_->twin(h);
      if (t < 0) break;
      h = TriangleMesh::next(static_cast<std::uint32_t>(t));
      theta += g.corner_angle(h);
    }
  }
  const double angle = edge_angle(h) + theta;
  return {h / 3, std::cos(angle), std::sin(angle)};
}

// ---------------------------------------------------------------------------------------------

std::vector<double> exact_geodesic_distances(const TriangleMesh& mesh,
                                             const IntrinsicGeometry& geometry,
                                             std::span<const GeodesicSource> sources,
                                             const ExactGeodesicSolver::Options& options) {
  ExactGeodesicSolver solver(mesh, geometry);
  solver.solve(sources, {}, options);
  return solver.vertex_distances();
}

GeodesicPath exact_geodesic_path(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                                 const SurfacePoint& source, const SurfacePoint& target) {
  ExactGeodesicSolver solver(mesh, geometry);
  const GeodesicSource one{source, 0.0};
  const SurfacePoint targets[] = {target};
  ExactGeodesicSolver::Options options;
  options.stop_after_targets = 1;
  solver.solve(std::span<const GeodesicSource>(&one, 1), targets, options);
  return solver.path_to(target);
}

}  // namespace geoprox
