// Benchmark of point-to-point queries by how far apart the points are (docs/queries.md, "The
// exact solves of a query"). Not a test: it only measures.
//
//   query_band_bench MESH GRAPH [--pairs N] [--seed X] [--exact-within X] [--exact-bands]
//
// GRAPH is a graph file built for MESH (geoprox build). For each band of geodesic distance (0 to
// rho/2, rho/2 to rho, rho to 2 rho, then 2 to 3 and 3 to 4 rho, the near pairs that are refined;
// rho the graph's link radius), N pairs (default 400): s a
// random face point (uniform over faces), t a random vertex whose exact distance from s lies in
// the band. Reports the median, p90 and p99 time of GeodesicQuery::distance and ::path on one
// thread, and how many answers were exact (--exact-within: GeodesicQueryOptions::exact_within,
// 0 for the graph's answers below 2 rho). With --exact-bands, then for the bands rho/2 to rho,
// rho to 2 rho, 4 to 5 rho and 10 to 12 rho (N / 4 pairs each): GeodesicQuery::exact_distance
// (bounded by the graph's answer and goal-directed, as the daemon's "exact": true) against a
// plain exact solve stopped once t is settled; median times and windows created.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "bench/bench_support.h"
#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/query/geodesic_query.h"
#include "core/graph/graph_file.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/graph/loaded_graph.h"

