// The exact solver's engine: window propagation (ICH with MMP's ordering and trimming), its
// state and its helpers. Private to core/geodesic: callers use ExactGeodesicSolver
// (exact_geodesic.h), which owns one of these. docs/exact_geodesic.md describes the method.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#if defined(__SSE2__)
#include <xmmintrin.h>
#endif

#include "core/base/errors.h"
#include "core/base/mapped_array.h"
#include "core/base/radix_heap.h"
#include "core/base/tuning.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/geodesic/geodesic_types.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox::detail {

// ---- Helpers shared by the solver's source files ----
// Whether x (along an edge of length L) lies inside the edge, clear of both ends by the
// visibility slack: a window's source there on the edge's line is a point of the edge, not a
// corner (propagate's sees_face and keep_source_point agree on this).
inline bool strictly_inside_edge(double x, double L) {
  const double slack = tuning::kVisibilitySlack * L;
  return x > slack && x < L - slack;
}
inline constexpr std::uint32_t kVertexItem = 0x80000000u;
inline constexpr std::uint32_t kHalfedgeItem = 0x40000000u;
// vertex_via_vertex_ codes besides a neighbour id.
inline constexpr std::int32_t kViaNone = -1;
inline constexpr std::int32_t kViaSourceVertex = -2;
// kViaSeedBase - i: reached straight from seed i (a source inside one of v's faces).
inline constexpr std::int32_t kViaSeedBase = -3;

inline double cross2(double ax, double ay, double bx, double by) { return ax * by - ay * bx; }
// Plain Euclidean length: mesh coordinates are nowhere near overflow, and std::hypot's care
// for it is expensive on this path.
inline double length2(double x, double y) { return std::sqrt(x * x + y * y); }

// A float at or below / at or above x, for x in [-1e30, 1e30] (window spans, whose screens
// must contain the double interval): the nearest float moved outwards by at least two of its
// ulps (|f| 2^-22), so whichever way the conversion and the subtraction round, the result is
// past x, at most three ulps wider than needed. Branch-free: stepping the bit pattern when the
// conversion had rounded the wrong way mispredicted half the time.
inline float round_down_to_float(double x) {
  const auto f = static_cast<float>(x);
  return f - (std::abs(f) * 0x1p-22f + std::numeric_limits<float>::denorm_min());
}
inline float round_up_to_float(double x) { return -round_down_to_float(-x); }

// Coordinates of point p (given in the frame of face f, i.e. of halfedge 3f) in the frame of
// halfedge 3f + i.
// The frame of halfedge 3f + i seen from the frame of face f: its origin and unit x axis.
struct HalfedgeAxes {
  Vec2 origin;
  double ex, ey;
};
inline HalfedgeAxes halfedge_axes(const IntrinsicGeometry& g, std::uint32_t f, int i) {
  if (i == 0) return {{0, 0}, 1, 0};
  const Vec2 origin = g.face_corner(f, i);
  const Vec2 to = g.face_corner(f, (i + 1) % 3);
  const double len = g.layout(3 * f + static_cast<std::uint32_t>(i)).length;
  // A zero-length side (coincident corners) has no direction: the face's own axes stand in,
  // so that nothing derived from it (end directions) is NaN.
  if (!(len > 0)) return {origin, 1, 0};
  return {origin, (to.x - origin.x) / len, (to.y - origin.y) / len};
}

inline Vec2 face_to_halfedge_frame(const IntrinsicGeometry& g, std::uint32_t f, int i, Vec2 p) {
  if (i == 0) return p;
  const HalfedgeAxes a = halfedge_axes(g, f, i);
  const double dx = p.x - a.origin.x, dy = p.y - a.origin.y;
  return {dx * a.ex + dy * a.ey, cross2(a.ex, a.ey, dx, dy)};
}

class WindowPropagation {
 public:
  using Options = ExactGeodesicOptions;

