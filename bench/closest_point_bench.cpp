// Benchmark of the closest-point index (core/mesh/closest_point.h). Not a test: it measures.
//
//   closest_point_bench MESH... [--queries N] [--runs R] [--leaf-size L] [--seed X]
//
// For each mesh, single thread: the build time (median of R builds) and node count, then N
// deterministic random queries of two kinds, each timed one by one (the clock's own cost, some
// tens of nanoseconds, is included) after one untimed warm-up pass over the same queries:
//  - near: a random point of a random face moved up to 1% of the bounding-box diagonal in a
//    random direction (a client snapping a point it believes is on the surface);
//  - box: uniform in the bounding box grown by 10% on every side (anywhere, mostly far off).
// Reported: the median and the 99th percentile of the single-query wall times in microseconds,
// and the mean over all queries from the total CPU time of the thread (which, unlike wall time,
// does not count time other processes held the core).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <exception>
#include <string>
#include <vector>

#include "bench/bench_support.h"
#include "core/mesh/closest_point.h"
#include "core/mesh/mesh.h"
#include "core/mesh/mesh_io.h"

namespace {

using namespace geoprox;
using namespace geoprox::bench;

double us_between(Clock::time_point start, Clock::time_point stop) {
  return std::chrono::duration<double, std::micro>(stop - start).count();
}

/// CPU time of this thread in microseconds.
double thread_cpu_us() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e6 * static_cast<double>(ts.tv_sec) + 1e-3 * static_cast<double>(ts.tv_nsec);
}

struct Settings {
  int queries = 100000;
  int runs = 5;
  std::uint32_t leaf_size = ClosestPointOptions{}.leaf_size;
  std::uint64_t seed = 2024;
};

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr,
               "closest_point_bench: %s\n"
               "usage: closest_point_bench MESH... [--queries N] [--runs R] [--leaf-size L] "
               "[--seed X]\n",
               why);
  std::exit(2);
}

long parse_positive(const char* flag, const char* text) {
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (*end != 0 || value <= 0) {
    std::fprintf(stderr, "closest_point_bench: %s needs a positive integer, got '%s'\n", flag,
                 text);
    std::exit(2);
  }
  return value;
}

Vec3 random_unit(Rng& rng) {
  for (;;) {
    const Vec3 v{rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)};
    const double n = norm(v);
    if (n > 0.1 && n <= 1) return (1.0 / n) * v;
  }
}

struct Timing {
  double median_us = 0, p99_us = 0, mean_cpu_us = 0;
  double checksum = 0;  ///< sum of distances: keeps the queries from being optimized away
};

Timing time_queries(const ClosestPointIndex& index, const std::vector<Vec3>& queries) {
  Timing t;
  for (const Vec3& q : queries) t.checksum += index.closest(q).distance;  // warm-up
  std::vector<double> single_us;
  single_us.reserve(queries.size());
  const double cpu_start = thread_cpu_us();
  for (const Vec3& q : queries) {
    const auto start = Clock::now();
    t.checksum += index.closest(q).distance;
    single_us.push_back(us_between(start, Clock::now()));
  }
  t.mean_cpu_us = (thread_cpu_us() - cpu_start) / static_cast<double>(queries.size());
  t.median_us = percentile(single_us, 0.5);
  t.p99_us = percentile(single_us, 0.99);
  return t;
}

void bench_mesh(const std::string& path, const Settings& s) {
  const TriangleMesh mesh = load_mesh(path);
  const ClosestPointOptions options{.leaf_size = s.leaf_size};
  std::vector<double> build_ms;
  std::size_t nodes = 0;
  for (int r = 0; r < s.runs; ++r) {
    const auto start = Clock::now();
    const ClosestPointIndex index(mesh, options);
    build_ms.push_back(1e-3 * us_between(start, Clock::now()));
    nodes = index.num_nodes();
  }
  const ClosestPointIndex index(mesh, options);

  Vec3 lo = mesh.position(0), hi = lo;
  for (const Vec3& p : mesh.positions()) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  const double diagonal = norm(hi - lo);
  const Vec3 margin = 0.1 * (hi - lo);
  Rng rng{s.seed};
  std::vector<Vec3> near, box;
  const auto num_faces = static_cast<std::uint32_t>(mesh.num_faces());
  for (int i = 0; i < s.queries; ++i) {
    double b0 = rng.uniform(), b1 = rng.uniform();
    if (b0 + b1 > 1) {
      b0 = 1 - b0;
      b1 = 1 - b1;
    }
    const Vec3 on = mesh.face_point(rng.below(num_faces), {b0, b1, 1 - b0 - b1});
    near.push_back(on + (0.01 * diagonal * rng.uniform()) * random_unit(rng));
    box.push_back({rng.uniform(lo.x - margin.x, hi.x + margin.x),
                   rng.uniform(lo.y - margin.y, hi.y + margin.y),
                   rng.uniform(lo.z - margin.z, hi.z + margin.z)});
  }
  const Timing near_time = time_queries(index, near);
  const Timing box_time = time_queries(index, box);
  std::printf("| %s | %zu | %u | %zu | %.1f | %.3f / %.3f / %.3f | %.3f / %.3f / %.3f |\n",
              base_name(path).c_str(), mesh.num_faces(), s.leaf_size, nodes,
              percentile(build_ms, 0.5), near_time.median_us, near_time.p99_us,
              near_time.mean_cpu_us, box_time.median_us, box_time.p99_us, box_time.mean_cpu_us);
  std::fprintf(stderr, "%s: checksum %.17g\n", base_name(path).c_str(),
               near_time.checksum + box_time.checksum);
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  std::vector<std::string> meshes;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> const char* {
      if (i + 1 >= argc) usage((a + " needs a value").c_str());
      return argv[++i];
    };
    if (a == "--queries") {
      s.queries = static_cast<int>(parse_positive("--queries", value()));
    } else if (a == "--runs") {
      s.runs = static_cast<int>(parse_positive("--runs", value()));
    } else if (a == "--leaf-size") {
      s.leaf_size = static_cast<std::uint32_t>(parse_positive("--leaf-size", value()));
    } else if (a == "--seed") {
      s.seed = static_cast<std::uint64_t>(parse_positive("--seed", value()));
    } else if (a == "-h" || a == "--help") {
      usage("benchmark of the closest-point index");
    } else if (!a.empty() && a[0] == '-') {
      usage(("unknown option " + a).c_str());
    } else {
      meshes.push_back(a);
    }
  }
  if (meshes.empty()) usage("no mesh given");
  std::printf("%d queries of each kind; build: median of %d; query times in us: median / p99 "
              "(single queries, wall) / mean (thread CPU)\n",
              s.queries, s.runs);
  std::printf("| mesh | faces | leaf size | nodes | build ms | near: median / p99 / mean | "
              "box: median / p99 / mean |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  int failures = 0;
  for (const std::string& path : meshes) {
    try {
      bench_mesh(path, s);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "closest_point_bench: %s: %s\n", path.c_str(), e.what());
      ++failures;
    }
  }
  return failures == 0 ? 0 : 1;
}
