// Benchmark of graph distance fields (GeodesicQuery::field, paper §3.2). Not a test: it only
// measures.
//
//   field_bench MESH GRAPH [--fields K] [--rounds R] [--seed X]
//
// K sources (default 20): vertices drawn uniformly (deterministic for the seed), each the source
// of one single-source field, and every third field from three of them. One query and one
// scratch are reused, as the daemon does; every field runs once per round (default 5) and each
// field's median over the rounds is taken; the report gives the median and the 90th percentile
// of those, wall and thread CPU time, on one thread. Run it on an otherwise idle machine, and
// compare two builds by running them alternately in the same session.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench/bench_support.h"
#include "core/base/errors.h"
#include "core/query/geodesic_query.h"
#include "core/graph/loaded_graph.h"

namespace {

using namespace geoprox;
using namespace geoprox::bench;

struct Settings {
  int fields = 20;
  int rounds = 5;
  std::uint64_t seed = 11;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: field_bench MESH GRAPH [--fields K] [--rounds R] [--seed X]\n");
    return 1;
  }
  Settings settings;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--fields") settings.fields = std::atoi(argv[i + 1]);
    else if (flag == "--rounds") settings.rounds = std::atoi(argv[i + 1]);
    else if (flag == "--seed") settings.seed = std::strtoull(argv[i + 1], nullptr, 10);
    else {
      std::fprintf(stderr, "field_bench: unknown option %s\n", argv[i]);
      return 1;
    }
  }
  if (settings.fields < 1 || settings.rounds < 1) {
    std::fprintf(stderr, "field_bench: --fields and --rounds must be positive\n");
    return 1;
  }
  try {
    const LoadedGraph loaded(argv[1], argv[2]);
    const TriangleMesh& mesh = loaded.mesh;
    const GeodesicQuery& query = *loaded.query;
    Rng rng{settings.seed};
    std::vector<std::vector<SurfacePoint>> fields;
    for (int k = 0; k < settings.fields; ++k) {
      auto vertex = [&] {
        const auto n = static_cast<std::uint32_t>(mesh.num_vertices());
        std::uint32_t v = rng.below(n);
        while (mesh.is_isolated_vertex(v)) v = rng.below(n);
        return SurfacePoint::vertex(v);
      };
      if (k % 3 == 2) fields.push_back({vertex(), vertex(), vertex()});
      else fields.push_back({vertex()});
    }
    QueryScratch scratch = query.make_scratch();
    query.field(fields[0], scratch);  // warm-up: first-touch of the scratch
    std::vector<std::vector<double>> wall(fields.size()), cpu(fields.size());
    for (int round = 0; round < settings.rounds; ++round) {
      for (std::size_t k = 0; k < fields.size(); ++k) {
        const double cpu_start = thread_cpu_ms();
        const auto start = Clock::now();
        const DistanceField f = query.field(fields[k], scratch);
        wall[k].push_back(ms_since(start));
        cpu[k].push_back(thread_cpu_ms() - cpu_start);
        if (f.distances.size() != mesh.num_vertices()) return 2;
      }
    }
    std::vector<double> wall_medians, cpu_medians;
    for (std::size_t k = 0; k < fields.size(); ++k) {
      wall_medians.push_back(median(wall[k]));
      cpu_medians.push_back(median(cpu[k]));
    }
    std::printf("mesh %s: %zu faces, %zu vertices; graph %u samples, rho %.4g\n",
                base_name(argv[1]).c_str(), mesh.num_faces(), mesh.num_vertices(),
                loaded.file.view().num_samples, query.link_radius());
    std::printf("%d fields (every third from 3 sources), %d rounds: median %.3f ms, p90 %.3f ms "
                "wall; median %.3f ms cpu\n",
                settings.fields, settings.rounds, median(wall_medians),
                percentile(wall_medians, 0.9), median(cpu_medians));
  } catch (const Error& e) {
    std::fprintf(stderr, "field_bench: %s [%s]\n", e.what(), e.reason().c_str());
    return 1;
  }
  return 0;
}
