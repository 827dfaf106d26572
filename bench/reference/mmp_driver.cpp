// Times MMP (Mitchell, Mount & Papadimitriou 1987, as implemented by Surazhsky et al. 2005 and
// Kirsanov's "geodesic" library) from its public source: see README.md.
//   mmp_driver MESH.obj SOURCE_VERTEX RUNS [DISTANCES_OUT]
//   mmp_driver MESH.obj --disks FILE      (bounded solves: its own max_propagation_distance stop)
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
  if (!run.disks.empty()) {
    std::vector<double> times, within;
    for (const reference::Disk& disk : run.disks) {
      std::vector<geodesic::SurfacePoint> sources{
          geodesic::SurfacePoint(&mesh.vertices()[disk.source])};
      const auto start = std::chrono::steady_clock::now();
      algorithm->propagate(sources, disk.radius);
      times.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                                start).count());
      double count = 0;
      for (std::size_t v = 0; v < run.num_vertices(); ++v) {
        geodesic::SurfacePoint p(&mesh.vertices()[v]);
        double d = geodesic::GEODESIC_INF;
        algorithm->best_source(p, d);
        count += d <= disk.radius ? 1 : 0;
      }
      within.push_back(count);
    }
    reference::report_disks(times, within);
    return 0;
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
