// Times VTP (Qin et al., "Fast and exact discrete geodesic computation based on
// triangle-oriented wavefront propagation", SIGGRAPH 2016) from its public source: see README.md.
//   vtp_driver MESH.obj SOURCE_VERTEX RUNS [DISTANCES_OUT]
//   vtp_driver MESH.obj --disks FILE      (bounded solves: needs the radius stop of README.md)
#include <chrono>
#include <memory>

#include "stdafx.h"
#include "geodesic_algorithm_exact.h"
#include "geodesic_mesh.h"

#include "common.h"

int main(int argc, char** argv) {
  reference::Run run;
  if (const int status = reference::start(argc, argv, run)) return status;
  if (!run.disks.empty()) {
#if defined(GEOPROX_VTP_STOP_RADIUS)
    std::vector<double> times, within;
    for (const reference::Disk& disk : run.disks) {
      geodesic::Mesh mesh;
      std::unique_ptr<geodesic::GeodesicAlgorithmExact> algorithm;
      {
        const reference::StdoutToStderr quiet;
        mesh.initialize_mesh_data(run.points, run.faces);
        algorithm = std::make_unique<geodesic::GeodesicAlgorithmExact>(&mesh);
      }
      geodesic::stop_radius = disk.radius;
      const auto start = std::chrono::steady_clock::now();
      algorithm->propagate(disk.source);
      times.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                                start).count());
      double count = 0;
      for (std::size_t v = 0; v < run.num_vertices(); ++v) {
        count += mesh.vertices()[v].geodesic_distance() <= disk.radius ? 1 : 0;
      }
      within.push_back(count);
    }
    reference::report_disks(times, within);
    return 0;
#else
    std::fprintf(stderr, "VTP has no radius stop: patch it and build with "
                         "-DGEOPROX_VTP_STOP_RADIUS (bench/reference/README.md)\n");
    return 1;
#endif
  }
  std::vector<double> times, distance(run.num_vertices());
  for (int r = 0; r < run.runs; ++r) {
    // VTP keeps its state in the mesh and never resets it: a fresh mesh and solver per run,
    // built outside the timer.
    geodesic::Mesh mesh;
    std::unique_ptr<geodesic::GeodesicAlgorithmExact> algorithm;
    {
      const reference::StdoutToStderr quiet;
      mesh.initialize_mesh_data(run.points, run.faces);
      algorithm = std::make_unique<geodesic::GeodesicAlgorithmExact>(&mesh);
    }
    const auto start = std::chrono::steady_clock::now();
    algorithm->propagate(run.source);
    times.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    for (std::size_t v = 0; v < distance.size(); ++v) {
      distance[v] = mesh.vertices()[v].geodesic_distance();
    }
  }
  reference::report(times, distance, geodesic::GEODESIC_INF / 2);
  if (run.distances_out) reference::write_distances(run.distances_out, distance);
  return 0;
}
