// Tuning constants of geoprox core, named once: the numbers that decide behaviour but that no
// caller sets. Internal to core (and its tests); public options live in each algorithm's header.
// Each constant says what it bounds, in which unit, and why its value.
#pragma once

#include <cstddef>
#include <cstdint>

namespace geoprox::tuning {

// ---- Shared ---------------------------------------------------------------------------------

/// Relative slack that lets a value computed one way meet its bound computed another way: a
/// distance compared with a radius, a length with the distance it should equal. Rounding in
/// sums of a few hundred terms stays far below it.
inline constexpr double kRelativeSlack = 1e-9;

// ---- Mesh (core/mesh) -----------------------------------------------------------------------

// ---- Geodesic solvers (core/geodesic) -------------------------------------------------------

// ---- Proximity graph (core/graph) -----------------------------------------------------------

/// Automatic sampling samples on exact distances instead of fast marching when the mean Lo
/// quality of the faces is below this (an equilateral triangle scores 0.1443, the paper's poor
/// model scores below this): fast marching's distances, and so its samples, go wrong on meshes
/// of poorly shaped triangles.
inline constexpr double kPoorMeshLoQuality = 0.07;
/// ... or when more than this fraction of the faces are obtuse, where fast marching's updates
/// are least accurate.
inline constexpr double kPoorMeshObtuseFraction = 0.5;

/// graph_size_for_error clamps m_P to [min, max]; its prediction then says what the clamped
/// m_P gives.
inline constexpr std::uint32_t kErrorFitMinNeighbors = 4;
inline constexpr std::uint32_t kErrorFitMaxNeighbors = 64;
/// The fit of the measured relative error to m_P (docs/accuracy.md, bench/accuracy_plot.py):
/// mean = kErrorFitMeanScale * m_P^-kErrorFitMeanExponent, and the same for the 99th percentile.
inline constexpr double kErrorFitMeanScale = 0.4169;
inline constexpr double kErrorFitMeanExponent = 1.577;
inline constexpr double kErrorFitP99Scale = 0.5693;
inline constexpr double kErrorFitP99Exponent = 1.288;
/// An m_P computed from the fit that is within this of an integer (in neighbours) is that
/// integer: rounding must not ask for one neighbour more than the target needs.
inline constexpr double kErrorFitRoundingSlack = 1e-9;

/// Samples between two progress reports of the sampling and local-solve phases: often enough
/// for a progress bar, rarely enough to cost nothing.
inline constexpr std::size_t kGraphProgressEvery = 64;
/// Samples an OpenMP thread takes at a time in the local solves: consecutive samples along the
/// spatial order share mesh data in cache, and the solves vary in cost (dynamic schedule).
inline constexpr int kLocalSolveChunk = 16;

/// Directions: a face layout whose corner at vertex 0 has |sin| at most this is degenerate, and
/// the face's 3D frame is built from its positions instead.
inline constexpr double kDegenerateLayoutSine = 1e-12;
/// ... and a 3D face whose squared sine at a corner is at most this has no reliable plane to
/// hold a direction read from the text format.
inline constexpr double kDegenerateFaceSineSquared = 1e-24;
/// The text format: a sample's coordinates match a mesh vertex within this fraction of the
/// bounding-box diagonal (%.17g round-trips exactly; this absorbs other writers' rounding).
inline constexpr double kSampleMatchTolerance = 1e-9;

/// Graph file I/O buffers (bytes): the writer's (one write(2) per buffer), the checksum's read
/// chunk (small enough for L2: each byte is copied, then hashed) and the text export's (one
/// stream write per buffer).
inline constexpr std::size_t kGraphWriteBufferBytes = std::size_t{1} << 20;
inline constexpr std::size_t kChecksumReadChunkBytes = 256 * 1024;
inline constexpr std::size_t kTextFlushBytes = std::size_t{1} << 20;

// ---- Queries (core/query) -------------------------------------------------------------------

// ---- Applications (core/apps) ---------------------------------------------------------------

}  // namespace geoprox::tuning
