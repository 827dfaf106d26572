// Exact discrete geodesics by window propagation: Xin & Wang, "Improving Chen and Han's
// algorithm on the discrete geodesic problem", ACM TOG 28(4), 2009 (ICH), with the windows
// processed in order of their minimum distance, or a lower bound of it (as in Mitchell, Mount &
// Papadimitriou 1987 and Surazhsky et al. 2005) so a solve can stop early, and with windows
// trimmed against the vertices' current distances (ICH's filters) and against the other windows
// on their edge (MMP's pairwise trimming) when they are created. docs/exact_geodesic.md has the
// details and the robustness decisions.
//
// A window is an interval of a halfedge through which the straight unfolded segment from one
// (pseudo-)source S reaches every point; its distance is sigma + |S - x|. Every stored window is
// a real path, so all distances are upper bounds that become exact once settled. Pseudo-sources
// are saddle vertices (emitting only into their shadow), boundary vertices and corners of
// zero-area faces; flat vertices are passed straight through.
//
// Reads only IntrinsicGeometry (edge lengths): positions are used only to report path points,
// and for the straight-line bound of a goal-directed solve (Options::goal), which callers ask
// for only when the lengths are the positions' chords.
#pragma once

#include <algorithm>
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
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/base/radix_heap.h"
#include "core/base/mapped_array.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

struct GeodesicSource {
  SurfacePoint point;
  double offset = 0;  ///< distance already travelled to this source (mesh units, >= 0)
};

/// A unit direction in the frame of a face (origin at its corner 0, x towards corner 1, y towards
/// corner 2's side), see IntrinsicGeometry. Stored by the proximity graph and traced from later.
struct FaceDirection {
  std::uint32_t face = 0;
  double x = 1, y = 0;
};

struct PathPoint {
  SurfacePoint point;
  Vec3 position;
};

struct GeodesicPath {
  /// From the source to the target: the source point, edge crossings and pseudo-source vertices,
  /// then the target point.
  std::vector<PathPoint> points;
  double length = kInfinity;       ///< equals the distance to the target
  std::uint32_t source_index = 0;  ///< which of the solve's sources the path starts at
  /// Unit tangent at the source pointing along the path (towards the target), and at the target
  /// pointing back along the path (towards the source). For a path of zero length both are the
  /// x axis of the point's face.
  FaceDirection direction_at_source;
  FaceDirection direction_at_target;
};

struct ExactGeodesicStats {
  std::size_t windows_created = 0;     ///< windows stored after creation-time pruning
  std::size_t pseudo_source_windows = 0;  ///< of which emitted directly by a (pseudo-)source
  std::size_t windows_propagated = 0;  ///< windows popped and unfolded into the next face
  /// windows dropped at creation (vertex or pairwise pruning) or cut away later by a new one
  std::size_t windows_pruned = 0;
  /// windows not stored because the solve stops before it would pop them (bounded solves)
  std::size_t windows_beyond_stop = 0;
  std::size_t vertices_reached = 0;    ///< vertices whose distance is final (<= radius_reached)
  std::size_t peak_queue = 0;          ///< largest priority-queue size
  std::size_t queue_pops = 0;          ///< entries popped (windows, vertices, stale entries)
};