  // What ExactGeodesicSolver offers, with its contracts (exact_geodesic.h).
  WindowPropagation(const TriangleMesh& mesh, const IntrinsicGeometry& geometry);
  void solve(std::span<const GeodesicSource> sources, std::span<const SurfacePoint> targets = {},
             const Options& options = {});
  void solve(std::span<const GeodesicSource> sources, const GeodesicTargets& targets,
             const Options& options = {});
  void solve(const SurfacePoint& source, const Options& options = {});
  double distance(std::uint32_t vertex) const;
  double distance(const SurfacePoint& point) const;
  std::vector<double> vertex_distances() const;
  std::int32_t nearest_source(std::uint32_t vertex) const;
  GeodesicPath path_to(const SurfacePoint& point) const;
  const std::vector<std::uint32_t>& touched_vertices() const { return touched_vertices_; }
  std::size_t windows_stored() const { return windows_.size(); }
  std::uint32_t window_halfedge(std::size_t window) const { return windows_[window].halfedge; }
  double radius_reached() const { return radius_reached_; }
  const std::vector<std::uint32_t>& settled_targets() const { return settled_targets_; }
  const std::vector<double>& settled_target_distances() const { return settled_distances_; }
  const ExactGeodesicStats& stats() const { return stats_; }

  /// Tests and benchmarks only: forces the queue strategy of later solves (true: one entry per
  /// halfedge, false: one per window; full solves always queue halfedges), or gives the choice
  /// back to the solver (nullopt).
  void force_queue_strategy(std::optional<bool> queue_halfedges) {
    forced_queue_halfedges_ = queue_halfedges;
  }

  const TriangleMesh& mesh() const { return *mesh_; }
  const IntrinsicGeometry& geometry() const { return *geometry_; }

 private:
  struct Window {
    // 64 bytes: one cache line. The fields read while trimming come first.
    double b0, b1;     // interval along the halfedge, from its origin
    double key;        // smallest distance over the interval when created, a lower bound once
                       // a newer window trims the interval; kInfinity once dropped
    double sx, sy;     // unfolded (pseudo-)source in the halfedge frame, sy < 0
    double sigma;      // distance already travelled to the (pseudo-)source
    std::uint32_t halfedge;
    std::int32_t parent;  // window this one was unfolded from, or -1
    /// Where the chain of windows starts: a pseudo-source vertex (>= 0) or seed -1 - root.
    std::int32_t root;
    std::uint32_t source_index : 31;
    std::uint32_t propagated : 1;  // unfolded into the next face already (never trimmed after)

    double distance_at(double x) const { return sigma + std::sqrt((x - sx) * (x - sx) + sy * sy); }
    /// Where the straight line from point (px, py), py >= 0, towards S crosses the edge's line
    /// (px itself when both lie on that line).
    double crossing_x(double px, double py) const {
      return py - sy > 0 ? sx + (px - sx) * (-sy) / (py - sy) : px;
    }
  };

  // The windows of a halfedge are listed in chunks of one cache line each, with their intervals
  // rounded outwards to float: finding the few windows that overlap a new one then reads a line
  // or two instead of one scattered Window per window on the edge. Intervals only shrink, so the
  // rounded copies stay conservative; a dropped window's span is emptied when next met. The
  // chunk is laid out by field so that one branch-free test (overlap_mask) screens five spans:
  // fewer instructions than a test and a branch per span.
  struct SpanChunk {
    static constexpr int kCapacity = 5;
    // window[i] is the window's index, with kListedTaken set once a halfedge batch took it.
    float lo[kCapacity];             // free or emptied slot: +inf
    float hi[kCapacity];             // free or emptied slot: -inf
    std::int32_t window[kCapacity];  // -1: free slot (free slots come last)
    std::int32_t next;               // older chunk of the same halfedge, or -1

