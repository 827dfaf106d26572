// Queries on a proximity graph: "Lightweight preprocessing and fast query of geodesic distance
// via proximity graph", §3 (Algorithm 1 for point-to-point distance and path, §3.2 for the
// distance field), plus a distance matrix that shares the linking and the graph searches.
//
// Linking follows the paper's text (§3.1: "the geodesic distances from s to its neighboring
// samples in a geodesic disk of radius R"): every query point is linked to all samples within the
// graph's link radius rho, chosen at build time so that such a disk holds m_st = 2 m_P samples on
// average. A vertex takes its links from its row of the cover table, which lists exactly the
// samples within rho (every sample's build-time solve reached rho). A point inside a face or on
// an edge is linked through the vertices around it: a small exact solve (three edges, at most
// the nearest 100 vertices) settles them, and each offers its cover row; a link is the best
// path through one such vertex (see Options::link_solve_edges). Every graph edge, cover entry
// and link is the length of a real path, so graph answers are upper bounds of the true
// distance.
//
// Near pairs, where the paper's worst errors are (a graph path of few hops bends sharply at the
// samples it passes), get more work (Options::refine_within): both points are solved exactly
// out to near_radius (0.7 rho; farther among large triangles, for the same work). Pairs whose
// graph answer is under exact_within (2) rho come out exact instead, from one solve bounded by
// that answer and directed at t (under the mesh's own lengths; it explores less than the two
// disks would). When the two disks overlap (pairs up to about 1.4 rho), the pair meets at the
// best point of both on an edge near the best common vertex (exact distances on both sides:
// the exact distance where the geodesic crosses that edge). All near
// pairs link through every vertex of their disks, so that their links reach 1.7 rho and the
// graph path bends at one or two samples instead of several. The rule depends on each point
// alone and on the graph's answer, which is symmetric: answers are symmetric. A distance field
// is exact out to 1.75 rho around each source (rho with exact_within = 0), and every sample in
// that disk links the source to the graph; beyond it a vertex takes the best of its cover row,
// never longer than the paper's answer (a query with refine_within = exact_within = 0).
//
// Thread safety: a GeodesicQuery is immutable after construction and may be shared by any
// number of threads; each thread passes its own QueryScratch, which holds every buffer a query
// needs (two exact solvers, the graph labels stamped by generation, heaps), so that nothing is
// allocated in proportion to the mesh or the graph once a scratch has warmed up.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <vector>

#include "core/mesh/closest_point.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/graph/proximity_graph.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

struct QueryLinks;  // geodesic_query.cpp: one query point's links
struct PairAnswer;  // geodesic_query.cpp: a point-to-point answer and where it came from

/// How the augmented graph is searched between s and t (all three give the same distance).
enum class GraphSearch : std::uint8_t {
  /// Two fronts, stopped once the smallest keys of both sum to the best meeting distance
  /// (classic bidirectional Dijkstra), directed towards each other by straight-line potentials
  /// when the edge lengths are the embedding's. Settles the fewest samples: the default.
  Bidirectional = 0,
  /// The paper's Algorithm 1: one queue for both fronts, stopped once a popped label reaches
  /// (best + R) / 2, R being the longest edge of the augmented graph.
  MeetInTheMiddle = 1,
  /// Plain single-source Dijkstra from s until t is settled (the reference for tests).
  Dijkstra = 2,
};