namespace {

using namespace geoprox;
using namespace geoprox::bench;

struct Settings {
  std::size_t pairs = 400;
  std::uint64_t seed = 5;
  bool exact_bands = false;
  double exact_within = GeodesicQueryOptions{}.exact_within;
};

/// Pairs whose exact distance lies in [lo, hi]: s a random face point, t a random vertex of the
/// band (found by a solve from s out to hi). Fewer when the mesh has no such vertices.
std::vector<std::pair<SurfacePoint, SurfacePoint>> band_pairs(const TriangleMesh& mesh,
                                                              ExactGeodesicSolver& solver, Rng& rng,
                                                              double lo, double hi,
                                                              std::size_t count) {
  std::vector<std::pair<SurfacePoint, SurfacePoint>> pairs;
  std::vector<std::uint32_t> band;
  for (std::size_t attempt = 0; pairs.size() < count && attempt < 20 * count; ++attempt) {
    double b0 = rng.uniform(), b1 = rng.uniform();
    if (b0 + b1 > 1) {
      b0 = 1 - b0;
      b1 = 1 - b1;
    }
    const auto face = rng.below(static_cast<std::uint32_t>(mesh.num_faces()));
    const SurfacePoint s = SurfacePoint::face(face, b0, b1, 1 - b0 - b1);
    ExactGeodesicOptions options;
    options.max_distance = hi;
    solver.solve(s, options);
    band.clear();
    for (std::uint32_t v : solver.touched_vertices()) {
      const double d = solver.distance(v);
      if (d >= lo && d <= hi) band.push_back(v);
    }
    if (band.empty()) continue;
    const std::uint32_t t = band[rng.below(static_cast<std::uint32_t>(band.size()))];
    pairs.emplace_back(s, SurfacePoint::vertex(t));
  }
  return pairs;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: query_band_bench MESH GRAPH [--pairs N] [--seed X] [--exact-within X] "
                 "[--exact-bands]\n");
    return 1;
  }
  Settings settings;
  for (int i = 3; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--exact-bands") {
      settings.exact_bands = true;
    } else if (flag == "--pairs" && i + 1 < argc) {
      settings.pairs = std::strtoull(argv[++i], nullptr, 10);
    } else if (flag == "--seed" && i + 1 < argc) {
      settings.seed = std::strtoull(argv[++i], nullptr, 10);
    } else if (flag == "--exact-within" && i + 1 < argc) {
      settings.exact_within = std::strtod(argv[++i], nullptr);
    } else {
      std::fprintf(stderr, "query_band_bench: unknown option %s\n", argv[i]);
      return 1;
    }
  }
  if (settings.pairs == 0) {
    std::fprintf(stderr, "query_band_bench: --pairs must be positive\n");
    return 1;
  }
  try {
    GeodesicQueryOptions query_options;
    query_options.exact_within = settings.exact_within;
    const LoadedGraph loaded(argv[1], argv[2], {}, query_options);
    const TriangleMesh& mesh = loaded.mesh;
    const IntrinsicGeometry& geometry = loaded.geometry;
    const GeodesicQuery& query = *loaded.query;
    QueryScratch scratch = query.make_scratch();
    const double rho = query.link_radius();
    std::printf("mesh %s: %zu faces; graph %u samples, m_P %u, rho %.6g\n",
                base_name(argv[1]).c_str(), mesh.num_faces(), loaded.file.view().num_samples,
                loaded.file.view().neighbors, rho);
    ExactGeodesicSolver reference(mesh, geometry), plain(mesh, geometry);
    Rng rng{settings.seed};

    for (const auto& [lo, hi] :
         {std::pair{0.0, 0.5}, std::pair{0.5, 1.0}, std::pair{1.0, 2.0}, std::pair{2.0, 3.0},
          std::pair{3.0, 4.0}}) {
      const auto pairs = band_pairs(mesh, reference, rng, lo * rho, hi * rho, settings.pairs);
      std::vector<double> distance_ms, path_ms;
      std::size_t exact = 0;
      // Two passes: a path right after the distance of the same pair would find it in cache.
      for (const auto& [s, t] : pairs) {
        const auto start = Clock::now();
        exact += query.distance(s, t, scratch).exact ? 1 : 0;
        distance_ms.push_back(ms_since(start));
      }
      for (const auto& [s, t] : pairs) {
        const auto start = Clock::now();
        (void)query.path(s, t, scratch);
        path_ms.push_back(ms_since(start));
      }
      std::printf("band %4.1f-%4.1f rho, %zu pairs (%zu exact): distance p50 %.3f p90 %.3f "
                  "p99 %.3f ms; path p50 %.3f p90 %.3f p99 %.3f ms\n",
                  lo, hi, pairs.size(), exact, median(distance_ms), percentile(distance_ms, 0.9),
                  percentile(distance_ms, 0.99), median(path_ms), percentile(path_ms, 0.9),
                  percentile(path_ms, 0.99));
    }

    if (!settings.exact_bands) return 0;
    const std::size_t exact_pairs = std::max<std::size_t>(settings.pairs / 4, 1);
    for (const auto& [lo, hi] : {std::pair{0.5, 1.0}, std::pair{1.0, 2.0}, std::pair{4.0, 5.0},
                                 std::pair{10.0, 12.0}}) {
      const auto pairs = band_pairs(mesh, reference, rng, lo * rho, hi * rho, exact_pairs);
      std::vector<double> plain_ms, plain_windows, directed_ms;
      for (const auto& [s, t] : pairs) {
        ExactGeodesicOptions options;
        options.stop_after_targets = 1;
            const GeodesicSource source{s, 0.0};
        auto start = Clock::now();
        plain.solve(std::span<const GeodesicSource>(&source, 1),
                    std::span<const SurfacePoint>(&t, 1), options);
        plain_ms.push_back(ms_since(start));
        plain_windows.push_back(static_cast<double>(plain.stats().windows_created));
        start = Clock::now();
        (void)query.exact_distance(s, t, scratch);
        directed_ms.push_back(ms_since(start));
      }
      std::printf("exact band %4.1f-%4.1f rho, %zu pairs: stopped at t %.3f ms (%.0f windows); "
                  "graph bound + goal-directed %.3f ms\n",
                  lo, hi, pairs.size(), median(plain_ms), median(plain_windows),
                  median(directed_ms));
    }
  } catch (const Error& e) {
    std::fprintf(stderr, "query_band_bench: %s\n", e.what());
    return 2;
  }
  return 0;
}
