#include "core/graph/proximity_graph.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <numbers>
#include <optional>
#include <queue>
#include <string>
#include <tuple>

#include "core/base/errors.h"
#include "core/base/tuning.h"
#include "core/base/union_find.h"
#include "core/geodesic/covering_radius.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/geodesic/fast_marching.h"
#include "core/graph/refined_surface.h"
#include "core/mesh/mesh_report.h"

namespace geoprox {

namespace {

struct TableRow {
  double faces;
  double samples;
  double neighbors;
};
// Table 1 of the paper: its settings (n_P, m_P) by face count.
constexpr TableRow kTable1[] = {{10'000, 1300, 22},  {20'000, 1500, 21},   {50'000, 2300, 18},
                                {100'000, 5000, 18}, {200'000, 10000, 18}, {300'000, 15000, 18}};

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Connected components of the mesh's faces, as a component id per vertex (isolated vertices
// get their own id).
std::vector<std::uint32_t> vertex_components(const TriangleMesh& mesh, std::size_t& count) {
  UnionFind uf(mesh.num_vertices());
  for (const Triangle& t : mesh.faces()) {
    uf.unite(t[0], t[1]);
    uf.unite(t[1], t[2]);
  }
  std::vector<std::uint32_t> id(mesh.num_vertices());
  std::vector<std::uint32_t> relabel(mesh.num_vertices(), UINT32_MAX);
  count = 0;
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    const std::uint32_t root = uf.find(v);
    if (relabel[root] == UINT32_MAX) relabel[root] = static_cast<std::uint32_t>(count++);
    id[v] = relabel[root];
  }
  return id;
}

struct LocalEdge {
  std::uint32_t from, to;
  double distance;
  GraphDirection direction;  // at `from`, towards `to`
};

// The direction at `vertex` as the graph stores it. A path leaving a vertex on the long side of
// a zero-area face is described in the face across it, which does not touch the vertex: such a
// direction is stored as unknown (a zero vector in one of the vertex's faces) and queries fall
// back to an exact solve there.
GraphDirection to_graph_direction(const TriangleMesh& mesh, std::uint32_t vertex,
                                  const FaceDirection& d) {
  const Triangle& t = mesh.face(d.face);
  if (t[0] == vertex || t[1] == vertex || t[2] == vertex) {
    return {d.face, static_cast<float>(d.x), static_cast<float>(d.y)};
  }
  return {mesh.outgoing_halfedges(vertex)[0] / 3, 0.0f, 0.0f};
}

// The nearest float not below d: cover distances stay upper bounds of the exact distance, so
// fields built from them are lengths of real paths (never below the truth).
float float_at_least(double d) {
  float f = static_cast<float>(d);
  if (static_cast<double>(f) < d) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

}  // namespace

std::pair<std::uint32_t, std::uint32_t> default_graph_size(std::size_t faces) {
  const auto f = static_cast<double>(faces);
  const std::size_t rows = std::size(kTable1);
  if (f <= kTable1[0].faces) {
    return {static_cast<std::uint32_t>(kTable1[0].samples),
            static_cast<std::uint32_t>(kTable1[0].neighbors)};
  }
  for (std::size_t i = 1; i < rows; ++i) {
    if (f <= kTable1[i].faces) {
      const double t = (f - kTable1[i - 1].faces) / (kTable1[i].faces - kTable1[i - 1].faces);
      const double n = kTable1[i - 1].samples + t * (kTable1[i].samples - kTable1[i - 1].samples);
      const double m =
          kTable1[i - 1].neighbors + t * (kTable1[i].neighbors - kTable1[i - 1].neighbors);
      return {static_cast<std::uint32_t>(std::lround(n)),
              static_cast<std::uint32_t>(std::lround(m))};
    }
  }
  return {static_cast<std::uint32_t>(kTable1[rows - 1].samples),
          static_cast<std::uint32_t>(kTable1[rows - 1].neighbors)};
}

GraphSizeForError graph_size_for_error(std::size_t faces, double target_mean_error) {
  if (!(target_mean_error > 0 && target_mean_error < 1)) {
    throw InvalidInput(ErrorCode::BadTargetError,
                       "target error must be a fraction in (0, 1), e.g. 0.005 for 0.5%, not " +
                           std::to_string(target_mean_error));
  }
  using namespace tuning;
  const double exact_m =
      std::pow(kErrorFitMeanScale / target_mean_error, 1.0 / kErrorFitMeanExponent);
  GraphSizeForError size;
  size.num_samples = default_graph_size(faces).first;
  size.neighbors = static_cast<std::uint32_t>(
      std::clamp(std::ceil(exact_m - kErrorFitRoundingSlack), double{kErrorFitMinNeighbors},
                 double{kErrorFitMaxNeighbors}));
  size.predicted_mean = kErrorFitMeanScale * std::pow(size.neighbors, -kErrorFitMeanExponent);
  size.predicted_p99 = kErrorFitP99Scale * std::pow(size.neighbors, -kErrorFitP99Exponent);
  return size;
}

double ProximityGraphView::error_bound() const {
  // R is the radius within which every pair of samples is linked: the link radius (every
  // sample's solve reaches it and links every sample it finds). The longest edge does not
  // qualify: samples in sparse spots link farther out than others do.
  const double denom = link_radius - 2 * covering_radius;
  return link_radius > 0 && denom > 0 ? 2 * covering_radius / denom
                                      : std::numeric_limits<double>::infinity();
}

std::string sparse_sampling_warning(const ProximityGraphView& graph,
                                    const ProximityGraphStats* stats) {
  // Theorem 4.2 bounds the error only when rho > 2r; otherwise nothing does.
  if (!(graph.link_radius > 0 && 2 * graph.covering_radius >= graph.link_radius)) return {};
  char text[640];
  if (graph.covering_radius <= graph.link_radius) {
    std::snprintf(text, sizeof text,
                  "some points are up to %.6g from every sample (%s), %.2f link radii: Theorem "
                  "4.2 bounds the graph's error only where the link radius %.6g exceeds twice "
                  "that, and answers through such gaps can be off by several percent. Build "
                  "without --no-refine if long faces leave them (the build then refines the mesh "
                  "internally; not under a metric), else with more samples (--samples) or a "
                  "larger link radius (--link-samples)",
                  graph.covering_radius,
                  stats ? stats->largest_empty_disk.to_string().c_str() : "the covering radius",
                  graph.covering_radius / graph.link_radius, graph.link_radius);
    return text;
  }
  if (stats && stats->faces_beyond_link > 0) {
    std::snprintf(text, sizeof text,
                  "%zu faces (%.3g%% of the area) hold points with no sample within the link "
                  "radius %.6g; the farthest, %s, is %.6g from every sample. ",
                  stats->faces_beyond_link, 100 * stats->area_fraction_beyond_link,
                  graph.link_radius, stats->largest_empty_disk.to_string().c_str(),
                  graph.covering_radius);
  } else {
    std::snprintf(text, sizeof text,
                  "some points are up to %.6g from every sample, beyond the link radius %.6g. ",
                  graph.covering_radius, graph.link_radius);
  }
  return std::string(text) +
         "Faces that long leave gaps between the samples (which are vertices), and answers "
         "through them can be far off: build without --no-refine (the build then refines the "
         "mesh internally; not under a metric), or serve a refined mesh "
         "(geoprox refine MESH -o OUT.obj; docs/meshes.md)";
}

ProximityGraphView ProximityGraph::view() const {
  ProximityGraphView v;
  v.num_vertices = num_vertices;
  v.num_samples = static_cast<std::uint32_t>(sample_vertex.size());
  v.neighbors = neighbors;
  v.longest_edge = longest_edge;
  v.covering_radius = covering_radius;
  v.link_radius = link_radius;
  v.sample_vertex = sample_vertex;
  v.edge_offsets = edge_offsets;
  v.edge_target = edge_target;
  v.edge_distance = edge_distance;
  v.edge_direction = edge_direction;
  v.cover_offsets = cover_offsets;
  v.cover_sample = cover_sample;
  v.cover_distance = cover_distance;
  return v;
}

namespace {

// Morton codes interleave 21 bits per axis into 63 bits.
constexpr std::uint64_t kMortonAxisMask = 0x1FFFFF;

// Spreads the low 21 bits of x to every third bit (bit i to bit 3i).
std::uint64_t spread_bits(std::uint64_t x) {
  x &= kMortonAxisMask;
  x = (x | x << 32) & 0x1F00000000FFFFull;
  x = (x | x << 16) & 0x1F0000FF0000FFull;
  x = (x | x << 8) & 0x100F00F00F00F00Full;
  x = (x | x << 4) & 0x10C30C30C30C30C3ull;
  x = (x | x << 2) & 0x1249249249249249ull;
  return x;
}

// The samples in the order of a Morton (Z-order) curve through their positions. Farthest-point
// order puts consecutive samples far apart; along the curve, consecutive local solves explore
// overlapping disks and find much of their mesh data still in cache.
std::vector<std::uint32_t> spatial_order(const TriangleMesh& mesh,
                                         const std::vector<std::uint32_t>& sample_vertex) {
  Vec3 lo{kInfinity, kInfinity, kInfinity}, hi{-kInfinity, -kInfinity, -kInfinity};
  for (std::uint32_t v : sample_vertex) {
    const Vec3& p = mesh.position(v);
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  const double scale = extent > 0 ? kMortonAxisMask / extent : 0;
  auto cell = [&](double t, double t0) { return static_cast<std::uint64_t>((t - t0) * scale); };
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(sample_vertex.size());
  for (std::uint32_t i = 0; i < sample_vertex.size(); ++i) {
    const Vec3& p = mesh.position(sample_vertex[i]);
    keyed[i] = {spread_bits(cell(p.x, lo.x)) | spread_bits(cell(p.y, lo.y)) << 1 |
                    spread_bits(cell(p.z, lo.z)) << 2,
                i};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<std::uint32_t> order(keyed.size());
  for (std::size_t k = 0; k < keyed.size(); ++k) order[k] = keyed[k].second;
  return order;
}

// Vertices where shortest paths can turn sharply, to be samples ahead of farthest-point
// sampling: a geodesic bends only at a boundary vertex whose angle exceeds pi or at a saddle
// (angle sum above 2 pi), by at most that excess. A graph path through a sample a distance d
// beside such a corner is longer by up to about 2 d sin(excess / 2): first order in the samples'
// spacing, where elsewhere graph paths are off by its square. Slits that repair cuts open and
// the corners of a CAD model's openings turn paths by up to pi. Largest excess first, at most
// `limit`, only vertices below `eligible`.
std::vector<std::uint32_t> corner_vertices(const TriangleMesh& mesh,
                                           const IntrinsicGeometry& geometry,
                                           std::uint32_t eligible, std::size_t limit) {
  std::vector<std::pair<double, std::uint32_t>> corners;
  for (std::uint32_t v = 0; v < eligible; ++v) {
    if (mesh.is_isolated_vertex(v)) continue;
    const double flat = mesh.is_boundary_vertex(v) ? std::numbers::pi : 2 * std::numbers::pi;
    const double excess = geometry.angle_sum(v) - flat;
    if (excess > tuning::kCornerSampleTurn) corners.emplace_back(excess, v);
  }
  // Ties towards the lower id: deterministic.
  std::sort(corners.begin(), corners.end(), [](const auto& a, const auto& b) {
    return a.first > b.first || (a.first == b.first && a.second < b.second);
  });
  if (corners.size() > limit) corners.resize(limit);
  std::vector<std::uint32_t> out;
  out.reserve(corners.size());
  for (const auto& [excess, v] : corners) out.push_back(v);
  return out;
}

// Farthest-point sampling (paper §2.1): each new sample is the vertex farthest from all
// previous ones; the distance field is only lowered where the new sample is closer, and the
// farthest vertex comes from a lazy max-heap, not a scan. Vertices of a component with no sample
// yet are infinitely far, so every component is seeded before any gets a second sample. Only
// vertices [0, eligible) may become samples (ProximityGraphOptions::candidate_vertices).
std::vector<std::uint32_t> farthest_point_samples(
    const TriangleMesh& mesh, const IntrinsicGeometry& geometry, std::uint32_t count,
    std::uint32_t eligible, SamplingMethod method, std::span<const std::uint32_t> seeds,
    double seed_radius, const BuildProgress& progress) {
  const std::uint32_t nv = static_cast<std::uint32_t>(mesh.num_vertices());
  std::vector<double> field(nv, kInfinity);
  std::vector<std::uint32_t> samples;
  samples.reserve(count);
  using Entry = std::pair<double, std::uint32_t>;
  // Ties broken towards the lower vertex id, so sampling is deterministic.
  auto lower_priority = [](const Entry& a, const Entry& b) {
    return a.first < b.first || (a.first == b.first && a.second > b.second);
  };
  std::priority_queue<Entry, std::vector<Entry>, decltype(lower_priority)> farthest(lower_priority);
  // Only vertices below `eligible` enter the heap; the field covers every vertex.
  for (std::uint32_t v = 0; v < eligible; ++v) {
    if (!mesh.is_isolated_vertex(v)) farthest.push({kInfinity, v});
  }
  // Only the solver of the chosen method is built: each holds per-vertex scratch.
  std::optional<FastMarchingSolver> fmm;
  std::optional<ExactGeodesicSolver> exact;
  if (method == SamplingMethod::Exact) {
    exact.emplace(mesh, geometry);
  } else {
    fmm.emplace(mesh, geometry);
  }
  std::vector<std::uint32_t> lowered;
  // The seeds first, in their order; then `count` farthest points.
  std::size_t next_seed = 0;
  const std::size_t total = seeds.size() + count;
  while (samples.size() < total && (next_seed < seeds.size() || !farthest.empty())) {
    std::uint32_t v = 0;
    double d = kInfinity;
    if (next_seed < seeds.size()) {
      v = seeds[next_seed++];
      if (field[v] == 0) continue;  // a seed listed twice
      // Seeds are not the farthest points: their solves stop at seed_radius, beyond which the
      // farthest points that follow lower the field themselves.
      d = std::min(field[v], seed_radius);
    } else {
      std::tie(d, v) = farthest.top();
      farthest.pop();
      if (d != field[v] || d == 0) continue;  // stale entry, or already a sample
    }
    samples.push_back(v);
    field[v] = 0;
    lowered.clear();
    if (method == SamplingMethod::Exact) {
      // Only vertices closer than the current farthest distance can be lowered.
      ExactGeodesicOptions options;
      options.max_distance = std::isfinite(d) ? d : kInfinity;
      exact->solve(SurfacePoint::vertex(v), options);
      for (std::uint32_t u : exact->touched_vertices()) {
        const double du = exact->distance(u);
        if (du < field[u]) {
          field[u] = du;
          lowered.push_back(u);
        }
      }
    } else {
      fmm->lower(field, SurfacePoint::vertex(v));
      const auto& by_fmm = fmm->lowered_vertices();
      lowered.assign(by_fmm.begin(), by_fmm.end());
    }
    for (std::uint32_t u : lowered) {
      if (field[u] > 0 && u < eligible) farthest.push({field[u], u});
    }
    if (progress &&
        (samples.size() % tuning::kGraphProgressEvery == 0 || samples.size() == total)) {
      progress("sampling", static_cast<double>(samples.size()) / total);
    }
  }
  // Restricted candidates may leave a component without a sample.
  if (eligible < nv) {
    for (std::uint32_t v = 0; v < nv; ++v) {
      if (!mesh.is_isolated_vertex(v) && !std::isfinite(field[v])) {
        throw InvalidInput(ErrorCode::BadGraphSize,
                           "vertex " + std::to_string(v) +
                               " is in a component with no candidate vertex "
                               "(ids below " +
                               std::to_string(eligible) + "): no sample can reach it");
      }
    }
  }
  return samples;
}

}  // namespace

double link_radius_for(double area, std::uint32_t num_samples, std::uint32_t neighbors,
                       std::uint32_t link_samples) {
  const double samples_per_disk = link_samples ? link_samples : 2.0 * neighbors;
  return std::sqrt(samples_per_disk * area / (std::numbers::pi * num_samples));
}

GraphSize resolve_graph_size(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                             const ProximityGraphOptions& options) {
  auto [default_samples, default_neighbors] = default_graph_size(mesh.num_faces());
  // Vertices [0, eligible) may become samples; those in faces are usable.
  const auto nv = static_cast<std::uint32_t>(mesh.num_vertices());
  GraphSize size;
  size.eligible = options.candidate_vertices > 0 ? std::min(options.candidate_vertices, nv) : nv;
  std::size_t usable_vertices = 0;
  for (std::uint32_t v = 0; v < size.eligible; ++v) {
    usable_vertices += mesh.is_isolated_vertex(v) ? 0 : 1;
  }
  std::uint32_t num_samples = options.num_samples ? options.num_samples : default_samples;
  const std::uint32_t neighbors = options.neighbors ? options.neighbors : default_neighbors;
  if (options.num_samples > usable_vertices) {
    throw InvalidInput(ErrorCode::TooManySamples,
                       "asked for " + std::to_string(options.num_samples) +
                           " samples but the mesh has only " + std::to_string(usable_vertices) +
                           (options.candidate_vertices > 0 ? " candidate vertices in faces"
                                                           : " vertices in faces"));
  }
  num_samples = static_cast<std::uint32_t>(std::min<std::size_t>(num_samples, usable_vertices));
  if (neighbors == 0 || num_samples == 0) {
    throw InvalidInput(ErrorCode::BadGraphSize, "samples and neighbours must be positive");
  }

  size.num_samples = num_samples;
  size.neighbors = neighbors;
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) size.area += geometry.face_area(f);
  size.link_radius = link_radius_for(size.area, num_samples, neighbors, options.link_samples);
  return size;
}

namespace {

// ---------------------------------------------------------------------------------------------
// The phases of build_proximity_graph, in order.

// Automatic sampling: exact distances on meshes of poorly shaped triangles, where fast marching
// cannot be trusted; the mesh report measures their quality.
SamplingMethod choose_sampling(const MeshReport& report, SamplingMethod asked) {
  if (asked != SamplingMethod::Automatic) return asked;
  const double obtuse =
      static_cast<double>(report.obtuse_faces) / static_cast<double>(report.faces);
  return report.lo_quality_mean < tuning::kPoorMeshLoQuality ||
                 obtuse > tuning::kPoorMeshObtuseFraction
             ? SamplingMethod::Exact
             : SamplingMethod::FastMarching;
}

// The samples as the local solves see them, shared read-only by the threads.
struct SampleSet {
  SampleSet(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
            const std::vector<std::uint32_t>& sample_vertex)
      : vertex(sample_vertex),
        points(as_points(sample_vertex)),
        prepared(geometry, points),
        sample_of_vertex(mesh.num_vertices(), -1) {
    for (std::uint32_t i = 0; i < size(); ++i) {
      sample_of_vertex[vertex[i]] = static_cast<std::int32_t>(i);
    }
  }
  std::uint32_t size() const { return static_cast<std::uint32_t>(vertex.size()); }

  const std::vector<std::uint32_t>& vertex;    ///< [sample] its vertex
  std::vector<SurfacePoint> points;            ///< [sample] as a surface point
  GeodesicTargets prepared;                    ///< the points, as solver targets
  std::vector<std::int32_t> sample_of_vertex;  ///< [vertex] its sample, or -1

 private:
  static std::vector<SurfacePoint> as_points(const std::vector<std::uint32_t>& vertices) {
    std::vector<SurfacePoint> points(vertices.size());
    for (std::size_t i = 0; i < vertices.size(); ++i) points[i] = SurfacePoint::vertex(vertices[i]);
    return points;
  }
};

// What the local solve from one sample found: its edges (both directions of each) and the
// exact distance to every vertex of its disk, rounded up to float later in the cover table.
struct LocalSolveResult {
  std::vector<LocalEdge> edges;
  std::vector<std::pair<std::uint32_t, double>> covers;  // (vertex, distance)
};

// The edges i -> j and j -> i of a geodesic found from sample i, with their end directions.
void add_edge_pair(const TriangleMesh& mesh, const SampleSet& samples, std::uint32_t i,
                   std::uint32_t j, double distance, const GeodesicPath& path,
                   std::vector<LocalEdge>& edges) {
  edges.push_back(
      {i, j, distance, to_graph_direction(mesh, samples.vertex[i], path.direction_at_source)});
  edges.push_back(
      {j, i, distance, to_graph_direction(mesh, samples.vertex[j], path.direction_at_target)});
}

// One thread's local solves (paper §2.2). A plain solve to the link radius finds the samples
// within it from the vertices it reaches; only where fewer than m_P lie within it does a second
// solve run to the m_P nearest (its targets prepared once: registering all n_P samples at every
// solve would cost O(n_P^2)).
class LocalSolver {
 public:
  LocalSolver(const TriangleMesh& mesh, const IntrinsicGeometry& geometry, const SampleSet& samples,
              double link_radius, std::uint32_t neighbors)
      : mesh_(mesh), samples_(samples), solver_(mesh, geometry) {
    to_radius_.max_distance = link_radius;
    to_neighbors_.stop_after_targets = std::min<std::size_t>(neighbors + 1, samples.size());
    to_neighbors_.min_distance = link_radius;
  }

  void solve_from(std::uint32_t i, LocalSolveResult& result) {
    const SurfacePoint& from = samples_.points[i];
    solver_.solve(from, to_radius_);
    found_.clear();
    for (std::uint32_t v : solver_.touched_vertices()) {
      const std::int32_t j = samples_.sample_of_vertex[v];
      const double d = solver_.distance(v);  // finite only within the radius
      if (j >= 0 && static_cast<std::uint32_t>(j) != i && d < kInfinity) {
        found_.emplace_back(d, static_cast<std::uint32_t>(j));
      }
    }
    if (found_.size() + 1 < to_neighbors_.stop_after_targets) {
      // A sparse spot (or a small component): on to the m_P nearest samples.
      const GeodesicSource source{from, 0.0};
      solver_.solve(std::span<const GeodesicSource>(&source, 1), samples_.prepared, to_neighbors_);
      found_.clear();
      for (std::size_t k = 0; k < solver_.settled_targets().size(); ++k) {
        const std::uint32_t j = solver_.settled_targets()[k];
        if (j != i) found_.emplace_back(solver_.settled_target_distances()[k], j);
      }
    }
    std::sort(found_.begin(), found_.end());
    // Every sample found is an edge: the m_P nearest and every one within the link radius. The
    // solve has reached them anyway, and longer, more numerous edges make graph paths
    // straighter, so graph distances more accurate.
    for (const auto& [d, j] : found_) {
      add_edge_pair(mesh_, samples_, i, j, d, solver_.path_to(samples_.points[j]), result.edges);
    }
    for (std::uint32_t v : solver_.touched_vertices()) {
      const double d = solver_.distance(v);
      if (d < kInfinity) result.covers.push_back({v, d});
    }
  }

 private:
  const TriangleMesh& mesh_;
  const SampleSet& samples_;
  ExactGeodesicSolver solver_;
  ExactGeodesicOptions to_radius_;
  ExactGeodesicOptions to_neighbors_;
  std::vector<std::pair<double, std::uint32_t>> found_;  // (distance, sample)
};

// Local exact solves from every sample until its m_P nearest samples are settled and the link
// radius is reached, so that the cover table lists, for every vertex, every sample within the
// link radius (what queries link a vertex to). Result i is sample i's, whatever the thread.
std::vector<LocalSolveResult> solve_locally(const TriangleMesh& mesh,
                                            const IntrinsicGeometry& geometry,
                                            const SampleSet& samples, double link_radius,
                                            std::uint32_t neighbors, int threads,
                                            const BuildProgress& progress) {
  const std::uint32_t n = samples.size();
  std::vector<LocalSolveResult> results(n);
  const std::vector<std::uint32_t> solve_order = spatial_order(mesh, samples.vertex);
  std::size_t done = 0;
  // No exception may leave an OpenMP region: the first one of any thread is rethrown once all
  // have stopped, and the others skip their remaining samples.
  std::exception_ptr failure;
  std::atomic<bool> failed = false;
#pragma omp parallel num_threads(threads)
  {
    LocalSolver solver(mesh, geometry, samples, link_radius, neighbors);
    // Each result goes to its sample's slot: the order changes nothing but the time (the graph
    // file is the same byte for byte).
#pragma omp for schedule(dynamic, tuning::kLocalSolveChunk)
    for (std::uint32_t rank = 0; rank < n; ++rank) {
      if (failed.load(std::memory_order_relaxed)) continue;
      try {
        const std::uint32_t i = solve_order[rank];
        solver.solve_from(i, results[i]);
        if (progress) {
#pragma omp critical(geoprox_graph_progress)
          {
            ++done;
            if (done % tuning::kGraphProgressEvery == 0 || done == n) {
              progress("local solves", static_cast<double>(done) / n);
            }
          }
        }
      } catch (...) {
#pragma omp critical(geoprox_graph_failure)
        if (!failure) failure = std::current_exception();
        failed.store(true, std::memory_order_relaxed);
      }
    }
  }
  if (failure) std::rethrow_exception(failure);
  return results;
}

// The first sample, in sample order, whose piece of the graph differs from that of its mesh
// component's first sample; -1 when each component's samples form one piece.
std::int32_t first_stray_sample(const std::vector<LocalSolveResult>& results,
                                const SampleSet& samples,
                                const std::vector<std::uint32_t>& component,
                                std::size_t component_count, UnionFind& pieces) {
  for (const LocalSolveResult& result : results) {
    for (const LocalEdge& e : result.edges) pieces.unite(e.from, e.to);
  }
  std::vector<std::uint32_t> component_root(component_count, UINT32_MAX);
  for (std::uint32_t i = 0; i < samples.size(); ++i) {
    std::uint32_t& root = component_root[component[samples.vertex[i]]];
    if (root == UINT32_MAX) root = pieces.find(i);
    if (pieces.find(i) != root) return static_cast<std::int32_t>(i);
  }
  return -1;
}

// The graph must be connected within each mesh component (the paper's R >= 2r argument
// guarantees it for dense enough samples; thin parts can still split it). Joins every stray
// piece to the nearest sample outside it, which is a genuine geodesic edge.
void connect_stray_pieces(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                          const SampleSet& samples, std::vector<LocalSolveResult>& results) {
  std::size_t component_count = 0;
  const std::vector<std::uint32_t> component = vertex_components(mesh, component_count);
  ExactGeodesicSolver solver(mesh, geometry);
  const std::uint32_t n = samples.size();
  while (true) {
    UnionFind pieces(n);
    const std::int32_t stray =
        first_stray_sample(results, samples, component, component_count, pieces);
    if (stray < 0) break;
    const auto i = static_cast<std::uint32_t>(stray);
    std::vector<SurfacePoint> others;
    std::vector<std::uint32_t> other_index;
    for (std::uint32_t j = 0; j < n; ++j) {
      if (pieces.find(j) != pieces.find(i) &&
          component[samples.vertex[j]] == component[samples.vertex[i]]) {
        others.push_back(samples.points[j]);
        other_index.push_back(j);
      }
    }
    ExactGeodesicOptions nearest;
    nearest.stop_after_targets = 1;
    const GeodesicSource source{samples.points[i], 0.0};
    solver.solve(std::span<const GeodesicSource>(&source, 1), others, nearest);
    GEOPROX_ASSERT(!solver.settled_targets().empty(), "component has no reachable sample");
    const std::uint32_t j = other_index[solver.settled_targets()[0]];
    const GeodesicPath path = solver.path_to(samples.points[j]);
    const double d = solver.settled_target_distances()[0];
    add_edge_pair(mesh, samples, i, j, d, path, results[i].edges);
  }
}

// Symmetric CSR: i ~ j if either listed the other; when both did, the solve of the smaller
// index wins so the result is independent of thread scheduling.
void fill_edges(const std::vector<LocalSolveResult>& results, ProximityGraph& graph) {
  const auto n = static_cast<std::uint32_t>(results.size());
  std::vector<LocalEdge> all;
  for (const LocalSolveResult& result : results) {
    for (const LocalEdge& e : result.edges) all.push_back(e);
  }
  std::stable_sort(all.begin(), all.end(), [](const LocalEdge& a, const LocalEdge& b) {
    return a.from != b.from ? a.from < b.from : a.to < b.to;
  });
  all.erase(std::unique(all.begin(), all.end(),
                        [](const LocalEdge& a, const LocalEdge& b) {
                          return a.from == b.from && a.to == b.to;
                        }),
            all.end());
  graph.edge_offsets.assign(n + 1, 0);
  for (const LocalEdge& e : all) ++graph.edge_offsets[e.from + 1];
  for (std::uint32_t i = 0; i < n; ++i) graph.edge_offsets[i + 1] += graph.edge_offsets[i];
  graph.edge_target.reserve(all.size());
  graph.edge_distance.reserve(all.size());
  graph.edge_direction.reserve(all.size());
  graph.longest_edge = 0;
  for (const LocalEdge& e : all) {
    graph.edge_target.push_back(e.to);
    graph.edge_distance.push_back(e.distance);
    graph.edge_direction.push_back(e.direction);
    graph.longest_edge = std::max(graph.longest_edge, e.distance);
  }
}

// Per-vertex cover table, rows sorted by sample for determinism.
void fill_cover_table(const std::vector<LocalSolveResult>& results, std::size_t num_vertices,
                      ProximityGraph& graph) {
  graph.cover_offsets.assign(num_vertices + 1, 0);
  for (const LocalSolveResult& result : results) {
    for (const auto& [v, d] : result.covers) ++graph.cover_offsets[v + 1];
  }
  for (std::size_t v = 0; v < num_vertices; ++v) {
    graph.cover_offsets[v + 1] += graph.cover_offsets[v];
  }
  graph.cover_sample.resize(graph.cover_offsets.back());
  graph.cover_distance.resize(graph.cover_offsets.back());
  std::vector<std::uint32_t> fill(graph.cover_offsets.begin(), graph.cover_offsets.end() - 1);
  for (std::uint32_t i = 0; i < results.size(); ++i) {  // increasing i: rows sorted by sample
    for (const auto& [v, d] : results[i].covers) {
      graph.cover_sample[fill[v]] = i;
      graph.cover_distance[fill[v]] = float_at_least(d);
      ++fill[v];
    }
  }
}

// Theorem 4.2's r: the farthest any point of the surface is from every sample. Faces longer
// than the samples' spacing hold points much farther out than any vertex.
void measure_covering_radius(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                             const SampleSet& samples, double area, ProximityGraph& graph) {
  ExactGeodesicSolver solver(mesh, geometry);
  CoveringRadiusOptions covering;
  covering.beyond = graph.link_radius;
  const CoveringRadius r = covering_radius(solver, samples.points, covering);
  graph.covering_radius = r.radius;
  graph.stats.vertex_covering_radius = r.vertex_radius;
  graph.stats.largest_empty_disk = r.farthest;
  graph.stats.faces_beyond_link = r.faces_beyond;
  graph.stats.area_fraction_beyond_link = area > 0 ? r.area_beyond / area : 0;
}

}  // namespace

namespace {

/// Whether Theorem 4.2 gives no bound (rho <= 2r) because of the faces' insides: the vertices
/// alone are close enough to the samples for it. (Where they are not, the samples are too few
/// for the surface, and refining the mesh adds nothing.)
bool faces_leave_gaps(const ProximityGraph& graph) {
  return 2 * graph.covering_radius >= graph.link_radius &&
         2 * graph.stats.vertex_covering_radius < graph.link_radius;
}

/// The paper's build on `mesh` as it is. With `stop_if_faces_leave_gaps`, returns before the
/// local solves (no edges, no cover table) when faces_leave_gaps: the samples and r are known
/// by then.
ProximityGraph build_on(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                        const ProximityGraphOptions& options, const BuildProgress& progress,
                        bool stop_if_faces_leave_gaps) {
  const auto start = std::chrono::steady_clock::now();
  const GraphSize size = resolve_graph_size(mesh, geometry, options);
  ProximityGraph graph;
  graph.num_vertices = static_cast<std::uint32_t>(mesh.num_vertices());
  graph.neighbors = size.neighbors;

  const MeshReport report = compute_mesh_report(mesh, geometry);
  graph.stats.components = report.components;
  graph.stats.sampling_used = choose_sampling(report, options.sampling);
  const std::vector<std::uint32_t> corners =
      options.corner_samples
          ? corner_vertices(
                mesh, geometry, size.eligible,
                static_cast<std::size_t>(tuning::kMaxCornerSampleFraction * size.num_samples))
          : std::vector<std::uint32_t>{};
  graph.sample_vertex =
      farthest_point_samples(mesh, geometry, size.num_samples, size.eligible,
                             graph.stats.sampling_used, corners, size.link_radius, progress);
  // Corners are samples beyond n_P (fewer where they coincide with nothing left to sample).
  graph.stats.corner_samples = std::min(corners.size(), graph.sample_vertex.size());
  graph.stats.sampling_seconds = seconds_since(start);

  const SampleSet samples(mesh, geometry, graph.sample_vertex);
  // For the farthest-point samples sampling found (fewer than asked where vertices coincide):
  // corner samples add to them where paths bend, not to the density elsewhere.
  const std::size_t spread = std::max<std::size_t>(samples.size() - graph.stats.corner_samples, 1);
  graph.link_radius = link_radius_for(size.area, static_cast<std::uint32_t>(spread), size.neighbors,
                                      options.link_samples);

  // r depends on the samples alone: measured before the local solves, which it may save.
  const auto covering_start = std::chrono::steady_clock::now();
  if (progress) progress("covering radius", 0);
  measure_covering_radius(mesh, geometry, samples, size.area, graph);
  if (progress) progress("covering radius", 1);
  graph.stats.covering_seconds = seconds_since(covering_start);
  if (stop_if_faces_leave_gaps && faces_leave_gaps(graph)) return graph;

  const auto solves_start = std::chrono::steady_clock::now();
  const int threads = options.threads > 0 ? options.threads : omp_get_max_threads();
  std::vector<LocalSolveResult> results =
      solve_locally(mesh, geometry, samples, graph.link_radius, size.neighbors, threads, progress);
  connect_stray_pieces(mesh, geometry, samples, results);
  fill_edges(results, graph);
  fill_cover_table(results, mesh.num_vertices(), graph);
  graph.stats.local_solve_seconds = seconds_since(solves_start);
  return graph;
}

}  // namespace

ProximityGraph build_proximity_graph(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                                     const ProximityGraphOptions& options,
                                     const BuildProgress& progress) {
  const auto start = std::chrono::steady_clock::now();
  const bool may_refine =
      options.refine_long_faces && geometry.lengths_are_chords() &&
      (options.candidate_vertices == 0 || options.candidate_vertices >= mesh.num_vertices());
  ProximityGraph first = build_on(mesh, geometry, options, progress, may_refine);
  if (!may_refine || !faces_leave_gaps(first)) return first;
  const double first_seconds = seconds_since(start);
  const auto refine_start = std::chrono::steady_clock::now();
  if (progress) progress("refining", 0);
  GraphRefinement refinement = refine_for_graph(mesh, options);
  if (refinement.refined.edges_split == 0) {  // no edge past the limit: the mesh as it is
    return build_on(mesh, geometry, options, progress, /*stop_if_faces_leave_gaps=*/false);
  }
  auto refined = std::make_shared<const RefinedSurface>(mesh, std::move(refinement.refined),
                                                        refinement.max_edge_length);
  const double refine_seconds = seconds_since(refine_start);
  if (progress) progress("refining", 1);
  ProximityGraph graph = build_on(refined->mesh(), refined->geometry(), options, progress,
                                  /*stop_if_faces_leave_gaps=*/false);
  graph.refined = std::move(refined);
  graph.stats.unrefined_covering_radius = first.covering_radius;
  graph.stats.unrefined_link_radius = first.link_radius;
  graph.stats.unrefined_faces_beyond_link = first.stats.faces_beyond_link;
  graph.stats.unrefined_area_fraction_beyond_link = first.stats.area_fraction_beyond_link;
  graph.stats.unrefined_build_seconds = first_seconds;
  graph.stats.refinement_seconds = refine_seconds;
  return graph;
}

}  // namespace geoprox
