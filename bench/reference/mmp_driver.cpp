// Times MMP (Mitchell, Mount & Papadimitriou 1987, as implemented by Surazhsky et al. 2005 and
// Kirsanov's "geodesic" library) from its public source: see README.md.
//   mmp_driver MESH.obj SOURCE_VERTEX RUNS [DISTANCES_OUT]
#include <chrono>
#include <cstdio>
#include <unistd.h>

#include "geodesic_algorithm_exact.h"

#include "common.h"

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s MESH.obj SOURCE_VERTEX RUNS [DISTANCES_OUT]\n", argv[0]);
    return 1;
  }
  std::vector<double> points;
  std::vector<unsigned> faces;
  if (!reference::read_obj(argv[1], points, faces)) {
    std::fprintf(stderr, "cannot read %s (triangles only)\n", argv[1]);
    return 2;
  }
  const auto source = static_cast<unsigned>(std::atol(argv[2]));
  const int runs = std::atoi(argv[3]);
  const std::size_t nv = points.size() / 3;
  if (source >= nv || runs < 1) return 3;
  // The solver resets itself at every propagate(): built once, outside the timer (its mesh
  // check prints to stdout, sent to stderr here).
  const int saved = dup(1);
  dup2(2, 1);
  geodesic::Mesh mesh;
  mesh.initialize_mesh_data(points, faces);
  geodesic::GeodesicAlgorithmExact algorithm(&mesh);
  std::fflush(stdout);
  dup2(saved, 1);
  close(saved);
  std::vector<geodesic::SurfacePoint> sources{geodesic::SurfacePoint(&mesh.vertices()[source])};
  std::vector<double> times, distance(nv);
  for (int r = 0; r < runs; ++r) {
    const auto start = std::chrono::steady_clock::now();
    algorithm.propagate(sources);
    times.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  }
  for (std::size_t v = 0; v < nv; ++v) {
    geodesic::SurfacePoint p(&mesh.vertices()[v]);
    algorithm.best_source(p, distance[v]);
  }
  reference::report(times, distance, geodesic::GEODESIC_INF / 2);
  if (argc > 4) reference::write_distances(argv[4], distance);
  return 0;
}
