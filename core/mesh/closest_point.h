// Closest point on a triangle mesh's surface to a 3D position: a bounding-volume hierarchy of
// axis-aligned boxes over the faces, and the closest point on each candidate triangle by
// Ericson, "Real-Time Collision Detection", Morgan Kaufmann 2005, section 5.1.5 (Voronoi regions
// of the corners and edges, else the projection onto the plane).
//
// Build, O(F log F): top-down from all faces; a node with more than Options::leaf_size faces is
// split at the median face centroid along the longest axis of its centroids' bounding box
// (std::nth_element, ties by face id), so the halves differ by at most one face and the depth is
// at most ceil(log2 F) <= 30. Nodes live in one flat vector in depth-first order (the first
// child follows its parent); each box is the exact bounding box of its faces' corners.
//
// Query: depth first, nearer child first, keeping a fixed-size stack of postponed far children
// with their squared box distances; a subtree is skipped only when its box is strictly farther
// than the best face so far, so faces at exactly the best distance are still seen and the lowest
// face id among them wins. The answer is therefore the minimum of (computed squared distance,
// face id) over all faces: exactly what a loop over every face would return, whatever the leaf
// size (closest_point.cpp keeps computed points inside their triangle's box, so box distances
// are true lower bounds in floating point too).
//
// Per triangle, beyond Ericson: a face thinner than about 1.5e-8 of its longest edge (zero-area
// faces, collinear or coincident corners) is treated as its three edges, each a segment or a
// point, so nothing divides by a vanishing area; and the projection inside a face takes its
// barycentrics from sub-triangle normals (error ~ eps * L / h for a face of longest edge L and
// height h) instead of Ericson's products of dot products (~ eps * (L / h)^2), falling back to
// the edges when it lands outside. Accuracy: exact up to rounding on well-shaped faces; on a
// sliver of height h the distance can be off by at most about max(h, eps * L^2 / h).
//
// Only faces count: isolated vertices are never returned.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

struct ClosestPointOptions {
  /// Leaves hold at most this many faces (>= 1; 0 throws InvalidInput "BadLeafSize"). Smaller
  /// leaves mean more nodes (2 F / leaf_size to 4 F / leaf_size, 56 bytes each) and fewer
  /// triangle tests per query; the default balances the two (bench/closest_point_bench.cpp).
  std::uint32_t leaf_size = 4;
};

struct ClosestPointResult {
  /// The closest surface point: Kind::Vertex when it is exactly a corner (barycentric 1), else
  /// Kind::Face with barycentrics in that face's vertex order, non-negative and summing to 1.
  SurfacePoint point;
  /// Its 3D position (mesh units).
  Vec3 position;
  /// Euclidean distance from the query position to `position` (mesh units).
  double distance = 0;
};

class ClosestPointIndex {
 public:
  using Options = ClosestPointOptions;

  /// Builds once over the mesh's faces; the mesh must outlive the index. Read-only afterwards:
  /// closest() is const and safe from many threads at once, and allocates nothing.
  explicit ClosestPointIndex(const TriangleMesh& mesh, const Options& options = {});

  /// The closest point of the surface to `position`. Throws InvalidInput(ErrorCode::BadPosition)
  /// for a non-finite coordinate, or one beyond 1e150 in magnitude (its squared distance would
  /// overflow). Exact ties in distance go to the lowest face id, so results are deterministic.
  ClosestPointResult closest(const Vec3& position) const;

  std::size_t num_nodes() const { return nodes_.size(); }

 private:
  struct Node {
    Vec3 lo, hi;  ///< bounding box of the node's faces' corners
    /// Leaf: first slot of its faces in leaf_faces_. Interior: index of the second child (the
    /// first child is the next node).
    std::uint32_t begin = 0;
    std::uint32_t count = 0;  ///< leaf: number of faces (>= 1); interior: 0
  };
  struct LeafFace {
    std::uint32_t face = 0;
    /// Too thin for a reliable projection (see above): measured once at build time.
    bool degenerate = false;
  };

  std::uint32_t build_node(std::uint32_t begin, std::uint32_t end, std::uint32_t depth,
                           const std::vector<Vec3>& centroids, std::uint32_t leaf_size);

  const TriangleMesh* mesh_;
  std::vector<Node> nodes_;
  std::vector<LeafFace> leaf_faces_;  ///< faces in leaf order
};

}  // namespace geoprox
