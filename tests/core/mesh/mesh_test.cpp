// TriangleMesh construction: connectivity of good meshes and the refusals of bad ones.
#include "core/mesh/mesh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "core/base/errors.h"

namespace geoprox {
namespace {

// A unit square split along its diagonal 0-2: faces (0 1 2) and (0 2 3).
std::vector<Vec3> square_positions() { return {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}; }

// Regular octahedron, outward orientation.
TriangleMesh octahedron() {
  std::vector<Vec3> p = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  std::vector<Triangle> f = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                             {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  return TriangleMesh(std::move(p), std::move(f));
}

/// Runs `build`, expects a MeshError with `reason` whose message contains every `fragment`.
template <typename Build>
void expect_mesh_error(Build build, const std::string& reason,
                       const std::vector<std::string>& fragments) {
  try {
    build();
    FAIL() << "expected MeshError " << reason;
  } catch (const MeshError& e) {
    EXPECT_EQ(e.reason(), reason) << e.what();
    for (const std::string& fragment : fragments) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)
          << "message '" << e.what() << "' lacks '" << fragment << "'";
    }
  }
}

TEST(MeshConstruction, SquareHasFiveEdgesAndOneInteriorEdge) {
  const TriangleMesh mesh(square_positions(), {{0, 1, 2}, {0, 2, 3}});
  EXPECT_EQ(mesh.num_vertices(), 4u);
  EXPECT_EQ(mesh.num_faces(), 2u);
  EXPECT_EQ(mesh.num_halfedges(), 6u);
  EXPECT_EQ(mesh.num_edges(), 5u);
  // Halfedge 2 of face 0 runs 2->0, halfedge 3 (face 1, corner 0) runs 0->2: twins.
  EXPECT_EQ(mesh.origin(2), 2u);
  EXPECT_EQ(mesh.target(2), 0u);
  EXPECT_EQ(mesh.twin(2), 3);
  EXPECT_EQ(mesh.twin(3), 2);
  EXPECT_EQ(mesh.twin(0), kNoHalfedge);
  EXPECT_EQ(mesh.edge_of(2), mesh.edge_of(3));
  // Edges are numbered in order of first appearance: 0->1, 1->2, 2->0, then 2->3, 3->0.
  EXPECT_EQ(mesh.edge_of(0), 0u);
  EXPECT_EQ(mesh.edge_of(1), 1u);
  EXPECT_EQ(mesh.edge_of(2), 2u);
  EXPECT_EQ(mesh.edge_of(4), 3u);
  EXPECT_EQ(mesh.edge_of(5), 4u);
  EXPECT_EQ(mesh.edge_origin(2), 2u);
  EXPECT_EQ(mesh.edge_target(2), 0u);
  EXPECT_FALSE(mesh.is_boundary_edge(2));
  EXPECT_TRUE(mesh.is_boundary_edge(0));
  for (std::uint32_t v = 0; v < 4; ++v) EXPECT_TRUE(mesh.is_boundary_vertex(v));
  EXPECT_EQ(mesh.outgoing_halfedges(0).size(), 2u);
  EXPECT_EQ(mesh.outgoing_halfedges(1).size(), 1u);
}

TEST(MeshConstruction, HalfedgeArithmetic) {
  EXPECT_EQ(TriangleMesh::face_of(7), 2u);
  EXPECT_EQ(TriangleMesh::next(6), 7u);
  EXPECT_EQ(TriangleMesh::next(8), 6u);
  EXPECT_EQ(TriangleMesh::prev(6), 8u);
  const TriangleMesh mesh(square_positions(), {{0, 1, 2}, {0, 2, 3}});
  EXPECT_EQ(mesh.opposite_vertex(0), 2u);
  EXPECT_EQ(mesh.opposite_vertex(3), 3u);
}

TEST(MeshConstruction, ClosedOctahedronHasNoBoundary) {
  const TriangleMesh mesh = octahedron();
  EXPECT_EQ(mesh.num_edges(), 12u);
  for (std::uint32_t h = 0; h < mesh.num_halfedges(); ++h) {
    ASSERT_GE(mesh.twin(h), 0) << "halfedge " << h;
    EXPECT_EQ(mesh.twin(static_cast<std::uint32_t>(mesh.twin(h))), static_cast<std::int32_t>(h));
  }
  for (std::uint32_t v = 0; v < 6; ++v) {
    EXPECT_FALSE(mesh.is_boundary_vertex(v));
    EXPECT_EQ(mesh.outgoing_halfedges(v).size(), 4u);
  }
}

TEST(MeshConstruction, IsolatedVertexIsKept) {
  std::vector<Vec3> p = square_positions();
  p.push_back({5, 5, 5});
  const TriangleMesh mesh(std::move(p), {{0, 1, 2}, {0, 2, 3}});
  EXPECT_EQ(mesh.num_vertices(), 5u);
  EXPECT_TRUE(mesh.is_isolated_vertex(4));
  EXPECT_FALSE(mesh.is_isolated_vertex(0));
  EXPECT_EQ(mesh.position(4).z, 5.0);
}

TEST(MeshConstruction, FacePointInterpolatesCorners) {
  const TriangleMesh mesh(square_positions(), {{0, 1, 2}, {0, 2, 3}});
  const Vec3 p = mesh.face_point(1, {0.5, 0.25, 0.25});
  EXPECT_DOUBLE_EQ(p.x, 0.25);
  EXPECT_DOUBLE_EQ(p.y, 0.5);
}

TEST(MeshConstruction, RefusesNoFaces) {
  expect_mesh_error([] { TriangleMesh(square_positions(), {}); }, "EmptyMesh", {"no faces"});
}

TEST(MeshConstruction, RefusesVertexOutOfRange) {
  expect_mesh_error(
      [] {
        TriangleMesh(square_positions(), {{0, 1, 2}, {0, 2, 9}});
      },
      "VertexOutOfRange", {"face 1", "vertex 9"});
}

TEST(MeshConstruction, RefusesRepeatedCorner) {
  expect_mesh_error(
      [] {
        TriangleMesh(square_positions(), {{0, 1, 2}, {0, 3, 3}});
      },
      "DegenerateFaceIndices", {"face 1 (vertices 0 3 3)"});
}

TEST(MeshConstruction, RefusesNonFiniteCoordinate) {
  std::vector<Vec3> p = square_positions();
  p[2].y = std::numeric_limits<double>::quiet_NaN();
  expect_mesh_error([&] { TriangleMesh(p, {{0, 1, 2}}); }, "NonFiniteCoordinate", {"vertex 2"});
  p[2].y = std::numeric_limits<double>::infinity();
  expect_mesh_error([&] { TriangleMesh(p, {{0, 1, 2}}); }, "NonFiniteCoordinate", {"vertex 2"});
}

TEST(MeshConstruction, RefusesThreeFacesOnAnEdge) {
  // Faces 0 and 1 share edge 0-1 properly; face 2 adds a third face on it.
  std::vector<Vec3> p = {{0, 0, 0}, {1, 0, 0}, {0.5, 1, 0}, {0.5, -1, 0}, {0.5, 0, 1}};
  expect_mesh_error(
      [&] {
        TriangleMesh(p, {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}});
      },
      "NonManifoldEdge", {"face 2 (vertices 0 1 4)", "0->1", "face 0"});
}

