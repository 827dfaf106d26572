// Benchmark of geodesic splines (issue 7, paper §6.2: "100 points on the spline curve" of the
// 40k-face Horse in ~0.6 s) and of the exponential map (§6.1). Not a test: it only measures.
//
//   spline_bench MESH GRAPH [--curves K] [--samples N] [--step F] [--radius F] [--seed X]
//                [--threads T]
//
// GRAPH is a graph file built for MESH (geoprox build). K curves (default 10), each from 4
// control points: a deterministic random vertex, then three more, each the vertex farthest from
// the first among those at geodesic distance step * (bounding-box diagonal) from the previous
// one (default step 0.1: control points close enough for the construction to be well defined).
// For every curve a cubic Bezier and a uniform cubic B-spline of N points (default 100) are
// computed with graph geodesics and with exact ones; one GeodesicSpline object per mode is
// reused, as the daemon does. Reports the median and the worst wall time and the median
// CPU time per curve. Then the exponential map from each curve's first control point with
// radius F * diagonal (default 0.2): graph and exact, median wall time. Splines use T threads
// over the curve points (default 1; the CPU time is the process's, all threads); the
// exponential map runs on one.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench/bench_support.h"
#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/apps/exponential_map.h"
#include "core/query/geodesic_query.h"
#include "core/apps/geodesic_spline.h"
#include "core/graph/graph_file.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/graph/loaded_graph.h"

