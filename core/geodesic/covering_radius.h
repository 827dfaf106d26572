// The covering radius of a set of samples on a surface: the radius r of the largest geodesic disk
// with no sample in it, over every point of the surface (faces' insides included), the r of
// Theorem 4.2 of "Lightweight preprocessing and fast query of geodesic distance via proximity
// graph" (error bound 2r / (R - 2r)). Exact distances from all samples at once (one
// multi-source exact solve, core/geodesic/exact_geodesic.h), then best-first branch and bound over
// the faces, after Piyavskii's method for Lipschitz functions (Piyavskii 1972; Shubert 1972): the
// distance to the samples changes by at most the length travelled, so a triangle whose corners
// are at most D from the samples and whose longest side is L holds no point farther than
// D + L / sqrt(3) (every point of a triangle lies within L / sqrt(3) of one of its corners).
// Triangles that could still hold a point beyond the best found are split into four.
//
// The largest distance at the vertices alone can be far below r: on a mesh with faces longer
// than the samples' spacing, the middle of such a face is far from every vertex.
#pragma once

#include <cstddef>
#include <span>

#include "core/geodesic/exact_geodesic.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

struct CoveringRadiusOptions {
  /// The answer `radius` is an upper bound of r at most this fraction above it: triangles are
  /// split until none could hold a point beyond (1 + relative_tolerance) times the farthest
  /// point found. Dimensionless.
  double relative_tolerance = 1e-3;
  /// Also find the faces holding a point farther than this from every sample (mesh units;
  /// infinity: none are looked for). A face whose farthest point is within relative_tolerance
  /// of it may be counted either way.
  double beyond = kInfinity;
};

struct CoveringRadius {
  /// Upper bound of r (mesh units): no point of the surface is farther than this from every
  /// sample; at most relative_tolerance above `attained`. Infinity if some face cannot be
  /// reached from any sample (a component without one).
  double radius = 0;
  /// Distance from `farthest` to its nearest sample (a lower bound of r).
  double attained = 0;
  /// The point found farthest from every sample: the centre of the largest empty disk.
  SurfacePoint farthest;
  /// The largest distance from a vertex (in some face) to its nearest sample.
  double vertex_radius = 0;
  /// Faces holding a point farther than options.beyond from every sample, and their total
  /// area (mesh units squared).
  std::size_t faces_beyond = 0;
  double area_beyond = 0;
  /// Exact distances evaluated inside faces (beyond the vertices' own).
  std::size_t evaluations = 0;
};

/// Reuses `solver` (its last solve is replaced by the multi-source solve). Throws InvalidInput
/// for an empty sample set or a sample that is not on the solver's mesh.
CoveringRadius covering_radius(ExactGeodesicSolver& solver, std::span<const SurfacePoint> samples,
                               const CoveringRadiusOptions& options = {});

/// One-shot form.
CoveringRadius covering_radius(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                               std::span<const SurfacePoint> samples,
                               const CoveringRadiusOptions& options = {});

}  // namespace geoprox
