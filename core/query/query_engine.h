// The query engine behind GeodesicQuery (geodesic_query.h): its state, the links of query
// points, the graph searches' labels and the per-thread scratch. Private to core/query; its
// parts are in query_engine.cpp (construction, snapping, linking), query_search.cpp (graph
// searches), query_pairs.cpp (point-to-point answers), query_paths.cpp and query_fields.cpp
// (fields and matrices).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "core/base/errors.h"
#include "core/base/tuning.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/geodesic/geodesic_tracing.h"
#include "core/geodesic/geodesic_types.h"
#include "core/graph/proximity_graph.h"
#include "core/mesh/closest_point.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"
#include "core/query/geodesic_query.h"

namespace geoprox::detail {

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

/// How queries link points and search the graph, beyond what users set (GeodesicQueryOptions).
/// Tests vary these to compare with the paper's choices; everything else uses the defaults.
struct QueryTuning {
  GraphSearch search = GraphSearch::Bidirectional;
  /// A point that is not a vertex is linked through the vertices around it: one exact solve
  /// out to this many edge lengths (the mean of its face's edges; at least to the face's
  /// corners, at most rho), then every vertex it settled offers its cover-table row (exact
  /// build-time distances to the samples within rho of it). A link is the best such path
  /// through one vertex: an upper bound that exceeds the exact distance by about (lateral
  /// offset)^2 / radius, a small fraction of an edge. 0 (or any value reaching rho): links come
  /// from a solve out to rho, to the samples within rho, exactly, as in the paper.
  double link_solve_edges = tuning::kLinkSolveEdges;
  /// ... and no farther than the nearest this many vertices (still at least to the face's
  /// corners): where needles reach across small triangles, the mean of one face's edges
  /// misjudges its neighbourhood. The radius depends on p alone. A near pair's disk around p
  /// still reaches as far as the solve would have without the limit. 0: no limit.
  std::uint32_t link_solve_vertices = tuning::kLinkSolveVertices;
  /// A near pair's disks are directed at the pair's other point where the mesh's own lengths
  /// allow it (solve_near). false: whole disks, as under another metric.
  bool directed_near_disks = true;
  /// Landmarks of the bidirectional search's potentials (search_bidirectional), at most
  /// tuning::kSearchLandmarks. 0: straight-line potentials alone (none under another metric).
  std::uint32_t search_landmarks = tuning::kSearchLandmarks;
};

struct HeapEntry {
  double key;
  std::uint32_t node;
  std::uint32_t side;  // 0: from s, 1: from t (meet-in-the-middle shares one heap)
};

/// Parent of a sample linked directly to the query point.
inline constexpr std::int32_t kFromQueryPoint = -1;
/// QueryLinks::via of a link not through a vertex.
inline constexpr std::uint32_t kDirect = UINT32_MAX;

// Links of one query point: its nearest samples with exact distances, and what its local solve
// found out about the other query point(s).
struct QueryLinks {
  std::vector<std::pair<std::uint32_t, double>> samples;
  /// Parallel to samples: the vertex a link passes through and the exact distance to it
  /// (links through covers), or {kDirect, 0} for a link straight from a solve or a cover row.
  std::vector<std::pair<std::uint32_t, double>> via;
  double longest = 0;
  /// The exact distances of the local solve to every vertex it settled (fields, near pairs).
  std::vector<std::pair<std::uint32_t, double>> region;
};

/// A point-to-point answer and where it came from (paths are rebuilt from it).
struct PairAnswer {
  enum class From : std::uint8_t {
    Graph,   ///< a search over the augmented graph; halves meet at sample `meet`
    SolveS,  ///< exact, from solver_s's solve from s
    SolveT,  ///< exact, from solver_t's solve from t
    Join,    ///< near pair: through `join_point`, in both solvers' disks
  };
  double distance = kInfinity;
  From from = From::Graph;
  std::uint32_t meet = UINT32_MAX;
  SurfacePoint join_point;
  std::uint32_t settled = 0;
};

// A link solve's distance as point-to-point queries take it: exact out to `exact_within` (what
// link_by_solve returns), else none.
inline double exact_up_to(double d, double exact_within) {
  return d <= exact_within ? d : kInfinity;
}

/// The error of a pair in different connected components.
inline Unreachable unreachable(const SurfacePoint& s, const SurfacePoint& t) {
  return Unreachable(ErrorCode::Unreachable,
                     "no path between " + s.to_string() + " and " + t.to_string() +
                         ": they lie in different connected components");
}

class QueryEngine {
 public:
  using Options = GeodesicQueryOptions;

