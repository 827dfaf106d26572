// Tests of core/intrinsic_geometry: halfedge layouts against known triangles, and the per-halfedge
// crossing records the exact solver reads instead of the mesh's arrays (they must say exactly
// what the mesh says, on closed meshes, at boundaries and after a metric changes the lengths).
#include "core/mesh/intrinsic_geometry.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "core/mesh/mesh.h"
#include "tests/core/test_meshes.h"
#include "tests/core/test_support.h"

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
    // (No halfedge beyond a short side: no window goes through it.)
    ASSERT_EQ(c.twin_prev, (c.short_sides & HalfedgeCrossing::kShortPrev)
                               ? -1
                               : mesh.twin(TriangleMesh::prev(h)))
        << "halfedge " << h;
    ASSERT_EQ(c.twin_next, (c.short_sides & HalfedgeCrossing::kShortNext)
                               ? -1
                               : mesh.twin(TriangleMesh::next(h)))
        << "halfedge " << h;
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
    // (The mesh's own layouts come from its positions, the doubled lengths' from the lengths.)
    EXPECT_NEAR(doubled.layout(h).cx, 2 * spot.geometry->layout(h).cx,
                1e-12 * spot.geometry->layout(h).length)
        << h;
    EXPECT_NEAR(doubled.layout(h).cy, 2 * spot.geometry->layout(h).cy,
                1e-12 * spot.geometry->layout(h).length)
        << h;
  }
}

TEST(IntrinsicGeometry, LaysOutShortSidesFromTheLongestSide) {
  // Two needles sharing a side of 1.5e-15 (coordinates an ulp apart, from a bumpy test mesh),
  // their other sides 0.16-0.18. From the lengths alone, the layout on the short side put the
  // far corner where the long sides' difference (noise) said: 0.0023 along it, 1.8e-4 (relative)
  // off the two long sides' lengths, and a window unfolded through it came out shorter than the
  // straight line. Taken from the longest side's layout instead, every halfedge lays out the
  // same triangle; the short side is flagged, its records name no halfedge beyond it, and the
  // faces' corners emit in every direction.
  const TriangleMesh mesh({{0, 0, -0.077359966321925863},
                           {1.4901765115491748e-15, 0, -0.077359966321925974},
                           {1.4901765115491748e-15, 0.16526273602187291, -0.14473497004438463},
                           {0.0003, -0.1, 0.05}},
                          {Triangle{0, 1, 2}, Triangle{1, 0, 3}});
  const IntrinsicGeometry geometry(mesh);
  expect_records_match_mesh(mesh, geometry);
  for (std::uint32_t h = 0; h < mesh.num_halfedges(); ++h) {
    const HalfedgeLayout& lay = geometry.layout(h);
    const double ca = geometry.edge_length(mesh.edge_of(TriangleMesh::prev(h)));
    const double bc = geometry.edge_length(mesh.edge_of(TriangleMesh::next(h)));
    const double scale = std::max({lay.length, ca, bc});
    EXPECT_NEAR(lay.cx * lay.cx + lay.cy * lay.cy, ca * ca, 1e-14 * scale * scale) << h;
    EXPECT_NEAR((lay.cx - lay.length) * (lay.cx - lay.length) + lay.cy * lay.cy, bc * bc,
                1e-14 * scale * scale)
        << h;
    const bool short_side = mesh.edge_of(h) == mesh.edge_of(0);
    EXPECT_EQ((geometry.crossing(h).short_sides & HalfedgeCrossing::kShortSide) != 0, short_side)
        << h;
  }
  // The short side (halfedges 0 and 3) is prev of halfedges 1 and 4 and next of 2 and 5 (faces
  // (0 1 2) and (1 0 3)): their records name no halfedge beyond it, though the mesh has one.
  ASSERT_EQ(mesh.twin(0), 3);
  EXPECT_EQ(geometry.crossing(1).twin_prev, -1);
  EXPECT_EQ(geometry.crossing(2).twin_next, -1);
  EXPECT_EQ(geometry.crossing(4).twin_prev, -1);
  EXPECT_EQ(geometry.crossing(5).twin_next, -1);
  // Both have areas below 1e-14 of the mean edge squared: zero-area, not merely thin.
  for (std::uint32_t f = 0; f < 2; ++f) EXPECT_TRUE(geometry.is_degenerate_face(f)) << f;
  for (std::uint32_t v = 0; v < 4; ++v) {
    EXPECT_TRUE(geometry.is_degenerate_vertex(v)) << v;
    EXPECT_TRUE(geometry.is_pseudo_source(v)) << v;
  }
}

