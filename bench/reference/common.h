// Shared by the reference-solver drivers (see README.md): an OBJ reader and the report.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace reference {

/// Vertices (x y z per vertex) and triangles (0-based) of an OBJ file, in file order; false
/// when it cannot be read or a face is not a triangle.
inline bool read_obj(const char* path, std::vector<double>& points, std::vector<unsigned>& faces) {
  std::ifstream in(path);
  if (!in) return false;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream tokens(line);
    std::string kind;
    tokens >> kind;
    if (kind == "v") {
      double x, y, z;
      tokens >> x >> y >> z;
      points.insert(points.end(), {x, y, z});
    } else if (kind == "f") {
      std::string corner;
      std::vector<long> ids;
      while (tokens >> corner) ids.push_back(std::atol(corner.c_str()));  // "a/b/c" -> a
      if (ids.size() != 3) return false;
      for (long id : ids) faces.push_back(static_cast<unsigned>(id - 1));
    }
  }
  return true;
}

/// Prints the median and minimum time, the check distances and every run's time.
inline void report(const std::vector<double>& times_ms, const std::vector<double>& distance,
                   double unreachable_above) {
  std::vector<double> sorted = times_ms;
  std::sort(sorted.begin(), sorted.end());
  const std::size_t n = sorted.size();
  const double median = n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
  std::printf("%.3f %.3f\n", median, sorted.front());
  double farthest = 0;
  std::size_t farthest_vertex = 0, unreached = 0;
  for (std::size_t v = 0; v < distance.size(); ++v) {
    if (!(distance[v] < unreachable_above)) {
      ++unreached;
    } else if (distance[v] > farthest) {
      farthest = distance[v];
      farthest_vertex = v;
    }
  }
  auto at = [&](std::size_t v) { return v < distance.size() ? distance[v] : NAN; };
  std::printf("d[1] %.17g d[100] %.17g d[5000] %.17g farthest %.17g (vertex %zu) unreached %zu\n",
              at(1), at(100), at(5000), farthest, farthest_vertex, unreached);
  std::printf("runs_ms");
  for (double t : times_ms) std::printf(" %.3f", t);
  std::printf("\n");
}

inline void write_distances(const char* path, const std::vector<double>& distance) {
  if (FILE* out = std::fopen(path, "w")) {
    for (double d : distance) std::fprintf(out, "%.17g\n", d);
    std::fclose(out);
  }
}

}  // namespace reference
