// Times VTP (Qin et al., "Fast and exact discrete geodesic computation based on
// triangle-oriented wavefront propagation", SIGGRAPH 2016) from its public source: see README.md.
//   vtp_driver MESH.obj SOURCE_VERTEX RUNS [DISTANCES_OUT]
#include <chrono>
#include <memory>

#include "stdafx.h"
#include "geodesic_algorithm_exact.h"
#include "geodesic_mesh.h"

#include "common.h"

int main(int argc, char** argv) {
  reference::Run run;
  if (const int status = reference::start(argc, argv, run)) return status;
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
