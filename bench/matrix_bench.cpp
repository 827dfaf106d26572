// Benchmark of distance matrices (GeodesicQuery::matrix) in C++: the reference that
// bench/python_matrix.py compares geoprox.native's matrix() with. Not a test: it only measures.
//
//   matrix_bench MESH GRAPH POINTS [--rounds R] [--threads N]
//
// POINTS is a text file of face points, one "face b0 b1 b2" line each (numbers as written by
// Python's repr, read back exactly); the matrix is every point to every point. Each round times
// one matrix: on one thread, one GeodesicQuery::matrix call (the daemon's geodesic.matrix); with
// --threads N > 1, the rows split into N blocks on N OpenMP threads, each block one matrix call
// with its own scratch (what geoprox.native does). Scratches are made before the first round and
// reused. Prints each round's wall milliseconds, then the median and the checksum of the last
// matrix (sum of finite entries), so that two programs can be checked to compute the same.
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <span>
#include <string>
#include <vector>

#include "bench/bench_support.h"
#include "core/base/errors.h"
#include "core/graph/loaded_graph.h"
#include "core/query/geodesic_query.h"

namespace {

using namespace geoprox;
using namespace geoprox::bench;

std::vector<SurfacePoint> read_points(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::vector<SurfacePoint> points;
  std::string face, b0, b1, b2;
  while (in >> face >> b0 >> b1 >> b2) {
    points.push_back(SurfacePoint::face(static_cast<std::uint32_t>(std::stoul(face)),
                                        std::strtod(b0.c_str(), nullptr),
                                        std::strtod(b1.c_str(), nullptr),
                                        std::strtod(b2.c_str(), nullptr)));
  }
  if (points.empty()) throw std::runtime_error("no points in " + path);
  return points;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: matrix_bench MESH GRAPH POINTS [--rounds R] [--threads N]\n");
    return 1;
  }
  int rounds = 3, threads = 1;
  for (int i = 4; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--rounds") rounds = std::atoi(argv[i + 1]);
    else if (flag == "--threads") threads = std::atoi(argv[i + 1]);
    else {
      std::fprintf(stderr, "matrix_bench: unknown option %s\n", argv[i]);
      return 1;
    }
  }
  if (rounds < 1 || threads < 1) {
    std::fprintf(stderr, "matrix_bench: --rounds and --threads must be positive\n");
    return 1;
  }
  try {
    const LoadedGraph loaded(argv[1], argv[2]);
    const GeodesicQuery& query = *loaded.query;
    const std::vector<SurfacePoint> points = read_points(argv[3]);
    const std::size_t n = points.size();
    const std::span<const SurfacePoint> all(points);
    std::vector<QueryScratch> scratches;
    for (int t = 0; t < threads; ++t) scratches.push_back(query.make_scratch());
    std::vector<double> times, out(n * n);
    for (int round = 0; round < rounds; ++round) {
      const Clock::time_point start = Clock::now();
      if (threads == 1) {
        out = query.matrix(all, all, scratches[0]);
      } else {
#pragma omp parallel for num_threads(threads) schedule(static, 1)
        for (int b = 0; b < threads; ++b) {
          const std::size_t begin = n * static_cast<std::size_t>(b) / threads;
          const std::size_t end = n * static_cast<std::size_t>(b + 1) / threads;
          const std::vector<double> rows =
              query.matrix(all.subspan(begin, end - begin), all, scratches[b]);
          std::copy(rows.begin(), rows.end(), out.begin() + static_cast<long>(begin * n));
        }
      }
      times.push_back(ms_since(start));
      std::printf("round %d: %.1f ms\n", round + 1, times.back());
    }
    double checksum = 0;
    for (double d : out) checksum += std::isfinite(d) ? d : 0;
    std::printf("points %zu threads %d median_ms %.3f checksum %.17g\n", n, threads,
                median(times), checksum);
  } catch (const Error& e) {
    std::fprintf(stderr, "matrix_bench: %s: %s\n", e.reason().c_str(), e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "matrix_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