struct ExactGeodesicOptions {
  /// Stop once every point within this geodesic distance of the sources is final (mesh
  /// units); points farther away are reported unreachable, except those a little beyond that
  /// are final too: radius_reached() may exceed this, up to the nearest window the solve did
  /// not store, by an amount that rounding decides. Infinity: the whole surface.
  double max_distance = kInfinity;
  /// With targets: stop as soon as this many targets are settled (0: all of them). The
  /// settled ones are then exactly the nearest ones, this many of them (ties at the last
  /// distance, coincident targets included, are cut in settling order), more only as
  /// min_distance says.
  std::size_t stop_after_targets = 0;
  /// With stop_after_targets or max_windows_propagated: do not stop before every point within
  /// this distance is final, even when enough targets are settled (all targets within it are
  /// then settled too) or the budget is spent.
  double min_distance = 0;
  /// Stop once this many windows have been propagated (0: no limit), once past min_distance: a
  /// budget of work rather than a radius. radius_reached() is then the smallest key left, and
  /// every point closer is final. The budget is checked between queue entries: with halfedges
  /// queued (queue_halfedges) the last entry may take it a few windows further.
  std::size_t max_windows_propagated = 0;
  /// Stop once this many vertices are final (0: no such stop), once past min_distance: the
  /// nearest this many vertices, whatever the triangles' sizes. Checked every 16 queue pops
  /// once that many vertices are reached, so the solve may settle a few more.
  std::size_t stop_after_vertices = 0;
  /// Queue each halfedge's waiting windows as one entry, propagated together (VTP's
  /// organisation), in a solve with a radius or targets too; a full solve always does. It pays
  /// where the wavefront is wide: the graph builder's local solves are 6-9% faster (armadillo,
  /// lucy), solves to the 36 nearest of 5000 samples on lucy.obj 3-10%, solves out to a
  /// query's link radius on lucy.obj 9%; solves a few edges wide gain nothing. The solver then
  /// keeps 16 bytes per halfedge of the mesh, from its first such solve on.
  bool queue_halfedges = false;
  /// Goal-directed, for a solve to one target: that target's position in space, when the edge
  /// lengths are the mesh's own (the chords of its positions: not under another metric), so
  /// that the straight line to it bounds every point's geodesic distance to the target from
  /// below. Windows and pseudo-sources whose distance so far plus that bound exceeds the stop
  /// (max_distance, or the target's current estimate) are dropped: the solve explores an
  /// ellipse around the shortest path instead of a disk. Only the target's distance and the
  /// path to it are then exact; other points' values are upper bounds.
  std::optional<Vec3> goal;
  /// Polled every 1024 queue pops; the solve throws Interrupted when it fires. Not owned.
  const QueryInterrupt* interrupt = nullptr;
};

/// Target points prepared once for many solves: validated and indexed by vertex and face, so
/// that a solve does not register them again. The paper's local solves all wait for the same
/// samples; registering 5000 of them took an eighth of a 36-nearest solve on lucy.obj. Read-only
/// once built: solvers on several threads may share one. Target i is points[i].
class GeodesicTargets {
 public:
  /// Throws InvalidInput for a point that is not on the geometry's mesh. The geometry must
  /// outlive the set.
  GeodesicTargets(const IntrinsicGeometry& geometry, std::span<const SurfacePoint> points) {
    assign(geometry, points);
  }
  std::size_t size() const { return entries_.size(); }
  bool empty() const { return entries_.empty(); }

 private:
  friend class ExactGeodesicSolver;
  // No public default constructor, so that solve(sources, {}, options) stays a solve without
  // targets rather than an ambiguous call.
  struct Unset {};
  explicit GeodesicTargets(Unset) {}
  /// Replaces the set, reusing its memory: only the index entries the old points wrote are
  /// cleared (a solver's own set, refilled at every solve, never walks the whole mesh).
  /// Validates every point before anything changes.
  void assign(const IntrinsicGeometry& geometry, std::span<const SurfacePoint> points);

  struct Entry {
    std::int32_t vertex;  ///< >= 0 for a vertex target, else the point is `point` in `face`
    std::uint32_t face;
    Vec2 point;           ///< in the face's frame (face targets)
    std::int32_t next;    ///< next target at the same vertex or in the same face, or -1
  };
  const IntrinsicGeometry* geometry_ = nullptr;
  std::vector<Entry> entries_;
  std::vector<std::int32_t> vertex_first_;  ///< per vertex: its first target, or -1
  std::vector<std::int32_t> face_first_;    ///< per face: its first face target, or -1
  std::size_t face_targets_ = 0;            ///< targets that are not vertices
};

class ExactGeodesicSolver {
 public:
  using Options = ExactGeodesicOptions;


  /// Both must outlive the solver, which only reads them (many solvers may share one mesh).
  ExactGeodesicSolver(const TriangleMesh& mesh, const IntrinsicGeometry& geometry);

  /// Runs one solve; buffers are reused from the previous solve. Throws InvalidInput for an
  /// invalid source or target point, or a negative or non-finite offset.
  void solve(std::span<const GeodesicSource> sources, std::span<const SurfacePoint> targets = {},
             const Options& options = {});
  /// The same with targets prepared once, with this solver's geometry (InvalidInput
  /// otherwise). settled_targets() indexes them.
  void solve(std::span<const GeodesicSource> sources, const GeodesicTargets& targets,
             const Options& options = {});
  void solve(const SurfacePoint& source, const Options& options = {});

