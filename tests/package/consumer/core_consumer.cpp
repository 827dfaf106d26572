// Uses the installed geoprox::core (COMPONENTS core): prints the exact geodesic distance
// v:0 -> f:100:0.2:0.3:0.5 on the mesh file given, with %.17g.
//   core_consumer MESH
#include <geoprox/core/geodesic/exact_geodesic.h>
#include <geoprox/core/mesh/intrinsic_geometry.h>
#include <geoprox/core/mesh/mesh_io.h>

#include <cstdio>
#include <exception>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: core_consumer MESH\n");
    return 2;
  }
  try {
    const geoprox::TriangleMesh mesh = geoprox::load_mesh(argv[1]);
    const geoprox::IntrinsicGeometry geometry(mesh);
    geoprox::ExactGeodesicSolver solver(mesh, geometry);
    solver.solve(geoprox::SurfacePoint::vertex(0));
    std::printf("%.17g\n", solver.distance(geoprox::SurfacePoint::face(100, 0.2, 0.3, 0.5)));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "core_consumer: %s\n", e.what());
    return 1;
  }
  return 0;
}