struct GeodesicQueryOptions {
  GraphSearch search = GraphSearch::Bidirectional;
  /// A traced path segment between two samples is accepted when it ends within this fraction
  /// of the segment's length from the next sample; otherwise that segment comes from an exact
  /// solve. The snap moves the end by at most this much, so the polyline length stays within
  /// about tolerance^2 / 2 (relative) of the distance.
  double trace_tolerance = 1e-4;
  /// Positions farther than this from the surface are refused by snap(), as a fraction of
  /// the mesh's bounding-box diagonal.
  double snap_tolerance = 0.05;
  /// A point that is not a vertex is linked through the vertices around it: one exact solve
  /// out to this many edge lengths (the mean of its face's edges; at least to the face's
  /// corners, at most rho), then every vertex it settled offers its cover-table row (exact
  /// build-time distances to the samples within rho of it). A link is the best such path
  /// through one vertex: an upper bound that exceeds the exact distance by about (lateral
  /// offset)^2 / radius, a small fraction of an edge, for a solve over a fraction of the area
  /// of a solve out to rho; links reach samples up to rho plus that radius away. 0 (or any
  /// value reaching rho): links come from a solve out to rho, to the samples within rho,
  /// exactly, as in the paper.
  double link_solve_edges = 3;
  /// ... and no farther than the nearest this many vertices (still at least to the face's
  /// corners): where needles reach across small triangles, the mean of one face's edges
  /// misjudges its neighbourhood (cheese.off: a solve out to three such edges settled 382
  /// vertices at the median, against 39-61 on the regular meshes of the test corpus, 44-135
  /// at their 90th percentile). The radius depends on p alone: the same from a solve that
  /// went farther. A near pair's disk around p still reaches as far as the solve would have
  /// without the limit, so that its wide links take every path the unlimited links would
  /// (docs/queries.md has the figures). 0: no limit.
  std::uint32_t link_solve_vertices = 100;
  /// Pairs whose graph answer is shorter than this many link radii are refined as the file
  /// comment says (near pairs); up to 3 times farther when a point's face has edges more than
  /// 4 times the mesh's mean (by a quarter of that ratio). 0 turns refinement off: then, with
  /// exact_within = 0, every answer is the paper's, and fields equal point-to-point queries.
  double refine_within = 4;
  /// Pairs whose graph answer is shorter than this many link radii are answered exactly, where
  /// the edge lengths are the mesh's own (straight lines then bound geodesics from below): one
  /// exact solve from s, bounded by the graph's answer and goal-directed towards t
  /// (ExactGeodesicOptions::goal), explores the ellipse {x : d(s, x) + |x t| <= answer}, which
  /// for such pairs is smaller than the two near disks of a refinement (below 2 rho: a median
  /// of 0.1-0.4 of their work on lucy, armadillo, the dragon and cheese; docs/queries.md).
  /// Farther pairs, and every pair under another metric, are refined as before. 0 turns it off.
  /// Under the mesh's own lengths and with exact_within > 0, distance fields are exact out to
  /// 1.75 link radii around each source (else rho), and every sample inside links the source
  /// to the graph.
  double exact_within = 2;
  /// The radius of a near pair's two exact solves, in link radii (rho): each solve runs at
  /// least that far, then on while it has done less work than such a disk takes on average
  /// (times half the ratio of its face's edges to the mean when that exceeds 2, at most 3), up
  /// to 3 times that radius.
  /// 0.7 takes about half the work of a solve out to rho.
  double near_radius = 0.7;
};

/// Per-thread buffers for queries on one GeodesicQuery (see the file comment). Movable, not
/// copyable; create one per thread with GeodesicQuery::make_scratch().
class QueryScratch {
 public:
  QueryScratch(QueryScratch&&) noexcept;
  QueryScratch& operator=(QueryScratch&&) noexcept;
  ~QueryScratch();
  struct Impl;  ///< defined in geodesic_query.cpp

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
  /// Throws InvalidInput ("GraphMismatch") if the graph was built for another vertex count.
  GeodesicQuery(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                const ProximityGraphView& graph, const Options& options = {});
  ~GeodesicQuery();

  QueryScratch make_scratch() const;