  // What GeodesicQuery offers, with its contracts (geodesic_query.h).
  QueryEngine(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
              const ProximityGraphView& graph, const Options& options,
              const QueryTuning& tuning);
  QueryScratch make_scratch() const;
  DistanceResult exact_distance(const SurfacePoint& s, const SurfacePoint& t,
                                QueryScratch& scratch) const;
  PathResult exact_path(const SurfacePoint& s, const SurfacePoint& t,
                        QueryScratch& scratch) const;
  DistanceResult distance(const SurfacePoint& s, const SurfacePoint& t,
                          QueryScratch& scratch) const;
  PathResult path(const SurfacePoint& s, const SurfacePoint& t, QueryScratch& scratch) const;
  DistanceField field(std::span<const SurfacePoint> sources, QueryScratch& scratch,
                      const DistanceFieldOptions& options) const;
  std::vector<double> matrix(std::span<const SurfacePoint> sources,
                             std::span<const SurfacePoint> targets, QueryScratch& scratch) const;
  SurfacePoint sample_point(std::uint32_t sample) const;
  SnapResult snap(const Vec3& position) const;
  const TriangleMesh& mesh() const { return *mesh_; }
  const IntrinsicGeometry& geometry() const { return *geometry_; }
  const ProximityGraphView& graph() const { return graph_; }
  double link_radius() const { return link_radius_; }
  const GeodesicQueryOptions& options() const { return options_; }

 private:
  using Links = QueryLinks;
  double link_pair(const SurfacePoint& s, const SurfacePoint& t, QueryScratch::Impl& w,
                   bool& solved_s, bool& solved_t) const;
  PairAnswer answer(const SurfacePoint& s, const SurfacePoint& t, QueryScratch::Impl& w) const;
  PairAnswer answer_near(const SurfacePoint& s, const SurfacePoint& t, double graph_distance,
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
                  const QueryInterrupt* interrupt, const SurfacePoint* toward = nullptr,
                  double pair_bound = kInfinity) const;
  bool near_disks_directed() const;
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
  void choose_landmarks();
  void prepare_landmarks(QueryScratch::Impl& s, const Links& from_s, const Links& from_t) const;
  void append_segment(QueryScratch::Impl& s, std::uint32_t from_sample, std::uint32_t to_sample,
                      std::uint32_t edge, PathResult& out) const;

  const TriangleMesh* mesh_;
  const IntrinsicGeometry* geometry_;
  ProximityGraphView graph_;
  Options options_;
  QueryTuning tuning_;
  double link_radius_ = 0;
  std::vector<std::int32_t> sample_of_vertex_;  ///< sample index per vertex, or -1
  std::vector<SurfacePoint> sample_points_;
  /// Every sample, prepared once for the solves to the nearest ones (shared by all scratches).
  std::optional<GeodesicTargets> sample_targets_;
  std::vector<Vec3> sample_positions_;
  /// Graph distance from landmark k to sample i at [i * landmarks_ + k] (kInfinity where
  /// unreachable): the bidirectional search's potentials (choose_landmarks).
  std::vector<double> landmark_distance_;
  std::uint32_t landmarks_ = 0;
  double bbox_diagonal_ = 0;
  std::size_t near_windows_ = 0;  ///< a near disk's budget, windows propagated (solve_near)
  double mean_edge_length_ = 0;  ///< of the intrinsic edges (see sparseness)
  double longest_edge_length_ = 0;  ///< of the intrinsic edges (see join_disks)
  mutable std::once_flag snap_index_once_;
  mutable std::unique_ptr<ClosestPointIndex> snap_index_;
};

}  // namespace geoprox::detail

namespace geoprox {

struct QueryScratch::Impl {
  Impl(const TriangleMesh& mesh, const IntrinsicGeometry& geometry, std::uint32_t num_samples)
      : solver_s(mesh, geometry),
        solver_t(mesh, geometry),
        stamp(num_samples, 0),
        label{std::vector<double>(num_samples), std::vector<double>(num_samples)},
        parent{std::vector<std::int32_t>(num_samples), std::vector<std::int32_t>(num_samples)},
        parent_edge{std::vector<std::uint32_t>(num_samples),
                    std::vector<std::uint32_t>(num_samples)},
        settled_stamp{std::vector<std::uint32_t>(num_samples, 0),
                      std::vector<std::uint32_t>(num_samples, 0)},
        potential(num_samples),
        origin(num_samples),
        link_stamp(num_samples, 0),
        link_slot(num_samples, 0),
        join_stamp(mesh.num_vertices(), 0),
        join_distance(mesh.num_vertices()),
        join_edge_stamp(mesh.num_edges(), 0) {}

