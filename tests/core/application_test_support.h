// Fixtures shared by the tests of issue 7 (riemannian_metric, exponential_map, geodesic_spline):
// the jittered flat grid they all use and a graph with its query over a test mesh. Header-only,
// like test_meshes.h (tests/CMakeLists.txt globs only *_test.cpp).
#pragma once

#include <cstdint>

#include "core/query/geodesic_query.h"
#include "core/graph/proximity_graph.h"
#include "tests/core/test_meshes.h"

namespace geoprox::test_meshes {

/// The unit square as a 24 x 24 grid, interior vertices jittered by up to 0.15 cell: vertex
/// (i, j) is 25 j + i.
inline const TestMesh& jittered_unit_grid() {
  static const TestMesh m = [] {
    GridOptions o;
    o.nx = o.ny = 24;
    o.hx = o.hy = 1.0 / 24;
    o.jitter = 0.15;
    return make_test_mesh(flat_grid(o));
  }();
  return m;
}

/// A proximity graph of a test mesh (0, 0: the paper's Table 1) and a query over it.
struct GraphEnv {
  GraphEnv(const TestMesh& m, std::uint32_t samples, std::uint32_t neighbors)
      : mesh(*m.mesh), geometry(*m.geometry), graph([&] {
          ProximityGraphOptions o;
          o.num_samples = samples;
          o.neighbors = neighbors;
          return build_proximity_graph(mesh, geometry, o);
        }()),
        query(mesh, geometry, graph.view()) {}
  const TriangleMesh& mesh;
  const IntrinsicGeometry& geometry;
  const ProximityGraph graph;
  const GeodesicQuery query;
};

}  // namespace geoprox::test_meshes
