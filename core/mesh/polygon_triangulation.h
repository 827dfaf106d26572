// Triangulation of one polygon face of a mesh file (an OBJ, OFF or PLY face of more than three
// corners) into triangles over its corners.
//
// The polygon may be non-convex, non-planar (a saddle quad) and have collinear corners (angles
// of 180 degrees). It is projected onto the plane through its centroid normal to its Newell
// normal (the sum of its edges' cross products: Newell's method, as in Sutherland, Sproull and
// Schumacker, "A characterization of ten hidden-surface algorithms", Computing Surveys 6(1),
// 1974), where a polygon that a modeller meant as a face is simple and counter-clockwise. Then:
//  - up to tuning::kPolygonDynamicProgrammingCorners corners, when the projection is simple:
//    dynamic programming over the diagonals that lie inside the projected polygon (the
//    minimum-weight triangulation of a simple polygon, Klincsek, "Minimal triangulations of
//    polygonal domains", Annals of Discrete Mathematics 9, 1980), O(n^3) time and O(n^2)
//    memory. Every triangle then lies inside the projected polygon, with the polygon's
//    orientation, so that the triangles cover the polygon once (InsideDiagonals).
//  - up to that many corners, when the projection is not simple (the polygon overlaps itself
//    seen along its normal, or that normal vanishes): the same programme over all diagonals,
//    the hole filling of Liepa, "Filling holes in meshes", SGP 2003 (MinimumArea).
//  - more corners: ear clipping in the projection (Meisters, "Polygons have ears", American
//    Mathematical Monthly 82(6), 1975), the best-shaped ear (largest smallest angle) first,
//    O(n^2) at worst (EarClipping). Corners collinear with their neighbours to rounding are no
//    ears, and corners on an ear's sides to rounding block it, so that no triangle is flat. A
//    polygon whose projection is not simple still gets n - 2 triangles: when no ear is left,
//    the best-shaped corner that turns the polygon's way is cut off.
// The weight, for both programmes: the triangles' total area in 3D first, then their smallest
// angle (larger is better). The area decides for a non-planar polygon: the least-area surface
// over its boundary is the one that folds least, and is Liepa's criterion. Every triangulation
// of a planar polygon has the polygon's area, so there (totals within
// tuning::kPolygonAreaTieTolerance times the square of the polygon's extent count as equal) the
// smallest angle decides, which for a convex polygon is what its Delaunay triangulation
// maximizes: slivers are what the geodesic solvers and the samples' spacing suffer from.
//
// Contract: a polygon of n >= 3 corners gets n - 2 triangles (a, b, c) of corner indices with
// a < b < c, which is the polygon's cyclic order, in lexicographic order. So each triangle keeps
// the polygon's orientation, and together they use each polygon edge once, in its direction, and
// each diagonal twice, once each way (a disk). A triangle (3 corners) is returned as it is. A
// polygon of 4 or more corners that all lie on one line, or at one point (within
// tuning::kPolygonDegenerateRatio of its extent), has no plane and no area: MeshError
// (DegenerateFaceIndices); so has one of fewer than 3 corners. Non-finite coordinates are the
// caller's to refuse. The result depends only on the corners' positions and order.
//
// Thread safety: a pure function; any number of calls may run at once.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/mesh/mesh.h"

namespace geoprox {

/// Which of the methods above triangulated a polygon.
enum class PolygonTriangulationMethod : std::uint8_t {
  AlreadyTriangle,  ///< three corners: the polygon itself
  InsideDiagonals,  ///< dynamic programming over the diagonals inside the projection
  MinimumArea,      ///< dynamic programming over all diagonals (the projection is not simple)
  EarClipping,      ///< more corners than dynamic programming takes
};

struct PolygonTriangulation {
  /// corners.size() - 2 triangles of corner indices (0 .. corners.size() - 1), each ascending.
  std::vector<Triangle> triangles;
  PolygonTriangulationMethod method = PolygonTriangulationMethod::AlreadyTriangle;
};

/// Triangulates the polygon with these corners, in order (see above).
PolygonTriangulation triangulate_polygon(std::span<const Vec3> corners);

}  // namespace geoprox