    /// Bit i set when slot i may overlap [qlo, qhi] (free and emptied slots never do).
    unsigned overlap_mask(float qlo, float qhi) const {
#if defined(__SSE2__)
      // Slots 0-3 in one vector compare (the compiler keeps the loop scalar), slot 4 alone.
      const __m128 hit = _mm_and_ps(_mm_cmple_ps(_mm_loadu_ps(lo), _mm_set1_ps(qhi)),
                                    _mm_cmpge_ps(_mm_loadu_ps(hi), _mm_set1_ps(qlo)));
      static_assert(kCapacity == 5);
      return static_cast<unsigned>(_mm_movemask_ps(hit)) |
             static_cast<unsigned>((lo[4] <= qhi) & (hi[4] >= qlo)) << 4;
#else
      unsigned mask = 0;
      for (int i = 0; i < kCapacity; ++i) {
        mask |= static_cast<unsigned>((lo[i] <= qhi) & (hi[i] >= qlo)) << i;
      }
      return mask;
#endif
    }
    /// Bit i set when slot i overlaps [qlo, qhi] by less than min_overlap with neither
    /// interval inside the other (a sliver overlap), judged in float on the listed span.
    unsigned sliver_mask(float qlo, float qhi, float min_overlap) const {
#if defined(__SSE2__)
      const __m128 l = _mm_loadu_ps(lo), h = _mm_loadu_ps(hi);
      const __m128 ql = _mm_set1_ps(qlo), qh = _mm_set1_ps(qhi);
      const __m128 overlap = _mm_sub_ps(_mm_min_ps(qh, h), _mm_max_ps(ql, l));
      const __m128 thin = _mm_cmplt_ps(overlap, _mm_set1_ps(min_overlap));
      const __m128 mine_sticks_out = _mm_or_ps(_mm_cmplt_ps(ql, l), _mm_cmpgt_ps(qh, h));
      const __m128 theirs_sticks_out = _mm_or_ps(_mm_cmplt_ps(l, ql), _mm_cmpgt_ps(h, qh));
      const __m128 sliver = _mm_and_ps(thin, _mm_and_ps(mine_sticks_out, theirs_sticks_out));
      return static_cast<unsigned>(_mm_movemask_ps(sliver)) |
             sliver_slot(4, qlo, qhi, min_overlap) << 4;
#else
      unsigned mask = 0;
      for (int i = 0; i < kCapacity; ++i) mask |= sliver_slot(i, qlo, qhi, min_overlap) << i;
      return mask;
#endif
    }
    unsigned sliver_slot(int i, float qlo, float qhi, float min_overlap) const {
      const bool thin = std::min(qhi, hi[i]) - std::max(qlo, lo[i]) < min_overlap;
      return static_cast<unsigned>(thin & ((qlo < lo[i]) | (qhi > hi[i])) &
                                   ((lo[i] < qlo) | (hi[i] > qhi)));
    }
    /// Slots holding a window (free slots come last). Counted without a branch: a loop to the
    /// first free slot mispredicted once per listing.
    int used() const {
      int n = 0;
      for (int i = 0; i < kCapacity; ++i) n += window[i] >= 0;
      return n;
    }
    void empty_slot(int i) {
      lo[i] = std::numeric_limits<float>::infinity();
      hi[i] = -std::numeric_limits<float>::infinity();
    }
  };
  static_assert(sizeof(Window) == 64 && sizeof(SpanChunk) == 64);
  /// Set in a chunk's window entry once propagate_halfedge took that window, so that the next
  /// batch of the halfedge reads its chunks and none of the windows already done.
  static constexpr std::int32_t kListedTaken = 1 << 30;
  static constexpr std::int32_t kListedIndex = kListedTaken - 1;

  struct QueueEntry {
    double key;
    /// A window's index; kHalfedgeItem | the index of the window that queued its halfedge (full
    /// solves: see propagate_halfedge); or kVertexItem | a vertex.
    std::uint32_t item;
    std::uint32_t halfedge;  // a window's halfedge (in what was padding): prefetched with it
  };
  struct Candidate;

