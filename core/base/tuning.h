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

// ---- Geodesic solvers (core/geodesic) -------------------------------------------------------

// ---- Proximity graph (core/graph) -----------------------------------------------------------

// ---- Queries (core/query) -------------------------------------------------------------------

// ---- Applications (core/apps) ---------------------------------------------------------------

}  // namespace geoprox::tuning
