// Queries on a proximity graph: "Lightweight preprocessing and fast query of geodesic distance
// via proximity graph", section 3 (Algorithm 1 for point-to-point distance and path, 3.2 for the
// distance field), plus a distance matrix that shares the linking and the graph searches.
//
// Every query point is linked to the samples within the graph's link radius rho (chosen at build
// time so that such a disk holds 2 m_P samples on average). A vertex takes its links from its
// row of the cover table; a point inside a face or on an edge is linked through the vertices
// around it, which a small exact solve settles. Every graph edge, cover entry and link is the
// length of a real path, so graph answers are upper bounds of the true distance.
//
// Near pairs, where the paper's worst errors are, get more work (Options::refine_within): both
// points are solved exactly out to a near radius, their disks are joined where they overlap, and
// their links reach farther so that the graph path bends at fewer samples. Pairs whose graph
// answer is under Options::exact_within rho come out exact, from one solve bounded by that
// answer and directed at t. A distance field is exact out to a radius around each source, and
// every sample in that disk links the source to the graph; beyond it a vertex takes the best of
// its cover row. The rule depends on each point alone and on the graph's answer, which is
// symmetric: answers are symmetric. The graph is searched from both ends at once, each front
// steered towards the other by lower bounds of the distance left: straight lines, and the
// triangle inequality over graph distances from a few landmark samples computed when the query
// object is made. docs/queries.md describes all of this with its figures.
//
// Thread safety: a GeodesicQuery is immutable after construction and may be shared by any
// number of threads; each thread passes its own QueryScratch, which holds every buffer a query
// needs, so that nothing is allocated in proportion to the mesh or the graph once a scratch has
// warmed up.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "core/base/errors.h"
#include "core/geodesic/geodesic_types.h"
#include "core/graph/proximity_graph.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

class RefinedSurface;

namespace detail {
class QueryEngine;
struct QueryTuning;
}  // namespace detail

struct GeodesicQueryOptions {
  /// Pairs whose graph answer is shorter than this many link radii are refined (near pairs, see
  /// the file comment); farther for a point whose face's edges are much longer than the mesh's
  /// mean. 0 turns refinement off: then, with exact_within = 0, every answer is the paper's,
  /// and fields equal point-to-point queries.
  double refine_within = 4;
  /// Pairs whose graph answer is shorter than this many link radii are answered exactly, where
  /// the edge lengths are the mesh's own (straight lines then bound geodesics from below): one
  /// exact solve from s, bounded by the graph's answer and goal-directed towards t, explores
  /// the ellipse {x : d(s, x) + |x t| <= answer}, which for such pairs is smaller than the two
  /// near disks of a refinement. Farther pairs, and every pair under another metric, are
  /// refined. 0 turns it off. With exact_within > 0 (and the mesh's own lengths), distance
  /// fields are exact out to 1.75 link radii around each source (else rho).
  double exact_within = 2;
};

/// Per-thread buffers for queries on one GeodesicQuery (see the file comment). Movable, not
/// copyable; create one per thread with GeodesicQuery::make_scratch().
class QueryScratch {
 public:
  QueryScratch(QueryScratch&&) noexcept;
  QueryScratch& operator=(QueryScratch&&) noexcept;
  ~QueryScratch();
  struct Impl;  ///< defined in query_engine.h

  /// Queries run with this scratch poll `interrupt` (in the exact solves and the graph
  /// searches) and throw Interrupted when it fires; nullptr (the default) never interrupts.
  /// Not owned: it must outlive the queries, or be reset first.
  void set_interrupt(const QueryInterrupt* interrupt);

  /// Runs two independent parts of one query: both, possibly at the same time on another
  /// thread, returning once both are done and rethrowing an exception of either (the first's
  /// if both threw). Each part uses its own solver of this scratch and reads the query's
  /// shared, read-only data only.
  using RunBoth =
      std::function<void(const std::function<void()>& first, const std::function<void()>& second)>;
  /// A near pair's two exact solves (most of its time) go through `run_both`, so that a server
  /// with an idle thread can run them at once. Empty (the default): one after the other.
  void set_run_both(RunBoth run_both);