  /// The exact geodesic distance between two surface points, from the exact solver rather than
  /// the graph (`exact` is true). Under the mesh's own lengths the graph's answer, never below
  /// the distance, bounds a goal-directed solve (ExactGeodesicOptions::goal): it explores an
  /// ellipse around the geodesic instead of the disk out to t. Throws as distance() does.
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
  /// Distances from the nearest of `sources` to every vertex (paper §3.2). Throws InvalidInput
  /// ("NoSources", "BadRadius", point reasons) and "NoCoverTable" for a graph without the
  /// per-vertex table (imported from the paper's text format).
  DistanceField field(std::span<const SurfacePoint> sources, QueryScratch& scratch,
                      const DistanceFieldOptions& options = {}) const;
  /// Row-major |sources| x |targets| distances (kInfinity for unreachable pairs); equal to
  /// distance() for each pair.
  std::vector<double> matrix(std::span<const SurfacePoint> sources,
                             std::span<const SurfacePoint> targets, QueryScratch& scratch) const;

  /// The vertex of sample i (throws InvalidInput "SampleOutOfRange").
  SurfacePoint sample_point(std::uint32_t sample) const;
  /// The closest surface point to a 3D position (the spatial index is built on first use).
  /// Throws InvalidInput ("BadPosition" for non-finite coordinates, "TooFarFromSurface" when it
  /// is farther than snap_tolerance of the bounding-box diagonal).
  SnapResult snap(const Vec3& position) const;

  const TriangleMesh& mesh() const { return *mesh_; }
  const IntrinsicGeometry& geometry() const { return *geometry_; }
  const ProximityGraphView& graph() const { return graph_; }
  /// rho: the graph's link radius (or, for an imported graph without one, the radius at which a
  /// disk holds 2 m_P samples on average).
  double link_radius() const { return link_radius_; }

