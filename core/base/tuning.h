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

// ---- Geodesic solvers (core/geodesic) -------------------------------------------------------

// ---- Proximity graph (core/graph) -----------------------------------------------------------

// ---- Queries (core/query) -------------------------------------------------------------------

// ---- Applications (core/apps) ---------------------------------------------------------------

}  // namespace geoprox::tuning
