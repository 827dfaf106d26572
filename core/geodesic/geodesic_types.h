// The vocabulary of the geodesic layer, shared by the exact solver, fast marching, tracing,
// the covering radius and the query engine: a source, a path and its points, a direction.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

/// The distance of what no solve reached.
inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

/// A point that distances are measured from, with the distance already travelled to it.
struct GeodesicSource {
  SurfacePoint point;
  double offset = 0;  ///< distance already travelled to this source (mesh units, >= 0)
};

/// A unit direction in the frame of a face (origin at its corner 0, x towards corner 1, y towards
/// corner 2's side), see IntrinsicGeometry. Stored by the proximity graph and traced from later.
struct FaceDirection {
  std::uint32_t face = 0;
  double x = 1, y = 0;
};

/// A point of a path: where it lies on the surface and in space.
struct PathPoint {
  SurfacePoint point;
  Vec3 position;
};

struct GeodesicPath {
  /// From the source to the target: the source point, edge crossings and pseudo-source vertices,
  /// then the target point.
  std::vector<PathPoint> points;
  double length = kInfinity;       ///< equals the distance to the target
  std::uint32_t source_index = 0;  ///< which of the solve's sources the path starts at
  /// Unit tangent at the source pointing along the path (towards the target), and at the target
  /// pointing back along the path (towards the source). For a path of zero length both are the
  /// x axis of the point's face.
  FaceDirection direction_at_source;
  FaceDirection direction_at_target;
};

}  // namespace geoprox