TEST(MeshConstruction, RefusesFlippedNeighbour) {
  // Face 0 has the halfedge 2->0 and face 1 (2 0 3) runs it the same way: one face is flipped.
  expect_mesh_error(
      [] {
        TriangleMesh(square_positions(), {{0, 1, 2}, {2, 0, 3}});
      },
      "InconsistentOrientation", {"face 1 (vertices 2 0 3)", "2->0", "face 0"});
}

TEST(MeshConstruction, RefusesBowtieVertex) {
  // Two triangles meeting only at vertex 0.
  std::vector<Vec3> p = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}};
  expect_mesh_error(
      [&] {
        TriangleMesh(p, {{0, 1, 2}, {0, 3, 4}});
      },
      "NonManifoldVertex", {"vertex 0", "face 1 (vertices 0 3 4)", "face 0"});
}

TEST(MeshConstruction, TwoComponentsAreFine) {
  std::vector<Vec3> p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {5, 0, 0}, {6, 0, 0}, {5, 1, 0}};
  const TriangleMesh mesh(std::move(p), {{0, 1, 2}, {3, 4, 5}});
  EXPECT_EQ(mesh.num_edges(), 6u);
  EXPECT_EQ(mesh.face(1), (Triangle{3, 4, 5}));
}

}  // namespace
}  // namespace geoprox