TEST(IntrinsicGeometry, CornersOfAFaceWithAShortSideEmitEverywhereWhateverTheOtherRatios) {
  // A small well-shaped face beside a large one: its sides are short against the large face's
  // longest side (1e-9 of it), yet it is neither zero-area nor thin, and with the other ratios
  // turned off nothing else flags its corners. They must emit in every direction all the same,
  // since the records hide the halfedges beyond the short side (the fan walk of a saddle
  // relies on them).
  IntrinsicGeometryOptions options;
  options.thin_face_ratio = 0;
  options.degenerate_area_ratio = 0;
  const TriangleMesh mesh({{0, 0, 0}, {1e-9, 0, 0}, {0.5e-9, 0.8e-9, 0}, {0.5, -1, 0}},
                          {Triangle{0, 1, 2}, Triangle{1, 0, 3}});
  const IntrinsicGeometry geometry(mesh, options);
  EXPECT_FALSE(geometry.is_thin_face(0));
  EXPECT_FALSE(geometry.is_degenerate_face(0));
  EXPECT_NE(geometry.crossing(0).short_sides & HalfedgeCrossing::kShortSide, 0u);
  EXPECT_EQ(geometry.crossing(4).twin_prev, -1);
  for (std::uint32_t v = 0; v < 3; ++v) EXPECT_TRUE(geometry.is_degenerate_vertex(v)) << v;
}

TEST(IntrinsicGeometry, MarksThinFacesButNotMerelyPoorOnes) {
  // Height over the longest side below 1e-5 of it: thin. Lucy's worst faces are near 1e-3.
  const TriangleMesh mesh({{0, 0, 0}, {1, 0, 0}, {0.5, 2e-6, 0}, {0.5, 1e-3, 0}},
                          {Triangle{0, 1, 2}, Triangle{1, 0, 3}});
  const IntrinsicGeometry geometry(mesh);
  EXPECT_TRUE(geometry.is_thin_face(0));
  EXPECT_FALSE(geometry.is_thin_face(1));
  EXPECT_FALSE(geometry.is_degenerate_face(0));
  EXPECT_TRUE(geometry.is_degenerate_vertex(2));
  EXPECT_FALSE(geometry.is_degenerate_vertex(3));
  EXPECT_EQ(geometry.crossing(0).short_sides, 0u);  // no side is short: only thin
}

TEST(IntrinsicGeometry, LaysOutZeroAreaFacesFromThePositions) {
  // A face of ugly_rectangle(36888): its middle corner 7e-21 off the line of the other two.
  // From the three rounded lengths alone (Heron's formula) its height is noise of 1.8e-9, and
  // paths across a row of such faces came out 2.4e-8 too long; from the positions it is zero
  // to their roundoff, so the face is zero-area (degenerate), as it is.
  const TriangleMesh mesh({{0.00088458472937772066, 4.7468027498228284e-05, 0},
                           {0.15627783079402663, 4.7468027498228277e-05, 0},
                           {0.2526970241734352, 4.7468027498228284e-05, 0}},
                          {Triangle{0, 1, 2}});
  const IntrinsicGeometry geometry(mesh);
  for (std::uint32_t h = 0; h < 3; ++h) EXPECT_LT(geometry.layout(h).cy, 1e-16) << "halfedge " << h;
  EXPECT_LT(geometry.face_area(0), 1e-17);
  EXPECT_TRUE(geometry.is_degenerate_face(0));
  // The same lengths given explicitly (a graph file's copy): the same geometry, bit for bit.
  const IntrinsicGeometry copy(mesh, geometry.edge_lengths());
  for (std::uint32_t h = 0; h < 3; ++h) {
    EXPECT_EQ(copy.layout(h).cx, geometry.layout(h).cx) << "halfedge " << h;
    EXPECT_EQ(copy.layout(h).cy, geometry.layout(h).cy) << "halfedge " << h;
    EXPECT_EQ(copy.corner_angle(h), geometry.corner_angle(h)) << "halfedge " << h;
  }
  // Other lengths (a metric: twice these) have only Heron's formula: a height, but a finite one.
  std::vector<double> doubled = geometry.edge_lengths();
  for (double& l : doubled) l *= 2;
  const IntrinsicGeometry metric(mesh, doubled);
  for (std::uint32_t h = 0; h < 3; ++h) {
    EXPECT_TRUE(std::isfinite(metric.layout(h).cy) && metric.layout(h).cy >= 0) << "halfedge " << h;
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