  void check_solve_input(std::span<const GeodesicSource> sources, const Options& options) const;
  /// The solve itself, inputs checked (targets may be empty).
  void run(std::span<const GeodesicSource> sources, const GeodesicTargets& targets,
           const Options& options);
  void reset();
  void touch_face(std::uint32_t face);
  std::size_t vertices_within(double distance) const;
  void add_source(std::uint32_t index, const GeodesicSource& source);
  void seed_face_point(std::uint32_t source_index, double offset, std::uint32_t face,
                       const std::array<double, 3>& bary);
  void emit_pseudo_source(std::uint32_t vertex);
  double incoming_angle(std::uint32_t vertex, std::uint32_t& fan_start) const;
  void emit_into_corner(std::uint32_t vertex, std::uint32_t halfedge, double angle_begin,
                        double angle_end);
  void propagate_halfedge(std::uint32_t halfedge, double key);
  void propagate(std::uint32_t window_index);
  /// propagate() for a window whose source lies on the line of the zero-area face it enters.
  void propagate_along_line(const Window& w, std::int32_t self, const HalfedgeCrossing& crossing);
  void create_window(std::uint32_t halfedge, double b0, double b1, Vec2 source, double sigma,
                     std::int32_t parent, std::int32_t root, std::uint32_t source_index);
  // Relaxes the ends of a short side of the window's face that its rays cross (from the far
  // corner to `end`) through the window, in place of a child there.
  void reach_short_side_ends(const Window& w, std::int32_t self, std::uint32_t end);
  // Relaxes corner v of the face window w (index `index`) enters through w; nothing if v is
  // not one of its corners.
  void relax_corner_through(const Window& w, std::int32_t index, std::uint32_t v);
  // Whether a window with its source on the halfedge's line, at one of its ends, is that end
  // vertex's own view and can go (relaxing the vertex through `parent` first).
  bool source_at_pseudo_source_end(std::uint32_t halfedge, Vec2 source, double sigma,
                                   std::int32_t parent);
  [[noreturn]] void throw_window_limit() const;
  void list_window(std::uint32_t halfedge, std::uint32_t index, double b0, double b1);
  /// Trims w against the distances of its face's corners; false if nothing is left. Sets key
  /// to window_key(w).
  bool trim_window(Window& w, double& key) const;
  bool trim_against_edge_windows(Window& w);
  // The interval [lo, hi] (empty unless alive) with the source point of w, which lies on its
  // edge's line, put back in; nothing if it is in already or a window of the edge is shorter
  // there.
  std::optional<std::pair<double, double>> keep_source_point(const Window& w, double lo,
                                                             double hi, bool alive) const;
  static double window_key(const Window& w);
  static double through_window(const Window& w, double x, double px, double py);
  FaceDirection into_corner(std::uint32_t vertex, FaceDirection direction) const;
  void relax_vertex(std::uint32_t vertex, double distance, std::int32_t via_window,
                    std::int32_t via_vertex, std::uint32_t source_index);
  void push(double key, std::uint32_t item, std::uint32_t halfedge = 0);
  void pop();
  void improve_target(std::uint32_t index, double estimate);
  void update_targets_in_face(std::uint32_t face);
  void update_targets_at_vertex(std::uint32_t vertex);
  void settle_targets_up_to(double key);
  void track_nearest(std::uint32_t index);
  Candidate best_in_face(std::uint32_t face, Vec2 point) const;
  /// Newest chunk of halfedge h's window list, or -1 when this solve listed none there.
  std::int32_t first_chunk(std::uint32_t h) const {
    const HalfedgeState& state = halfedge_state_[h];
    return state.stamp == generation_ ? state.first_chunk : -1;
  }
  /// Calls f(index, window) for each live window on halfedge h.
  template <class F>
  void for_each_live_window(std::uint32_t h, F&& f) const {
    for (std::int32_t c = first_chunk(h); c >= 0; c = chunks_[c].next) {
      const SpanChunk& chunk = chunks_[c];
      for (int i = 0; i < SpanChunk::kCapacity && chunk.window[i] >= 0; ++i) {
        const std::int32_t index = chunk.window[i] & kListedIndex;
        const Window& w = windows_[static_cast<std::size_t>(index)];
        if (w.key != kInfinity) f(index, w);
      }
    }
  }
  /// Cache hints for what creating a window on halfedge h reads: its crossing record, its
  /// window list's head and (batched solves) its queue entry.
  void prefetch_window_creation(std::uint32_t h) const {
    __builtin_prefetch(&geometry_->crossing(h));
    __builtin_prefetch(&halfedge_state_[h]);
    if (batch_halfedges_) __builtin_prefetch(&halfedge_queued_[h]);
  }
  double vertex_estimate(std::uint32_t v) const {
    return vertex_distance_[v];
  }
  /// Straight-line distance from vertex v to the goal (ExactGeodesicOptions::goal).
  double goal_bound(std::uint32_t v) const { return norm(mesh_->position(v) - *goal_); }
  double goal_bound(const Window& w) const;
  bool off_goal(double key, double bound) const {
    const double stop = goal_limit_ < kInfinity ? goal_limit_ : store_limit_;
    return key + bound > stop * (1 + tuning::kGoalSlack);
  }

