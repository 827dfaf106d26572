// The geodesic proximity graph of "Lightweight preprocessing and fast query of geodesic distance
// via proximity graph" (§2, building the graph): n_P samples by farthest-point sampling, each
// linked to its m_P nearest samples by exact local geodesics.
//
// Samples are mesh vertices (farthest-point sampling picks the farthest vertex; the paper also
// allows points inside faces, which measured no more accurate at Table 1 densities:
// docs/accuracy.md, "Samples at vertices or inside faces"). For every graph
// edge i -> j the graph keeps the exact geodesic distance and the unit direction in which the
// geodesic leaves sample i towards j (in the frame of one of i's faces, see FaceDirection), so
// paths can be traced back from the stored end directions. The local solve from each sample
// also gives exact distances from that sample to every vertex of its disk; each vertex keeps the
// samples covering it and those distances (the per-vertex cover table of §3.2).
//
// ProximityGraphView is what queries read: plain spans, over vectors owned by a ProximityGraph
// or over a memory-mapped graph file (core/graph/graph_file.h), never copied.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

class RefinedSurface;

enum class SamplingMethod : std::uint8_t {
  Automatic = 0,    ///< fast marching unless the mesh's triangles are poorly shaped
  FastMarching = 1, ///< farthest-point sampling on fast-marching distances
  Exact = 2,        ///< farthest-point sampling on exact distances (slower, for poor meshes)
};

struct ProximityGraphOptions {
  /// n_P, number of samples; 0 (default) picks the paper's Table 1 value for the face count.
  std::uint32_t num_samples = 0;
  /// m_P, nearest samples each sample is linked to; 0 (default) picks the Table 1 value.
  std::uint32_t neighbors = 0;
  /// m_st, samples a query point is linked to on average; 0 (default) uses 2 * m_P (the
  /// paper's). It sets the link radius (see link_radius_for).
  std::uint32_t link_samples = 0;
  /// How samples are picked; Automatic (default) uses exact distances on meshes of poorly
  /// shaped triangles (tuning::kPoorMeshLoQuality, kPoorMeshObtuseFraction), else fast marching.
  SamplingMethod sampling = SamplingMethod::Automatic;
  /// Only vertices with an id below this may become samples; 0 (default): every vertex. For a
  /// mesh refined by subdivision that keeps its original vertices first
  /// (scripts/subdivide_mesh.py): samples where the original mesh had vertices. Every
  /// component needs a candidate.
  std::uint32_t candidate_vertices = 0;
  /// Make samples of the vertices where shortest paths turn sharply (boundary corners whose
  /// angle exceeds pi, saddles, by more than tuning::kCornerSampleTurn), ahead of and on top of
  /// the n_P farthest-point samples; the link radius stays that of the n_P. Default on: graph
  /// paths around a corner with no sample on it are off by a share of the samples' spacing.
  bool corner_samples = true;
  /// OpenMP threads for the local solves; 0 (default) uses OpenMP's default. The graph is
  /// identical for every thread count.
  int threads = 0;
  /// When the graph leaves points too far from every sample for Theorem 4.2's bound (rho <= 2r)
  /// inside faces while its vertices are close enough (2 x their farthest distance < rho), build
  /// again on a refinement of the mesh (core/graph/refined_surface.h) that stays behind the
  /// mesh's own ids; default on. Only under the mesh's own lengths and
  /// with every vertex a candidate (a metric or candidate_vertices keep the first build, with
  /// sparse_sampling_warning's warning).
  bool refine_long_faces = true;
};

/// rho, the link radius of n_P = `num_samples` samples over a surface of `area` (mesh units
/// squared): the radius of a geodesic disk that holds m_st = `link_samples` samples on average,
/// pi rho^2 = m_st * area / n_P. `link_samples` 0 uses 2 m_P (the paper's m_st).
double link_radius_for(double area, std::uint32_t num_samples, std::uint32_t neighbors,
                       std::uint32_t link_samples = 0);

/// Table 1 of the paper, interpolated linearly in the face count between its rows and clamped
/// at its ends: (n_P, m_P) for a mesh of `faces` faces.
std::pair<std::uint32_t, std::uint32_t> default_graph_size(std::size_t faces);

