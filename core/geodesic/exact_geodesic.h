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

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "core/base/errors.h"
#include "core/geodesic/geodesic_types.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

namespace detail {
class WindowPropagation;
}  // namespace detail

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
  /// every point closer is final. The budget is checked between queue entries: where the solver
  /// queues whole halfedges (see ExactGeodesicSolver) the last entry may take it a few windows
  /// further.
  std::size_t max_windows_propagated = 0;
  /// Stop once this many vertices are final (0: no such stop), once past min_distance: the
  /// nearest this many vertices, whatever the triangles' sizes. Checked every 16 queue pops
  /// once that many vertices are reached, so the solve may settle a few more.
  std::size_t stop_after_vertices = 0;
  /// Goal-directed, for a solve to one target (or to none, with a goal_limit): its position in
  /// space, when the edge lengths are the mesh's own (the chords of its positions: not under
  /// another metric), so that the straight line to it bounds every point's geodesic distance
  /// to the target from below. Windows and pseudo-sources whose distance so far plus that bound
  /// exceeds the stop (max_distance, or the target's current estimate) are dropped: the solve
  /// explores an ellipse around the shortest path instead of a disk. Only the target's distance
  /// and the path to it are then exact; other points' values are upper bounds.
  std::optional<Vec3> goal;
  /// With a goal: the bound on distance plus straight-line distance to the goal past which
  /// windows are dropped, in place of max_distance (or the target's estimate), which then
  /// bounds the distance alone. The solve explores the part of its disk that a path to the goal
  /// no longer than this bound can cross; points of that part get exact distances (it holds
  /// their geodesics), others upper bounds or none. Infinity (the default): the stop bounds
  /// both.
  double goal_limit = kInfinity;
  /// Polled every 1024 queue pops; the solve throws Interrupted when it fires. Not owned.
  const QueryInterrupt* interrupt = nullptr;
};

/// Target points prepared once for many solves: validated and indexed by vertex and face, so
/// that a solve does not register them again. The paper's local solves all wait for the same
/// samples, and registering them at every solve would cost a large part of it. Read-only
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
  friend class detail::WindowPropagation;
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

/// Exact geodesic distances and paths from one or more sources. Reusable: its buffers, sized to
/// the mesh once, serve every solve. Not thread-safe: one solver per thread (many solvers may
/// share one mesh and geometry).
///
/// The solver picks how it queues windows: one queue entry per window for solves that stay a few
/// edges wide (those stopping at the nearest vertices, or at the nearest of several targets),
/// one entry per halfedge, propagating all its waiting windows together, for every other solve.
class ExactGeodesicSolver {
 public:
  using Options = ExactGeodesicOptions;

  /// Both must outlive the solver, which only reads them.
  ExactGeodesicSolver(const TriangleMesh& mesh, const IntrinsicGeometry& geometry);
  ~ExactGeodesicSolver();
  ExactGeodesicSolver(ExactGeodesicSolver&&) noexcept;
  ExactGeodesicSolver& operator=(ExactGeodesicSolver&&) noexcept;

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
  const std::vector<std::uint32_t>& touched_vertices() const;
  /// Calls f(halfedge) for the halfedge of every window the last solve stored, in the order
  /// stored (a halfedge comes once per window on it): the edges a bounded solve crossed,
  /// without scanning the whole mesh.
  template <class F>
  void for_each_window_halfedge(F&& f) const {
    const std::size_t count = windows_stored();
    for (std::size_t i = 0; i < count; ++i) f(window_halfedge(i));
  }

  /// Every point with distance <= radius_reached() is final. Infinity after a full solve.
  double radius_reached() const;
  /// Indices (into the targets given to solve) of the settled targets, nearest first, and their
  /// distances.
  const std::vector<std::uint32_t>& settled_targets() const;
  const std::vector<double>& settled_target_distances() const;
  const ExactGeodesicStats& stats() const;

  const TriangleMesh& mesh() const;
  const IntrinsicGeometry& geometry() const;

 private:
  std::size_t windows_stored() const;
  std::uint32_t window_halfedge(std::size_t window) const;

  std::unique_ptr<detail::WindowPropagation> engine_;
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