  const TriangleMesh* mesh_;
  const IntrinsicGeometry* geometry_;
  /// tuning::kNearMiss of the mean edge length (mesh units).
  double near_miss_;
  /// tuning::kWindowsPerHalfedge per halfedge, at least tuning::kMinWindows.
  std::size_t window_limit_;

  // Per-solve scratch, sized to the mesh once: distances are reset through touched_vertices_,
  // the rest is validated by generation stamps.
  std::uint32_t generation_ = 0;
  std::vector<double> vertex_distance_;
  std::vector<std::int32_t> vertex_via_window_;  ///< window whose source reaches v, or -1
  std::vector<std::int32_t> vertex_via_vertex_;  ///< pseudo-source neighbour, or -1
  std::vector<std::uint32_t> vertex_source_;     ///< index of the source that reaches v
  std::vector<std::uint8_t> vertex_emitted_;     ///< pseudo-source windows already emitted
  /// One entry per halfedge, so that finding a halfedge's window list is one memory access.
  struct HalfedgeState {
    std::uint32_t stamp;       ///< generation of the solve that listed windows here
    std::int32_t first_chunk;  ///< newest chunk of the halfedge's windows (valid if stamped)
  };
  std::vector<HalfedgeState> halfedge_state_;
  /// Full solves (batch_halfedges_): the queue entry that will propagate the halfedge's
  /// waiting windows: its key (kInfinity when none waits; valid if the state is stamped) and
  /// where the queue holds it, so that a nearer newcomer lowers that entry's key in place.
  struct QueuedHalfedge {
    double key;
    std::uint32_t bucket, index;  ///< the entry's position in queue_
  };
  /// Apart from HalfedgeState, which local solves read, so that theirs stays 8 bytes; empty
  /// until the first full solve.
  std::vector<QueuedHalfedge> halfedge_queued_;
  /// This solve queues halfedges rather than windows (see propagate_halfedge).
  bool batch_halfedges_ = false;
  std::optional<bool> forced_queue_halfedges_;  ///< force_queue_strategy
  std::vector<std::pair<double, std::uint32_t>> batch_;  ///< propagate_halfedge's (key, window)
  std::vector<std::uint32_t> face_stamp_;
  std::vector<std::int32_t> face_first_seed_;     ///< head of the face's source-seed list

  MappedArray<Window> windows_;
  MappedArray<SpanChunk> chunks_;
  /// Keeps halfedge_queued_'s positions current as the queue moves halfedge entries.
  struct HalfedgeEntryPlacement {
    QueuedHalfedge* queued = nullptr;  ///< halfedge_queued_.data(), set by every full solve
    void operator()(const QueueEntry& entry, std::uint32_t bucket, std::uint32_t index) const;
  };
  RadixHeap<QueueEntry, HalfedgeEntryPlacement> queue_;

