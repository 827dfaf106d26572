// Times MMP (Mitchell, Mount & Papadimitriou 1987, as implemented by Surazhsky et al. 2005 and
// Kirsanov's "geodesic" library) from its public source: see README.md.
//   mmp_driver MESH.obj SOURCE_VERTEX RUNS [DISTANCES_OUT]
#include <chrono>
#include <memory>

#include "geodesic_algorithm_exact.h"

#include "common.h"

int main(int argc, char** argv) {
  reference::Run run;
  if (const int status = reference::start(argc, argv, run)) return status;
  // The solver resets itself at every propagate(): built once, outside the timer.
  geodesic::Mesh mesh;
  std::unique_ptr<geodesic::GeodesicAlgorithmExact> algorithm;
  {
    const reference::StdoutToStderr quiet;
    mesh.initialize_mesh_data(run.points, run.faces);
    algorithm = std::make_unique<geodesic::GeodesicAlgorithmExact>(&mesh);
  }
  std::vector<geodesic::SurfacePoint> sources{geodesic::SurfacePoint(&mesh.vertices()[run.source])};
  std::vector<double> times, distance(run.num_vertices());
  for (int r = 0; r < run.runs; ++r) {
    const auto start = std::chrono::steady_clock::now();
    algorithm->propagate(sources);
    times.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  }
  for (std::size_t v = 0; v < distance.size(); ++v) {
    geodesic::SurfacePoint p(&mesh.vertices()[v]);
    algorithm->best_source(p, distance[v]);
  }
  reference::report(times, distance, geodesic::GEODESIC_INF / 2);
  if (run.distances_out) reference::write_distances(run.distances_out, distance);
  return 0;
}