 private:
  friend class GeodesicQuery;
  friend class detail::QueryEngine;
  explicit QueryScratch(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

struct DistanceResult {
  double distance = kInfinity;
  /// True when the answer came from an exact solve (s and t within one local region, or a
  /// graph answer under exact_within rho).
  bool exact = false;
  /// True when a near pair met at a point of both points' exact disks (see the file comment):
  /// no sample on the way.
  bool joined = false;
  /// Samples whose graph label became final during the search: 0 for pairs answered exactly
  /// before any search (closer than rho); a pair under exact_within rho counts the search whose
  /// answer bounded its exact solve.
  std::uint32_t samples_settled = 0;
};

struct PathResult {
  double distance = kInfinity;
  bool exact = false;
  bool joined = false;  ///< as DistanceResult::joined (then `samples` is empty)
  /// From s to t: s, every edge crossing, the samples passed through, t. Starts exactly at s
  /// and ends exactly at t; its length equals `distance` (see trace_tolerance).
  std::vector<PathPoint> points;
  /// The samples the path passes through, in order from s.
  std::vector<std::uint32_t> samples;
  /// Sample-to-sample segments that came from an exact solve because tracing the stored
  /// direction was not trusted (a vertex on the way, a boundary, or a miss).
  std::uint32_t exact_segments = 0;
};

struct DistanceFieldOptions {
  /// Vertices farther than this from every source get kInfinity (mesh units).
  double max_distance = kInfinity;
  /// OpenMP threads for the per-vertex pass; 0 uses OpenMP's default, 1 runs inline (what a
  /// server with its own thread pool wants).
  int threads = 1;
};

struct DistanceField {
  /// Distance of every vertex from the nearest source (kInfinity: unreachable or beyond
  /// max_distance).
  std::vector<double> distances;
  /// Index of that source per vertex (-1 where unreachable): the geodesic Voronoi diagram.
  std::vector<std::int32_t> nearest_source;
};

struct SnapResult {
  SurfacePoint point;
  Vec3 position;          ///< where the position was moved to
  double moved = 0;       ///< distance moved (mesh units)
};

class GeodesicQuery {
 public:
  using Options = GeodesicQueryOptions;

  /// All three must outlive the query object; the graph is usually a view into a mapped file.
  /// Throws InvalidInput (GraphMismatch) if the graph was built for another vertex count.
  /// Makes the search's landmark distances: a Dijkstra search of the graph per landmark, and
  /// tuning::kSearchLandmarks doubles per sample.
  GeodesicQuery(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                const ProximityGraphView& graph, const Options& options = {});
  /// Over a graph built on a refinement of `mesh` (ProximityGraph::refined, or a version-3
  /// graph file's: core/graph/refined_surface.h): the graph and the searches work on
  /// refined.mesh(), while points are given and answered on `mesh` (paths' points too), and
  /// fields are per vertex of `mesh`. `refined` must outlive the query.
  GeodesicQuery(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                const ProximityGraphView& graph, const RefinedSurface& refined,
                const Options& options = {});
  /// Tests only: the same with other links and graph search than the defaults (query_engine.h).
  GeodesicQuery(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                const ProximityGraphView& graph, const Options& options,
                const detail::QueryTuning& tuning);
  ~GeodesicQuery();
  GeodesicQuery(GeodesicQuery&&) noexcept;
  GeodesicQuery& operator=(GeodesicQuery&&) noexcept;

  QueryScratch make_scratch() const;

  /// The exact geodesic distance between two surface points, from the exact solver rather than
  /// the graph (`exact` is true). Under the mesh's own lengths the graph's answer, never below
  /// the distance, bounds a goal-directed solve: it explores an ellipse around the geodesic
  /// instead of the disk out to t. Throws as distance() does.
  DistanceResult exact_distance(const SurfacePoint& s, const SurfacePoint& t,
                                QueryScratch& scratch) const;
  /// The exact geodesic and its length, by the same bounded solve as exact_distance (`exact`
  /// is true): the backtrace of that solve. Throws as path() does.
  PathResult exact_path(const SurfacePoint& s, const SurfacePoint& t,
                        QueryScratch& scratch) const;

  /// Geodesic distance between two surface points. Throws InvalidInput for invalid points and
  /// Unreachable when they lie in different components.
  DistanceResult distance(const SurfacePoint& s, const SurfacePoint& t,
                          QueryScratch& scratch) const;
  /// Distance and the path as a polyline on the surface.
  PathResult path(const SurfacePoint& s, const SurfacePoint& t, QueryScratch& scratch) const;
  /// Distances from the nearest of `sources` to every vertex (paper section 3.2). Throws
  /// InvalidInput (NoSources, BadRadius, point codes) and NoCoverTable for a graph without the
  /// per-vertex table (imported from the paper's text format).
  DistanceField field(std::span<const SurfacePoint> sources, QueryScratch& scratch,
                      const DistanceFieldOptions& options = {}) const;
  /// Row-major |sources| x |targets| distances (kInfinity for unreachable pairs); equal to
  /// distance() for each pair up to rounding (the searches shared among targets add the same
  /// lengths in another order: a few units in the last place).
  std::vector<double> matrix(std::span<const SurfacePoint> sources,
                             std::span<const SurfacePoint> targets, QueryScratch& scratch) const;

  /// The vertex of sample i (throws InvalidInput SampleOutOfRange).
  SurfacePoint sample_point(std::uint32_t sample) const;
  /// The closest surface point to a 3D position (the spatial index is built on first use).
  /// Throws InvalidInput (BadPosition for non-finite coordinates, TooFarFromSurface when it is
  /// farther than 5% of the bounding-box diagonal).
  SnapResult snap(const Vec3& position) const;

  /// The mesh points are given on, and its lengths.
  const TriangleMesh& mesh() const;
  const IntrinsicGeometry& geometry() const;
  /// The graph (over the refined mesh when built on a refinement).
  const ProximityGraphView& graph() const;
  /// The refinement the graph was built on, or null.
  const RefinedSurface* refined() const { return refined_; }
  const Options& options() const;
  /// rho: the graph's link radius (or, for an imported graph without one, the radius at which a
  /// disk holds 2 m_P samples on average).
  double link_radius() const;

 private:
  /// `point` (given on mesh()) on the engine's mesh.
  SurfacePoint to_engine(const SurfacePoint& point) const;
  std::vector<SurfacePoint> to_engine(std::span<const SurfacePoint> points) const;
  /// A path of the engine's mesh on mesh(), from s to t as given.
  void path_to_mesh(PathResult& path, const SurfacePoint& s, const SurfacePoint& t) const;

  std::unique_ptr<detail::QueryEngine> engine_;
  const TriangleMesh* mesh_;
  const IntrinsicGeometry* geometry_;
  const RefinedSurface* refined_ = nullptr;
};

}  // namespace geoprox