  // Lazily resets sample i's labels for this search.
  void touch(std::uint32_t i) {
    if (stamp[i] != generation) {
      stamp[i] = generation;
      label[0][i] = label[1][i] = kInfinity;
      parent[0][i] = parent[1][i] = detail::kFromQueryPoint;
      potential[i] = kNoPotential;
    }
  }
  static constexpr double kNoPotential = -kInfinity;  ///< not computed yet in this search
  double get(int side, std::uint32_t i) const {
    return stamp[i] == generation ? label[side][i] : kInfinity;
  }
  bool is_settled(int side, std::uint32_t i) const {
    return settled_stamp[side][i] == generation;
  }
  void new_search() {
    if (++generation == 0) {
      std::fill(stamp.begin(), stamp.end(), 0);
      std::fill(settled_stamp[0].begin(), settled_stamp[0].end(), 0);
      std::fill(settled_stamp[1].begin(), settled_stamp[1].end(), 0);
      generation = 1;
    }
    heap[0].clear();
    heap[1].clear();
  }

  ExactGeodesicSolver solver_s, solver_t;
  std::uint32_t generation = 0;
  std::vector<std::uint32_t> stamp;
  std::vector<double> label[2];
  std::vector<std::int32_t> parent[2];        ///< previous sample, or detail::kFromQueryPoint
  std::vector<std::uint32_t> parent_edge[2];  ///< graph edge it came through
  std::vector<std::uint32_t> settled_stamp[2];
  std::vector<double> potential;  ///< goal direction: p(i), kNoPotential until computed
  std::vector<std::uint32_t> origin;  ///< fields: which source's links the label comes from
  std::vector<double> dense_label;    ///< fields: every sample's label, kInfinity if untouched
  std::vector<GeodesicSource> field_sources;  ///< fields: the sources of the disks' solve
  std::vector<char> field_linked;     ///< fields: a source has a sample within rho
  std::vector<detail::HeapEntry> heap[2];
  detail::QueryLinks links_s, links_t;
  std::vector<detail::QueryLinks> many;  ///< fields and matrices: one per point
  GeodesicTrace trace, trace_back;
  std::vector<PathPoint> piece;
  const QueryInterrupt* interrupt = nullptr;
  QueryScratch::RunBoth run_both;  ///< empty: one after the other
  Vec3 source_position, target_position;  ///< of the current point-to-point query
  /// The search's landmark distances of s and t (search_bidirectional), and which landmarks
  /// reach both.
  double landmark_s[tuning::kSearchLandmarks], landmark_t[tuning::kSearchLandmarks];
  std::uint32_t active_landmarks[tuning::kSearchLandmarks];
  std::uint32_t num_active_landmarks = 0;
  std::uint32_t pops = 0;  ///< graph-search pops, for polling the interrupt
  /// Linking through covers: slot of sample i in the links being assembled, valid when
  /// link_stamp[i] == link_generation.
  std::uint32_t link_generation = 0;
  std::vector<std::uint32_t> link_stamp;
  std::vector<std::uint32_t> link_slot;
  std::vector<double> link_distances;  ///< nearest_vertices_radius: settled vertices' distances
  /// Joining two near points' disks: one side's distance at vertex v, valid when
  /// join_stamp[v] == join_generation.
  std::uint32_t join_generation = 0;
  std::vector<std::uint32_t> join_stamp;
  std::vector<double> join_distance;
  detail::QueryLinks wide_s, wide_t;     ///< near pairs: wide links (see wide_links)
  std::vector<detail::QueryLinks> wide;  ///< matrices: wide links of each target of a near pair
  std::vector<char> has_wide;    ///< parallel to `wide`: computed for this matrix
  std::vector<std::uint32_t> join_edges;  ///< join_disks: the edges it searches
  /// join_disks: long edges one disk crossed (== join_generation), to find those both did.
  std::vector<std::uint32_t> join_edge_stamp;

  void poll() {
    if (interrupt && (++pops & 255) == 0) interrupt->check();
  }
};

}  // namespace geoprox
