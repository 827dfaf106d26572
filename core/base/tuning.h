// Tuning constants of geoprox core, named once: the numbers that decide behaviour but that no
// caller sets. Internal to core (and its tests); public options live in each algorithm's header.
// Each constant says what it bounds, in which unit, and why its value.
#pragma once

#include <cstddef>

namespace geoprox::tuning {

// ---- Shared ---------------------------------------------------------------------------------

/// Relative slack that lets a value computed one way meet its bound computed another way: a
/// distance compared with a radius, a length with the distance it should equal. Rounding in
/// sums of a few hundred terms stays far below it.
inline constexpr double kRelativeSlack = 1e-9;

// ---- Mesh (core/mesh) -----------------------------------------------------------------------

/// The fewest bytes a vertex record takes in a mesh file ("0 0 0\n"): a reader reserves room for
/// at most (file size / this) of the vertices a header announces, so that a short file cannot
/// make it allocate for billions.
inline constexpr std::size_t kSmallestVertexRecordBytes = 6;
/// The same for a face record ("3 0 1 2\n").
inline constexpr std::size_t kSmallestFaceRecordBytes = 8;
/// How far, relative to a face's perimeter, its edge lengths may break a triangle inequality
/// and still count as a triangle (IntrinsicGeometry, metrics): rounding of lengths computed
/// from positions stays well below it.
inline constexpr double kTriangleInequalitySlack = 1e-12;
/// Edge lengths within this relative difference of their vertices' chords are the positions'
/// lengths (IntrinsicGeometry::lengths_are_chords), not a metric of their own.
inline constexpr double kChordRelativeTolerance = 1e-12;
/// A face is a sliver for closest-point queries when (2 area)^2 <= this * (longest edge)^4: its
/// height is below ~1.5e-8 of its longest edge, where projected barycentrics are worse than
/// the distances to its edges.
inline constexpr double kClosestPointSliverRatio = 0x1p-52;  // DBL_EPSILON
/// Closest-point queries refuse coordinates beyond this magnitude: squared distances to them
/// would overflow to infinity and every face would tie.
inline constexpr double kClosestPointMaxCoordinate = 1e150;

// ---- Geodesic solvers (core/geodesic) -------------------------------------------------------

// ---- Proximity graph (core/graph) -----------------------------------------------------------

// ---- Queries (core/query) -------------------------------------------------------------------

// ---- Applications (core/apps) ---------------------------------------------------------------

}  // namespace geoprox::tuning