  /// Distance to vertex v, or kInfinity if unreachable / beyond the radius reached.
  double distance(std::uint32_t vertex) const;
  /// Distance to any surface point (validated; throws InvalidInput if it is not on the mesh).
  double distance(const SurfacePoint& point) const;
  /// Distance of every vertex, in vertex order (kInfinity where not reached).
  std::vector<double> vertex_distances() const;
  /// The source whose distance field is smallest at vertex v (the geodesic Voronoi cell), or -1.
  std::int32_t nearest_source(std::uint32_t vertex) const;

  /// Shortest path from the sources to `point`; throws Unreachable if it was not reached.
  GeodesicPath path_to(const SurfacePoint& point) const;

  /// Vertices the last solve gave a distance to (final or not), in the order reached; with
  /// distance(v) this lists a bounded solve's disk without scanning the whole mesh.
  const std::vector<std::uint32_t>& touched_vertices() const { return touched_vertices_; }

  /// Calls f(halfedge) for the halfedge of every window the last solve stored, in the order
  /// stored (a halfedge comes once per window on it): the edges a bounded solve crossed,
  /// without scanning the whole mesh.
  template <class F>
  void for_each_window_halfedge(F&& f) const {
    for (std::size_t i = 0; i < windows_.size(); ++i) f(windows_[i].halfedge);
  }

  /// Every point with distance <= radius_reached() is final. Infinity after a full solve.
  double radius_reached() const { return radius_reached_; }
  /// Indices (into the targets given to solve) of the settled targets, nearest first, and their
  /// distances.
  const std::vector<std::uint32_t>& settled_targets() const { return settled_targets_; }
  const std::vector<double>& settled_target_distances() const { return settled_distances_; }
  const ExactGeodesicStats& stats() const { return stats_; }

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
  // chunk is laid out by field so that one branch-free test (overlap_mask) screens five spans
  // (a new window on horse.ply screens about 20): 9% fewer instructions per solve there than a
  // test and a branch per span.
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
  bool source_at_pseudo_source_end(std::uint32_t halfedge, Vec2 source, double sigma, std::int32_t parent);
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
    return key + bound > store_limit_ * (1 + kGoalSlack);
  }
  static constexpr double kGoalSlack = 1e-12;  ///< relative, against rounding in the bound

  const TriangleMesh* mesh_;
  const IntrinsicGeometry* geometry_;
  /// How far outside a window's interval (mesh units) the ray to its face's far corner, not
  /// reached yet, may pass and still reach it, through the interval's nearer end (propagate):
  /// kNearMiss of the mean edge length. The detour costs at most ~near_miss^2 / distance.
  /// (1e-5 still left a corner beside a 1e-6 needle 9e-6 too far in the stress tests.)
  static constexpr double kNearMiss = 1e-4;
  /// Two points closer than this fraction of the lengths around them coincide (rounding).
  static constexpr double kCoincident = 1e-12;
  double near_miss_;
  /// The most windows one solve may store: kWindowsPerHalfedge per halfedge of the mesh (full
  /// solves on real meshes store 2-17), at least kMinWindows. Past it the solve throws
  /// ResourceExhausted, so that no solve's memory grows beyond a bound set by the mesh.
  static constexpr std::size_t kWindowsPerHalfedge = 64;
  static constexpr std::size_t kMinWindows = std::size_t{1} << 20;
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
  double skipped_min_key_ = kInfinity;
  /// Targets waited for, up to this many, are tracked to bound the solve's stop.
  static constexpr std::size_t kMaxNearestTracked = 64;
  std::size_t nearest_wanted_ = 0;
  std::vector<std::uint32_t> nearest_targets_;
  std::size_t nearest_worst_ = 0;  ///< index in nearest_targets_ of the largest estimate
  ExactGeodesicStats stats_;
};

/// One-shot: exact distance of every vertex from the sources (kInfinity where unreachable or
/// beyond options.max_distance).
std::vector<double> exact_geodesic_distances(const TriangleMesh& mesh,
                                             const IntrinsicGeometry& geometry,
                                             std::span<const GeodesicSource> sources,
                                             const ExactGeodesicSolver::Options& options = {});

/// One-shot: exact shortest path between two surface points.
GeodesicPath exact_geodesic_path(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                                 const SurfacePoint& source, const SurfacePoint& target);

}  // namespace geoprox
