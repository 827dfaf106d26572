// Tests of core/intrinsic_geometry: halfedge layouts against known triangles, and the per-halfedge
// crossing records the exact solver reads instead of the mesh's arrays (they must say exactly
// what the mesh says, on closed meshes, at boundaries and after a metric changes the lengths).
#include "core/intrinsic_geometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "core/mesh.h"
#include "test_meshes.h"
#include "test_support.h"

namespace geoprox {
namespace {

using test_meshes::GridOptions;
using test_meshes::TestMesh;

// Every field of every halfedge's record against the mesh and the layouts of the face.
void expect_records_match_mesh(const TriangleMesh& mesh, const IntrinsicGeometry& geometry) {
  for (std::uint32_t h = 0; h < mesh.num_halfedges(); ++h) {
    const HalfedgeCrossing& c = geometry.crossing(h);
    ASSERT_EQ(c.origin, mesh.origin(h)) << "halfedge " << h;
    ASSERT_EQ(c.target, mesh.target(h)) << "halfedge " << h;
    ASSERT_EQ(c.opposite, mesh.opposite_vertex(h)) << "halfedge " << h;
    ASSERT_EQ(c.twin_prev, mesh.twin(TriangleMesh::prev(h))) << "halfedge " << h;
    ASSERT_EQ(c.twin_next, mesh.twin(TriangleMesh::next(h))) << "halfedge " << h;
    ASSERT_EQ(&c.layout, &geometry.layout(h)) << "halfedge " << h;
    ASSERT_EQ(c.layout.length, geometry.edge_length(mesh.edge_of(h))) << "halfedge " << h;
  }
}

TEST(IntrinsicGeometry, LaysOutAThreeFourFiveTriangleInEachHalfedgeFrame) {
  // a = (0,0), b = (4,0), c = (0,3): |ab| = 4, |bc| = 5, |ca| = 3.
  const TriangleMesh mesh({{0, 0, 0}, {4, 0, 0}, {0, 3, 0}}, {Triangle{0, 1, 2}});
  const IntrinsicGeometry geometry(mesh);
  // h = a->b: c at (0, 3).
  EXPECT_DOUBLE_EQ(geometry.layout(0).length, 4);
  EXPECT_NEAR(geometry.layout(0).cx, 0, 1e-15);
  EXPECT_DOUBLE_EQ(geometry.layout(0).cy, 3);
  // h = b->c (length 5): a projects 16/5 along it, at height 12/5.
  EXPECT_DOUBLE_EQ(geometry.layout(1).length, 5);
  EXPECT_DOUBLE_EQ(geometry.layout(1).cx, 16.0 / 5);
  EXPECT_DOUBLE_EQ(geometry.layout(1).cy, 12.0 / 5);
  // h = c->a (length 3): b at (3, 4) in that frame.
  EXPECT_DOUBLE_EQ(geometry.layout(2).length, 3);
  EXPECT_DOUBLE_EQ(geometry.layout(2).cx, 3);
  EXPECT_DOUBLE_EQ(geometry.layout(2).cy, 4);
  EXPECT_NEAR(geometry.corner_angle(0), std::numbers::pi / 2, 1e-15);
  EXPECT_DOUBLE_EQ(geometry.face_area(0), 6);
}

TEST(IntrinsicGeometry, CrossingRecordsMatchTheMeshOnAClosedMesh) {
  const TestMesh& spot = test_support::spot();
  expect_records_match_mesh(*spot.mesh, *spot.geometry);
}

TEST(IntrinsicGeometry, CrossingRecordsMarkBoundaryEdgesWithoutATwin) {
  GridOptions options;
  options.nx = 5;
  options.ny = 4;
  const TestMesh grid = test_meshes::make_test_mesh(test_meshes::flat_grid(options));
  expect_records_match_mesh(*grid.mesh, *grid.geometry);
  // A 5 x 4 grid has 18 boundary edges; each is prev(h) of exactly one halfedge h.
  int open = 0;
  for (std::uint32_t h = 0; h < grid.mesh->num_halfedges(); ++h) {
    open += grid.geometry->crossing(h).twin_prev < 0;
  }
  EXPECT_EQ(open, 18);
  // Interior vertices of a flat grid are flat: no pseudo-sources there, only on the boundary.
  for (std::uint32_t v = 0; v < grid.mesh->num_vertices(); ++v) {
    EXPECT_EQ(grid.geometry->is_pseudo_source(v), grid.mesh->is_boundary_vertex(v)) << v;
    if (!grid.mesh->is_boundary_vertex(v)) {
      EXPECT_NEAR(grid.geometry->angle_sum(v), 2 * std::numbers::pi, 1e-12) << v;
    }
  }
}

TEST(IntrinsicGeometry, CrossingRecordsFollowExplicitEdgeLengths) {
  const TestMesh& spot = test_support::spot();
  std::vector<double> lengths = spot.geometry->edge_lengths();
  for (double& length : lengths) length *= 2;
  const IntrinsicGeometry doubled(*spot.mesh, lengths);
  expect_records_match_mesh(*spot.mesh, doubled);
  for (std::uint32_t h = 0; h < spot.mesh->num_halfedges(); h += 97) {
    EXPECT_DOUBLE_EQ(doubled.layout(h).cx, 2 * spot.geometry->layout(h).cx) << h;
    EXPECT_NEAR(doubled.layout(h).cy, 2 * spot.geometry->layout(h).cy,
                1e-12 * spot.geometry->layout(h).length)
        << h;
  }
}

TEST(IntrinsicGeometry, KnowsWhetherItsLengthsAreTheChords) {
  // Straight lines bound geodesics from below only under the embedding's own lengths: the
  // positions' chords, given as such or as explicit lengths, but not one edge changed.
  const TestMesh& spot = test_support::spot();
  EXPECT_TRUE(spot.geometry->lengths_are_chords());
  EXPECT_TRUE(IntrinsicGeometry(*spot.mesh, spot.geometry->edge_lengths()).lengths_are_chords());
  std::vector<double> lengths = spot.geometry->edge_lengths();
  lengths[lengths.size() / 2] *= 1 + 1e-9;
  EXPECT_FALSE(IntrinsicGeometry(*spot.mesh, lengths).lengths_are_chords());
}

}  // namespace
}  // namespace geoprox