/// What build_proximity_graph takes for `options` on a mesh, before it samples: n_P and m_P (from
/// the options, else Table 1), n_P at most the candidate vertices in faces, and the link radius
/// for n_P samples (pi rho^2 = m_st * area / n_P). Throws InvalidInput as the build does
/// (TooManySamples, BadGraphSize).
struct GraphSize {
  std::uint32_t num_samples = 0;  ///< n_P
  std::uint32_t neighbors = 0;    ///< m_P
  std::uint32_t eligible = 0;     ///< vertices [0, eligible) may become samples
  double area = 0;                ///< of the surface (mesh units squared)
  double link_radius = 0;         ///< rho for num_samples samples (mesh units)
};
GraphSize resolve_graph_size(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                             const ProximityGraphOptions& options = {});

/// Graph size for an accuracy instead of counts (the paper's §4.4 relationship, measured for
/// this implementation: docs/accuracy.md). The mean relative error of graph distances depends on
/// m_P (with m_st = 2 m_P) and hardly on n_P once n_P follows Table 1; the prediction is a
/// power law in m_P fitted to measured errors (tuning::kErrorFit*).
struct GraphSizeForError {
  std::uint32_t num_samples = 0;  ///< n_P: Table 1 for the face count
  std::uint32_t neighbors = 0;    ///< m_P: smallest whose predicted mean error <= the target
  double predicted_mean = 0;      ///< relative error, e.g. 0.005 for 0.5%
  double predicted_p99 = 0;
};
/// Throws InvalidInput ("BadTargetError") unless 0 < target_mean_error < 1. m_P is clamped to
/// [tuning::kErrorFitMinNeighbors, kErrorFitMaxNeighbors]; the prediction then says what that
/// gives.
GraphSizeForError graph_size_for_error(std::size_t faces, double target_mean_error);

/// A direction stored by the graph: unit vector (x, y) in the frame of face `face`, a face of
/// the sample it leaves. (0, 0) means unknown (a sample on the long side of a zero-area face):
/// a query then falls back to an exact solve.
struct GraphDirection {
  std::uint32_t face = 0;
  float x = 1, y = 0;
};

struct ProximityGraphView {
  std::uint32_t num_vertices = 0;
  std::uint32_t num_samples = 0;
  std::uint32_t neighbors = 0;        ///< m_P it was built with
  double longest_edge = 0;            ///< R: longest graph edge (mesh units)
  /// r: radius of the largest geodesic disk with no sample inside, over every point of the
  /// surface, faces' insides included (mesh units; an upper bound within 1e-3 of it, see
  /// core/geodesic/covering_radius.h). Older graph files hold the largest distance from a
  /// vertex instead, which faces longer than the samples' spacing leave far below r.
  double covering_radius = 0;
  /// rho: queries link a point to every sample within this geodesic distance and answer exactly
  /// below it. Chosen so that a disk of radius rho holds m_st samples on average
  /// (pi rho^2 = m_st * area / n_P); every sample's local solve reaches at least rho, so the
  /// cover row of a vertex lists every sample within rho of it (see link_radius_for).
  /// 0: unknown (imported graphs).
  double link_radius = 0;

  std::span<const std::uint32_t> sample_vertex;        ///< [num_samples] vertex of sample i
  std::span<const std::uint32_t> edge_offsets;         ///< [num_samples + 1] CSR rows
  std::span<const std::uint32_t> edge_target;          ///< [edges] sample j of edge i -> j
  std::span<const double> edge_distance;               ///< [edges] exact geodesic |ij|
  std::span<const GraphDirection> edge_direction;      ///< [edges] direction at i towards j
  std::span<const std::uint32_t> cover_offsets;        ///< [num_vertices + 1] CSR rows
  std::span<const std::uint32_t> cover_sample;         ///< [covers] sample covering the vertex
  /// [covers] exact distance to it, rounded up to the next float (an upper bound).
  std::span<const float> cover_distance;