  struct Seed {
    std::uint32_t face;
    Vec2 point;
    double offset;
    std::uint32_t source_index;
    std::int32_t next;
  };
  std::vector<Seed> seeds_;
  std::vector<GeodesicSource> sources_;

  /// Targets given as a span are indexed here at every solve (its index sized to the mesh by
  /// the constructor).
  GeodesicTargets own_targets_{GeodesicTargets::Unset{}};
  const GeodesicTargets* targets_ = nullptr;  ///< the current solve's, or null: none
  struct TargetState {
    double estimate = kInfinity;
    bool settled = false;
    bool in_nearest = false;  ///< one of nearest_targets_
  };
  /// Per target of the current set; those given an estimate are listed in touched_targets_,
  /// and only they are reset by the next solve.
  std::vector<TargetState> target_state_;
  std::vector<std::uint32_t> touched_targets_;
  std::vector<std::pair<double, std::uint32_t>> target_queue_;
  std::vector<std::uint32_t> settled_targets_;
  std::vector<double> settled_distances_;
  std::size_t targets_wanted_ = 0;
  std::vector<std::uint32_t> touched_vertices_;

  double radius_reached_ = kInfinity;
  double max_distance_ = kInfinity, min_distance_ = 0;  ///< of the current solve's options
  /// A window whose key exceeds this would never be popped: the solve stops first, at the
  /// radius, or once the targets it waits for are settled (their estimates only fall). Such
  /// windows are not stored; the smallest key not stored caps what is final.
  double store_limit_ = kInfinity;
  std::optional<Vec3> goal_;  ///< the current solve's goal (ExactGeodesicOptions::goal)
  double goal_limit_ = kInfinity;  ///< ExactGeodesicOptions::goal_limit
  double skipped_min_key_ = kInfinity;
  std::size_t nearest_wanted_ = 0;
  std::vector<std::uint32_t> nearest_targets_;
  std::size_t nearest_worst_ = 0;  ///< index in nearest_targets_ of the largest estimate
  ExactGeodesicStats stats_;
};

struct WindowPropagation::Candidate {
  enum class Kind { None, Vertex, Window, Seed } kind = Kind::None;
  double distance = kInfinity;
  std::int32_t index = -1;  // vertex id, window index or seed index
  Vec2 point_in_frame{};    // the query point in the window's halfedge frame (Kind::Window)
};

// Length of the path from a window's source to point (px, py) of the face it enters, whose
// straight line would cross the edge at `x`. Inside the interval that is the straight line; a
// point seen only within the visibility slack is reached through the interval's nearer end, so
// that the distance is always a real path and the backtraced polyline has exactly this length.
inline double WindowPropagation::through_window(const Window& w, double x, double px, double py) {
  if (x >= w.b0 && x <= w.b1) return w.sigma + length2(px - w.sx, py - w.sy);
  const double end = x < w.b0 ? w.b0 : w.b1;
  return w.sigma + length2(end - w.sx, w.sy) + length2(px - end, py);
}

inline void WindowPropagation::HalfedgeEntryPlacement::operator()(const QueueEntry& entry,
                                                             std::uint32_t bucket,
                                                             std::uint32_t index) const {
  // Both bits: a vertex item's index may reach bit 30 (a mesh of 2^30 vertices).
  if ((entry.item & (kVertexItem | kHalfedgeItem)) == kHalfedgeItem) {
    QueuedHalfedge& q = queued[entry.halfedge];
    q.bucket = bucket;
    q.index = index;
  }
}

inline void WindowPropagation::push(double key, std::uint32_t item, std::uint32_t halfedge) {
  queue_.push(QueueEntry{key, item, halfedge});
  stats_.peak_queue = std::max(stats_.peak_queue, queue_.size());
}

inline void WindowPropagation::pop() {
  ++stats_.queue_pops;
  queue_.pop();
}

}  // namespace geoprox::detail
