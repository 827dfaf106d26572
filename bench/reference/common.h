// Shared by the reference-solver drivers (see README.md): an OBJ reader and the report.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>
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

/// One bounded solve: from a vertex out to a radius. `exact_geodesic_bench --disks-out DIR`
/// writes the disks of its bounded solves as `source_vertex radius` lines (DIR/MESH.disks).
struct Disk {
  unsigned source = 0;
  double radius = 0;
};

/// The drivers' command line and the mesh: `MESH.obj SOURCE_VERTEX RUNS [DISTANCES_OUT]` (full
/// solves) or `MESH.obj --disks FILE` (one bounded solve per disk of FILE).
struct Run {
  std::vector<double> points;  ///< x y z per vertex
  std::vector<unsigned> faces;  ///< three 0-based vertex ids per triangle
  unsigned source = 0;
  int runs = 0;
  const char* distances_out = nullptr;
  std::vector<Disk> disks;  ///< not empty: bounded solves instead of full ones
  std::size_t num_vertices() const { return points.size() / 3; }
};

/// The disks of a FILE; false (and why, on stderr) when it cannot be read, a line is not
/// `source_vertex radius` with a vertex of the mesh and a finite radius >= 0, or it is empty.
inline bool read_disks(const char* path, std::size_t num_vertices, std::vector<Disk>& disks) {
  std::ifstream in(path);
  if (!in) {
    std::fprintf(stderr, "cannot read %s\n", path);
    return false;
  }
  std::string line;
  for (std::size_t number = 1; std::getline(in, line); ++number) {
    std::istringstream fields(line);
    long source = -1;
    double radius = -1;
    std::string rest;
    if (!(fields >> source >> radius) || (fields >> rest) || source < 0 ||
        static_cast<std::size_t>(source) >= num_vertices || !std::isfinite(radius) || radius < 0) {
      std::fprintf(stderr, "%s:%zu: expected `source_vertex radius` (a vertex of the mesh, a "
                   "finite radius >= 0), got '%s'\n", path, number, line.c_str());
      return false;
    }
    disks.push_back({static_cast<unsigned>(source), radius});
  }
  if (disks.empty()) std::fprintf(stderr, "%s lists no disks\n", path);
  return !disks.empty();
}

/// Reads the command line and the mesh; on failure says why and returns the exit code (1 usage,
/// 2 unreadable mesh, 3 bad source or run count), else 0.
inline int start(int argc, char** argv, Run& run) {
  if (argc < 4) {
    std::fprintf(stderr,
                 "usage: %s MESH.obj SOURCE_VERTEX RUNS [DISTANCES_OUT]\n"
                 "       %s MESH.obj --disks FILE\n",
                 argv[0], argv[0]);
    return 1;
  }
  if (!read_obj(argv[1], run.points, run.faces)) {
    std::fprintf(stderr, "cannot read %s (triangles only)\n", argv[1]);
    return 2;
  }
  if (std::string(argv[2]) == "--disks") {
    return read_disks(argv[3], run.num_vertices(), run.disks) ? 0 : 3;
  }
  run.source = static_cast<unsigned>(std::atol(argv[2]));
  run.runs = std::atoi(argv[3]);
  run.distances_out = argc > 4 ? argv[4] : nullptr;
  if (run.source >= run.num_vertices() || run.runs < 1) {
    std::fprintf(stderr, "source vertex out of range or no runs\n");
    return 3;
  }
  return 0;
}

/// While alive, what the solvers print on stdout (their set-up chatter) goes to stderr, so that
/// stdout holds only the report.
class StdoutToStderr {
 public:
  StdoutToStderr() : saved_(dup(1)) {
    std::fflush(stdout);
    dup2(2, 1);
  }
  ~StdoutToStderr() {
    std::fflush(stdout);
    dup2(saved_, 1);
    close(saved_);
  }
  StdoutToStderr(const StdoutToStderr&) = delete;
  StdoutToStderr& operator=(const StdoutToStderr&) = delete;

 private:
  int saved_;
};

inline double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

/// Every run's time, on one line.
inline void print_runs(const std::vector<double>& times_ms) {
  std::printf("runs_ms");
  for (double t : times_ms) std::printf(" %.3f", t);
  std::printf("\n");
}

/// Prints the median and minimum time, the check distances and every run's time.
inline void report(const std::vector<double>& times_ms, const std::vector<double>& distance,
                   double unreachable_above) {
  std::printf("%.3f %.3f\n", median(times_ms), *std::min_element(times_ms.begin(), times_ms.end()));
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
  print_runs(times_ms);
}

/// Bounded solves: the median time, and the median count of vertices each found within its
/// radius (to compare with the bench's disks), then every solve's time.
inline void report_disks(const std::vector<double>& times_ms, const std::vector<double>& within) {
  std::printf("%.3f %.3f bounded solves: median, minimum ms; %zu disks, median %.0f vertices "
              "within the radius\n",
              median(times_ms), *std::min_element(times_ms.begin(), times_ms.end()),
              times_ms.size(), median(within));
  print_runs(times_ms);
}

inline void write_distances(const char* path, const std::vector<double>& distance) {
  if (FILE* out = std::fopen(path, "w")) {
    for (double d : distance) std::fprintf(out, "%.17g\n", d);
    std::fclose(out);
  }
}

}  // namespace reference