  std::size_t num_edges() const { return edge_target.size(); }
  /// Theorem 4.2's bound on the relative error of graph distances: 2r / (R - 2r) with R the
  /// radius within which every pair of samples is linked, the link radius (infinite when
  /// R <= 2r, or when the link radius is unknown).
  double error_bound() const;
};

struct ProximityGraphStats {
  double sampling_seconds = 0;
  double local_solve_seconds = 0;
  double covering_seconds = 0;  ///< measuring r (core/geodesic/covering_radius.h)
  SamplingMethod sampling_used = SamplingMethod::FastMarching;
  std::size_t components = 0;
  /// Samples placed at corners where shortest paths turn sharply, ahead of and on top of the
  /// n_P farthest-point samples (tuning::kCornerSampleTurn).
  std::size_t corner_samples = 0;
  /// The largest distance from a vertex to its nearest sample; r counts the faces' insides too.
  double vertex_covering_radius = 0;
  /// Centre of the largest empty disk: the point found farthest from every sample, r away.
  SurfacePoint largest_empty_disk;
  /// Faces holding a point with no sample within the link radius, and the fraction of the
  /// surface's area they make up: regions of faces longer than the samples' spacing, with no
  /// vertex (so no sample) inside, which graph paths cross badly (docs/queries.md).
  std::size_t faces_beyond_link = 0;
  double area_fraction_beyond_link = 0;
  /// When the build refined the mesh (ProximityGraph::refined): the first pass's r and rho (its
  /// sampling and r, on the mesh as given: the local solves were skipped), what it left beyond
  /// the link radius, and the seconds of that pass and of the refinement (the phases above are
  /// the refined build's).
  double unrefined_covering_radius = 0;
  double unrefined_link_radius = 0;
  std::size_t unrefined_faces_beyond_link = 0;
  double unrefined_area_fraction_beyond_link = 0;
  double unrefined_build_seconds = 0;
  double refinement_seconds = 0;
};

/// Progress of a build: phase name ("sampling", "local solves", "covering radius"), fraction
/// done in [0, 1].
using BuildProgress = std::function<void(const std::string& phase, double fraction)>;

class ProximityGraph {
 public:
  ProximityGraphView view() const;

  std::uint32_t num_vertices = 0;
  std::uint32_t neighbors = 0;
  double longest_edge = 0;
  double covering_radius = 0;
  double link_radius = 0;
  std::vector<std::uint32_t> sample_vertex;
  std::vector<std::uint32_t> edge_offsets;
  std::vector<std::uint32_t> edge_target;
  std::vector<double> edge_distance;
  std::vector<GraphDirection> edge_direction;
  std::vector<std::uint32_t> cover_offsets;
  std::vector<std::uint32_t> cover_sample;
  std::vector<float> cover_distance;
  ProximityGraphStats stats;
  /// Set when the build refined the mesh (ProximityGraphOptions::refine_long_faces): the arrays
  /// above are then over refined->mesh(), and `refined` maps its points to the mesh given to
  /// the build, which must outlive it. Null when the graph is over the mesh as given.
  std::shared_ptr<const RefinedSurface> refined;
};

/// Builds the graph (throws InvalidInput for impossible options, e.g. more samples than
/// vertices). See ProximityGraphOptions::refine_long_faces for when it is built on a
/// refinement of `mesh`.
ProximityGraph build_proximity_graph(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                                     const ProximityGraphOptions& options = {},
                                     const BuildProgress& progress = {});

/// What to tell whoever built or serves the graph when Theorem 4.2 bounds none of its answers,
/// empty otherwise. That is precisely when rho <= 2r (error_bound() infinite): some point of
/// the surface is r >= rho / 2 from every sample, so the proof's chain of samples within R of
/// each other need not exist, and answers through that gap can be far off. When r > rho the
/// paper's linking finds no sample there at all; with the build's stats (graph files do not keep
/// them) the warning then names the faces' count and share of the area, and either way the
/// farthest point. Graphs that record no link radius (imported) get none: their bound is
/// unknown, not refuted.
std::string sparse_sampling_warning(const ProximityGraphView& graph,
                                    const ProximityGraphStats* stats = nullptr);

}  // namespace geoprox