 private:
  using Links = QueryLinks;
  double link_pair(const SurfacePoint& s, const SurfacePoint& t, QueryScratch::Impl& w,
                   bool& solved_s, bool& solved_t) const;
  PairAnswer answer(const SurfacePoint& s, const SurfacePoint& t, QueryScratch::Impl& w) const;
  PairAnswer answer_near(const SurfacePoint& s, const SurfacePoint& t,
                         QueryScratch::Impl& w) const;
  bool refines(const SurfacePoint& s, const SurfacePoint& t, double graph_distance) const;
  bool solves_exactly(double graph_distance) const;
  double field_exact_radius() const;
  void add_field_region(const ExactGeodesicSolver& solver, double exact_within,
                        double max_distance, Links& out) const;
  void link_field_disks(std::span<const SurfacePoint> sources, double radius, double max_distance,
                        QueryScratch::Impl& w) const;
  const ExactGeodesicSolver& solve_pair_exactly(const SurfacePoint& s, const SurfacePoint& t,
                                                QueryScratch::Impl& w, double& distance) const;
  double solve_exactly(const SurfacePoint& s, const SurfacePoint& t, double graph_distance,
                       ExactGeodesicSolver& solver, const QueryInterrupt* interrupt) const;
  double sparseness(const SurfacePoint& p, double knee) const;
  void solve_near(const SurfacePoint& p, ExactGeodesicSolver& solver,
                  const QueryInterrupt* interrupt) const;
  void wide_links(const ExactGeodesicSolver& solver, QueryScratch::Impl& s, const Links& narrow,
                  Links& out) const;
  double join_disks(QueryScratch::Impl& s, const ExactGeodesicSolver& a, const Links& a_disk,
                    const ExactGeodesicSolver& b, const Links& b_disk, SurfacePoint& at) const;
  PairAnswer join_or_search(QueryScratch::Impl& s, const ExactGeodesicSolver& a,
                            const Links& a_wide, const ExactGeodesicSolver& b,
                            const Links& b_wide) const;
  bool link_by_covers(const SurfacePoint& p, Links& out) const;
  /// Returns how far out `solver`'s distances then answer point-to-point queries from p
  /// exactly: rho, or every distance it reached when p had no sample within rho and it solved
  /// on to the nearest one.
  double link_by_solve(const SurfacePoint& p, ExactGeodesicSolver& solver, QueryScratch::Impl& s,
                       Links& out, bool solved_to_link_radius = false) const;
  /// Links p, whose solve out to rho `solver` holds (fields, matrices): through its cover row
  /// or by that solve. Returns as link_by_solve does (rho for a cover row).
  double link_solved(const SurfacePoint& p, ExactGeodesicSolver& solver, QueryScratch::Impl& s,
                     Links& out) const;
  struct LinkSolveRadius {
    double radius;   ///< link_solve_edges of the face's mean edge, at least `corners`, at most rho
    double corners;  ///< the farthest corner of p's face
  };
  LinkSolveRadius link_solve_radius(const SurfacePoint& p) const;
  double nearest_vertices_radius(const ExactGeodesicSolver& solver, const LinkSolveRadius& r,
                                 QueryScratch::Impl& s) const;
  double mean_face_edge(std::uint32_t face) const;
  bool link_through_covers(const ExactGeodesicSolver& solver, double radius,
                           QueryScratch::Impl& s, Links& out,
                           const Links* base = nullptr) const;
  bool may_be_within_link_radius(const SurfacePoint& s, const SurfacePoint& t) const;
  std::vector<PathPoint> link_piece(const SurfacePoint& p, const Links& links,
                                    std::uint32_t sample, QueryScratch::Impl& s,
                                    ExactGeodesicSolver& solver) const;
  void solve_within_link_radius(const SurfacePoint& p, ExactGeodesicSolver& solver,
                                const QueryInterrupt* interrupt) const;
  bool solve_towards(const SurfacePoint& p, const SurfacePoint& to, double radius,
                     ExactGeodesicSolver& solver, const QueryInterrupt* interrupt) const;
  std::vector<PathPoint> exact_piece(const SurfacePoint& from, const SurfacePoint& to,
                                     double length, ExactGeodesicSolver& solver,
                                     const QueryInterrupt* interrupt) const;
  double search(QueryScratch::Impl& s, const Links& from_s, const Links& from_t,
                double upper_bound, std::uint32_t& meet, std::uint32_t& settled) const;
  double search_bidirectional(QueryScratch::Impl& s, const Links& from_s, const Links& from_t,
                              double best, std::uint32_t& meet, std::uint32_t& settled) const;
  double search_meet_in_the_middle(QueryScratch::Impl& s, const Links& from_s,
                                   const Links& from_t, double best, std::uint32_t& meet,
                                   std::uint32_t& settled) const;
  double search_dijkstra(QueryScratch::Impl& s, const Links& from_s, const Links& from_t,
                         double best, std::uint32_t& meet, std::uint32_t& settled) const;
  void graph_distances_from(QueryScratch::Impl& s, std::span<const Links* const> sources,
                            double max_distance) const;
  void append_segment(QueryScratch::Impl& s, std::uint32_t from_sample, std::uint32_t to_sample,
                      std::uint32_t edge, PathResult& out) const;

  const TriangleMesh* mesh_;
  const IntrinsicGeometry* geometry_;
  ProximityGraphView graph_;
  Options options_;
  double link_radius_ = 0;
  std::vector<std::int32_t> sample_of_vertex_;  ///< sample index per vertex, or -1
  std::vector<SurfacePoint> sample_points_;
  /// Every sample, prepared once for the solves to the nearest ones (shared by all scratches).
  std::optional<GeodesicTargets> sample_targets_;
  std::vector<Vec3> sample_positions_;
  double bbox_diagonal_ = 0;
  std::size_t near_windows_ = 0;  ///< a near disk's budget, windows propagated (solve_near)
  double mean_edge_length_ = 0;  ///< of the intrinsic edges (see sparseness)
  double longest_edge_length_ = 0;  ///< of the intrinsic edges (see join_disks)
  mutable std::once_flag snap_index_once_;
  mutable std::unique_ptr<ClosestPointIndex> snap_index_;
};

}  // namespace geoprox