namespace {

using namespace geoprox;
using namespace geoprox::bench;

struct Settings {
  int curves = 10;
  std::uint32_t samples = 100;
  double step = 0.1;
  double radius = 0.2;
  std::uint64_t seed = 7;
  int threads = 1;
};

double diagonal(const TriangleMesh& mesh) {
  Vec3 lo = mesh.position(0), hi = lo;
  for (const Vec3& p : mesh.positions()) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  return norm(hi - lo);
}

std::vector<SurfacePoint> control_points(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                                         Rng& rng, double step) {
  ExactGeodesicSolver from_start(mesh, geometry), from_previous(mesh, geometry);
  std::uint32_t start = rng.below(static_cast<std::uint32_t>(mesh.num_vertices()));
  while (mesh.is_isolated_vertex(start)) start = rng.below(static_cast<std::uint32_t>(mesh.num_vertices()));
  std::vector<SurfacePoint> points = {SurfacePoint::vertex(start)};
  ExactGeodesicOptions bounded;
  bounded.max_distance = 4 * step;
  from_start.solve(points[0], bounded);
  for (int k = 1; k < 4; ++k) {
    ExactGeodesicOptions near;
    near.max_distance = 1.5 * step;
    from_previous.solve(points.back(), near);
    std::int64_t best = -1;
    for (std::uint32_t v : from_previous.touched_vertices()) {
      if (std::abs(from_previous.distance(v) - step) > 0.2 * step) continue;
      const double d = from_start.distance(v);
      if (best < 0 || (d < kInfinity && d > from_start.distance(static_cast<std::uint32_t>(best)))) {
        best = v;
      }
    }
    if (best < 0) return {};
    points.push_back(SurfacePoint::vertex(static_cast<std::uint32_t>(best)));
  }
  return points;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: spline_bench MESH GRAPH [--curves K] [--samples N] [--step F] "
                 "[--radius F] [--seed X]\n");
    return 1;
  }
  Settings settings;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--curves") settings.curves = std::atoi(argv[i + 1]);
    else if (flag == "--samples") settings.samples = static_cast<std::uint32_t>(std::atoi(argv[i + 1]));
    else if (flag == "--step") settings.step = std::atof(argv[i + 1]);
    else if (flag == "--radius") settings.radius = std::atof(argv[i + 1]);
    else if (flag == "--threads") settings.threads = std::atoi(argv[i + 1]);
    else if (flag == "--seed") settings.seed = std::strtoull(argv[i + 1], nullptr, 10);
    else {
      std::fprintf(stderr, "spline_bench: unknown option %s\n", argv[i]);
      return 1;
    }
  }
  try {
    const LoadedGraph loaded(argv[1], argv[2]);
    const TriangleMesh& mesh = loaded.mesh;
    const IntrinsicGeometry& geometry = loaded.geometry;
    const GeodesicQuery& query = *loaded.query;
    const double diag = diagonal(mesh);
    std::printf("mesh %s: %zu faces, %zu vertices; graph %u samples, m_P %u, rho %.4g (%.3g diag)\n",
                base_name(argv[1]).c_str(), mesh.num_faces(), mesh.num_vertices(),
                loaded.file.view().num_samples, loaded.file.view().neighbors, query.link_radius(),
                query.link_radius() / diag);

    Rng rng{settings.seed};
    GeodesicSpline graph_spline(query);
    GeodesicSpline exact_spline(mesh, geometry);
    ExponentialMap map(query);
    std::vector<double> wall[2][2], cpu[2][2], expmap_ms[2];
    std::vector<std::uint32_t> geodesic_counts;
    std::size_t expmap_vertices = 0;
    int done = 0;
    for (int attempt = 0; done < settings.curves && attempt < 10 * settings.curves; ++attempt) {
      const std::vector<SurfacePoint> control = control_points(mesh, geometry, rng, settings.step * diag);
      if (control.empty()) continue;
      ++done;
      for (int type = 0; type < 2; ++type) {
        for (int mode = 0; mode < 2; ++mode) {
          GeodesicSplineOptions options;
          options.type = type == 0 ? SplineType::Bezier : SplineType::BSpline;
          options.samples = settings.samples;
          options.geodesics = mode == 0 ? SplineGeodesics::Graph : SplineGeodesics::Exact;
          options.threads = settings.threads;
          GeodesicSpline& spline = mode == 0 ? graph_spline : exact_spline;
          const auto start = Clock::now();
          const double cpu_start = process_cpu_ms();
          const GeodesicSplineResult r = spline.compute(control, options);
          wall[type][mode].push_back(ms_since(start));
          cpu[type][mode].push_back(process_cpu_ms() - cpu_start);
          if (mode == 0) geodesic_counts.push_back(r.geodesics);
        }
      }
      for (int mode = 0; mode < 2; ++mode) {
        ExponentialMapOptions options;
        options.radius = settings.radius * diag;
        options.mode = mode == 0 ? ExponentialMapMode::Graph : ExponentialMapMode::Exact;
        const auto start = Clock::now();
        const ExponentialMapResult r = map.compute(control[0], options);
        expmap_ms[mode].push_back(ms_since(start));
        if (mode == 0) expmap_vertices += r.vertices.size();
      }
    }
    std::printf("%d curves of %u points from 4 control points (step %.3g diag), %u geodesics each\n",
                done, settings.samples, settings.step,
                geodesic_counts.empty() ? 0u : geodesic_counts.front());
    const char* types[2] = {"bezier ", "bspline"};
    const char* modes[2] = {"graph", "exact"};
    for (int type = 0; type < 2; ++type) {
      for (int mode = 0; mode < 2; ++mode) {
        std::printf("  %s %s: median %8.2f ms, worst %8.2f ms wall; median %8.2f ms cpu\n",
                    types[type], modes[mode], median(wall[type][mode]),
                    percentile(wall[type][mode], 1.0), median(cpu[type][mode]));
      }
    }
    std::printf("exponential map, radius %.3g diag (%.0f vertices on average): graph median %.2f ms, "
                "exact median %.2f ms\n",
                settings.radius, done ? static_cast<double>(expmap_vertices) / done : 0.0,
                median(expmap_ms[0]), median(expmap_ms[1]));
  } catch (const Error& e) {
    std::fprintf(stderr, "spline_bench: %s [%s]\n", e.what(), e.reason().c_str());
    return 2;
  }
  return 0;
}
