// The exact solver's driver: construction, a solve's set-up (sources, targets, options, the
// queue strategy) and its main loop. Window creation and propagation are in
// window_propagation.cpp, distances and paths read after a solve in window_results.cpp.
#include <algorithm>
#include <cmath>
#include <span>
#include <string>

#include "core/base/errors.h"
#include "core/geodesic/window_propagation.h"

namespace geoprox::detail {

WindowPropagation::WindowPropagation(const TriangleMesh& mesh, const IntrinsicGeometry& geometry)
    : mesh_(&mesh),
      geometry_(&geometry),
      near_miss_(tuning::kNearMiss * geometry.mean_edge_length()),
      window_limit_(
          std::max(tuning::kMinWindows, tuning::kWindowsPerHalfedge * 3 * mesh.num_faces())) {
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

void WindowPropagation::reset() {
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

void WindowPropagation::solve(const SurfacePoint& source, const Options& options) {
  const GeodesicSource one{source, 0.0};
  solve(std::span<const GeodesicSource>(&one, 1), {}, options);
}

std::size_t WindowPropagation::vertices_within(double distance) const {
  std::size_t count = 0;
  for (const std::uint32_t v : touched_vertices_) count += vertex_distance_[v] <= distance;
  return count;
}

void WindowPropagation::check_solve_input(std::span<const GeodesicSource> sources,
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
  if (std::isnan(options.goal_limit) || options.goal_limit < 0) {
    throw InvalidInput(ErrorCode::BadRadius, "goal_limit must be a non-negative number");
  }
  if (options.goal && !(std::isfinite(options.goal->x) && std::isfinite(options.goal->y) &&
                        std::isfinite(options.goal->z))) {
    throw InvalidInput(ErrorCode::BadGoal, "the goal position must be finite");
  }
}

void WindowPropagation::solve(std::span<const GeodesicSource> sources,
                              std::span<const SurfacePoint> targets, const Options& options) {
  check_solve_input(sources, options);
  own_targets_.assign(*geometry_, targets);  // validates the targets first
  run(sources, own_targets_, options);
}

void WindowPropagation::solve(std::span<const GeodesicSource> sources,
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

// The solve: set-up, then the main loop over the queue with its stops. Kept whole (over 100
// lines): the stops share the loop's state, and the loop is the solver's hot path.
void WindowPropagation::run(std::span<const GeodesicSource> sources, const GeodesicTargets& targets,
                            const Options& options) {
  // Without a goal_limit the target's estimate is the goal-directed stop.
  const bool no_stop = targets.empty() && options.goal_limit == kInfinity;
  if (options.goal && (targets.size() > 1 || no_stop)) {
    throw InvalidInput(ErrorCode::BadGoal,
                       "a goal-directed solve needs one target or a goal_limit, got " +
                           std::to_string(targets.size()) + " targets");
  }
  reset();
  goal_ = options.goal;
  goal_limit_ = options.goal_limit;
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
  // Halfedges collect many waiting windows only where the wavefront is wide: every solve but
  // those that stop at the nearest vertices or at the nearest of several targets, which stay a
  // few edges wide and keep one queue entry per window.
  const bool full_solve = !targets_ && max_distance_ == kInfinity &&
                          options.max_windows_propagated == 0 && options.stop_after_vertices == 0;
  const bool stays_narrow =
      options.stop_after_vertices > 0 || (targets_wanted_ == 1 && num_targets > 1);
  batch_halfedges_ = full_solve || forced_queue_halfedges_.value_or(!stays_narrow);
  // Sized at the first batched solve.
  if (batch_halfedges_ && halfedge_queued_.empty()) {
    halfedge_queued_.assign(halfedge_state_.size(), QueuedHalfedge{kInfinity, 0, 0});
  }
  queue_.placed().queued = halfedge_queued_.data();
  nearest_wanted_ = targets_wanted_ <= tuning::kMaxNearestTracked ? targets_wanted_ : 0;

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
      // when the vertex was queued), as the hints in relax_vertex and emit_pseudo_source do.
      mesh_->prefetch_outgoing_halfedges(queue_.top().item & ~kVertexItem);
    } else if (!queue_.empty()) {
      // The next window was stored long ago: start loading it, and its halfedge's crossing
      // record (the queue entry names the halfedge, so this does not wait for the window).
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

void WindowPropagation::add_source(std::uint32_t index, const GeodesicSource& source) {
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
    if (bary[i] >= 1 || gap <= tuning::kCoincident * g.mean_edge_length()) {
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

void WindowPropagation::seed_face_point(std::uint32_t source_index, double offset,
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

void WindowPropagation::settle_targets_up_to(double key) {
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

}  // namespace geoprox::detail
