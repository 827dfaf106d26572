#include "core/mesh/closest_point.h"

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "core/base/errors.h"
#include "core/base/tuning.h"

namespace geoprox {
namespace {

/// Postponed far children during a query. Entries are siblings of the current node's ancestors,
/// so the stack never holds more than the tree's depth, which the build checks against this.
constexpr std::size_t kStackCapacity = 64;

/// A face counts as degenerate when (2 * area)^2 <= kSliverRatio * (longest edge)^4, i.e. its
/// height over the longest edge L is below sqrt(kSliverRatio) * L. Below that the projection's
/// barycentrics (error ~ eps * L / h) are worse than using the edges (error <= h), so such
/// faces are treated as their three edges.
constexpr double kSliverRatio = tuning::kClosestPointSliverRatio;

/// Coordinates beyond this are refused (see tuning.h).
constexpr double kMaxCoordinate = tuning::kClosestPointMaxCoordinate;

// mesh.h's dot/cross are out of line; the per-triangle test is the hot loop, so it inlines its
// own (same operation order, so results are identical).
inline double dot3(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross3(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

double axis_value(const Vec3& v, int axis) { return axis == 0 ? v.x : (axis == 1 ? v.y : v.z); }

bool is_degenerate_triangle(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, bc = c - b;
  const Vec3 n = cross3(ab, ac);
  const double longest_squared = std::max({dot3(ab, ab), dot3(ac, ac), dot3(bc, bc)});
  // Written as !(x > y) so that a NaN (overflowing coordinates) also takes the edge path.
  return !(dot3(n, n) > kSliverRatio * longest_squared * longest_squared);
}

/// Candidate closest point on one triangle.
struct TriangleHit {
  double squared_distance = std::numeric_limits<double>::infinity();
  std::array<double, 3> bary{1, 0, 0};
  Vec3 position;
};

/// Position from barycentrics (the expression of TriangleMesh::face_point, so the result agrees
/// with SurfacePoint::position), clamped into the triangle's bounding box: rounding can push a
/// convex combination an ulp outside, and the query's box pruning relies on every computed
/// point lying inside the boxes that contain its triangle.
TriangleHit make_hit(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c,
                     const std::array<double, 3>& bary) {
  TriangleHit hit;
  hit.bary = bary;
  Vec3 q = bary[0] * a + bary[1] * b + bary[2] * c;
  q.x = std::clamp(q.x, std::min({a.x, b.x, c.x}), std::max({a.x, b.x, c.x}));
  q.y = std::clamp(q.y, std::min({a.y, b.y, c.y}), std::max({a.y, b.y, c.y}));
  q.z = std::clamp(q.z, std::min({a.z, b.z, c.z}), std::max({a.z, b.z, c.z}));
  hit.position = q;
  const Vec3 d = p - q;
  hit.squared_distance = dot3(d, d);
  return hit;
}

/// Closest point on the triangle's boundary: each edge is a segment, or a point when its
/// corners coincide. Used for degenerate faces, where there is no interior to project onto.
TriangleHit closest_on_edges(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const std::array<const Vec3*, 3> corner{&a, &b, &c};
  TriangleHit best;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    const Vec3 edge = *corner[j] - *corner[i];
    const double length_squared = dot3(edge, edge);
    const double t =
        length_squared > 0 ? std::clamp(dot3(p - *corner[i], edge) / length_squared, 0.0, 1.0)
                           : 0.0;
    std::array<double, 3> bary{0, 0, 0};
    bary[i] = 1 - t;
    bary[j] = t;
    const TriangleHit hit = make_hit(p, a, b, c, bary);
    // The first edge is always taken, so an overflowing distance still yields a point.
    if (i == 0 || hit.squared_distance < best.squared_distance) best = hit;
  }
  return best;
}

/// Orthogonal projection of p inside a non-degenerate triangle. Barycentrics come from the
/// normals of the sub-triangles at the projected point, divided by the triangle's: for a thin
/// face of longest edge L and height h their error is ~ eps * L / h, where Ericson's
/// (d5 * d2 - d1 * d6) / (va + vb + vc) cancels to ~ eps * (L / h)^2. Ericson's region tests can
/// also misjudge such a face, so a projection that lands outside falls back to the edges.
TriangleHit project_inside(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 n = cross3(b - a, c - a);
  const double nn = dot3(n, n);
  // Projecting first keeps the sub-triangle normals parallel to n, so a position far above the
  // plane does not add rounding to them.
  const Vec3 q = p - (dot3(n, p - a) / nn) * n;
  const double u = dot3(n, cross3(b - q, c - q)) / nn;
  const double v = dot3(n, cross3(c - q, a - q)) / nn;
  const double w = dot3(n, cross3(a - q, b - q)) / nn;
  const double sum = u + v + w;
  if (!(u >= 0 && v >= 0 && w >= 0 && sum > 0)) return closest_on_edges(p, a, b, c);
  return make_hit(p, a, b, c, {u / sum, v / sum, w / sum});
}

/// Ericson 5.1.5: the Voronoi regions of corners A, B, C and edges AB, AC, BC in that order,
/// else the interior. Divisions are guarded: a vanishing denominator means the two ends of the
/// edge are equally close, and either will do.
TriangleHit closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c,
                                bool degenerate) {
  if (degenerate) return closest_on_edges(p, a, b, c);
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot3(ab, ap), d2 = dot3(ac, ap);
  if (d1 <= 0 && d2 <= 0) return make_hit(p, a, b, c, {1, 0, 0});

  const Vec3 bp = p - b;
  const double d3 = dot3(ab, bp), d4 = dot3(ac, bp);
  if (d3 >= 0 && d4 <= d3) return make_hit(p, a, b, c, {0, 1, 0});

  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double denominator = d1 - d3;
    const double t = denominator > 0 ? d1 / denominator : 0;
    return make_hit(p, a, b, c, {1 - t, t, 0});
  }

  const Vec3 cp = p - c;
  const double d5 = dot3(ab, cp), d6 = dot3(ac, cp);
  if (d6 >= 0 && d5 <= d6) return make_hit(p, a, b, c, {0, 0, 1});

  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double denominator = d2 - d6;
    const double t = denominator > 0 ? d2 / denominator : 0;
    return make_hit(p, a, b, c, {1 - t, 0, t});
  }

  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    const double towards_c = d4 - d3;
    const double denominator = towards_c + (d5 - d6);
    const double t = denominator > 0 ? towards_c / denominator : 0;
    return make_hit(p, a, b, c, {0, 1 - t, t});
  }

  return project_inside(p, a, b, c);
}

/// Squared distance from p to the box, summed in dot3's order: for a point q inside the box
/// every term is at most the matching term of |p - q|^2 (rounding is monotone), so this never
/// exceeds a computed squared distance to anything in the box.
double squared_distance_to_box(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  const double dx = std::max({lo.x - p.x, 0.0, p.x - hi.x});
  const double dy = std::max({lo.y - p.y, 0.0, p.y - hi.y});
  const double dz = std::max({lo.z - p.z, 0.0, p.z - hi.z});
  return dx * dx + dy * dy + dz * dz;
}

std::string format_position(const Vec3& p) {
  char buffer[128];
  std::snprintf(buffer, sizeof buffer, "(%.17g, %.17g, %.17g)", p.x, p.y, p.z);
  return buffer;
}

}  // namespace

ClosestPointIndex::ClosestPointIndex(const TriangleMesh& mesh, const Options& options)
    : mesh_(&mesh) {
  if (options.leaf_size < 1) {
    throw InvalidInput(ErrorCode::BadLeafSize,
                       "leaf_size must be >= 1, got " + std::to_string(options.leaf_size));
  }
  const auto num_faces = static_cast<std::uint32_t>(mesh.num_faces());
  std::vector<Vec3> centroids(num_faces);
  leaf_faces_.resize(num_faces);
  for (std::uint32_t f = 0; f < num_faces; ++f) {
    const Triangle& t = mesh.face(f);
    const Vec3& a = mesh.position(t[0]);
    const Vec3& b = mesh.position(t[1]);
    const Vec3& c = mesh.position(t[2]);
    centroids[f] = (1.0 / 3.0) * (a + b + c);
    leaf_faces_[f] = {f, is_degenerate_triangle(a, b, c)};
  }
  // Median splits of more than leaf_size faces leave at least (leaf_size + 1) / 2 faces in every
  // leaf (unless the root is a leaf), hence at most F / that many leaves and twice that in nodes.
  const std::uint32_t min_leaf_faces = options.leaf_size / 2 + options.leaf_size % 2;
  nodes_.reserve(2 * std::size_t{num_faces / min_leaf_faces} + 1);
  build_node(0, num_faces, 0, centroids, options.leaf_size);
}

std::uint32_t ClosestPointIndex::build_node(std::uint32_t begin, std::uint32_t end,
                                            std::uint32_t depth,
                                            const std::vector<Vec3>& centroids,
                                            std::uint32_t leaf_size) {
  GEOPROX_ASSERT(depth < kStackCapacity,
                 "closest-point tree deeper than its query stack (" + std::to_string(depth) + ")");
  const auto index = static_cast<std::uint32_t>(nodes_.size());
  nodes_.emplace_back();  // filled in below; children are appended after it

  constexpr double kInf = std::numeric_limits<double>::infinity();
  Node node;
  node.lo = {kInf, kInf, kInf};
  node.hi = {-kInf, -kInf, -kInf};
  Vec3 centroid_lo = node.lo, centroid_hi = node.hi;
  for (std::uint32_t slot = begin; slot < end; ++slot) {
    const std::uint32_t f = leaf_faces_[slot].face;
    for (std::uint32_t v : mesh_->face(f)) {
      const Vec3& p = mesh_->position(v);
      node.lo = {std::min(node.lo.x, p.x), std::min(node.lo.y, p.y), std::min(node.lo.z, p.z)};
      node.hi = {std::max(node.hi.x, p.x), std::max(node.hi.y, p.y), std::max(node.hi.z, p.z)};
    }
    const Vec3& c = centroids[f];
    centroid_lo = {std::min(centroid_lo.x, c.x), std::min(centroid_lo.y, c.y),
                   std::min(centroid_lo.z, c.z)};
    centroid_hi = {std::max(centroid_hi.x, c.x), std::max(centroid_hi.y, c.y),
                   std::max(centroid_hi.z, c.z)};
  }

  if (end - begin <= leaf_size) {
    node.begin = begin;
    node.count = end - begin;
    nodes_[index] = node;
    return index;
  }

  const Vec3 extent = centroid_hi - centroid_lo;
  const int axis =
      extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  // Median split: both halves have (almost) the same size, which bounds the depth even when
  // centroids coincide; ties go by face id so the tree depends on the mesh alone.
  const std::uint32_t middle = begin + (end - begin) / 2;
  std::nth_element(leaf_faces_.begin() + begin, leaf_faces_.begin() + middle,
                   leaf_faces_.begin() + end, [&](const LeafFace& x, const LeafFace& y) {
                     const double cx = axis_value(centroids[x.face], axis);
                     const double cy = axis_value(centroids[y.face], axis);
                     return cx < cy || (cx == cy && x.face < y.face);
                   });
  build_node(begin, middle, depth + 1, centroids, leaf_size);  // lands at index + 1
  node.begin = build_node(middle, end, depth + 1, centroids, leaf_size);
  node.count = 0;
  nodes_[index] = node;
  return index;
}

ClosestPointResult ClosestPointIndex::closest(const Vec3& position) const {
  for (double coordinate : {position.x, position.y, position.z}) {
    if (!std::isfinite(coordinate)) {
      throw InvalidInput(ErrorCode::BadPosition,
                         "position " + format_position(position) + " has a non-finite coordinate");
    }
    if (std::abs(coordinate) > kMaxCoordinate) {
      throw InvalidInput(ErrorCode::BadPosition,
                         "position " + format_position(position) +
                             " is too far out: coordinates must be at most 1e150 "
                             "in magnitude");
    }
  }

  TriangleHit best;
  std::uint32_t best_face = std::numeric_limits<std::uint32_t>::max();
  struct Pending {
    std::uint32_t node;
    double box_squared_distance;
  };
  std::array<Pending, kStackCapacity> stack;
  std::size_t pending = 0;
  std::uint32_t current = 0;
  for (;;) {
    const Node& node = nodes_[current];
    if (node.count > 0) {
      for (std::uint32_t slot = node.begin; slot < node.begin + node.count; ++slot) {
        const LeafFace& leaf_face = leaf_faces_[slot];
        const Triangle& t = mesh_->face(leaf_face.face);
        const TriangleHit hit =
            closest_on_triangle(position, mesh_->position(t[0]), mesh_->position(t[1]),
                                mesh_->position(t[2]), leaf_face.degenerate);
        if (hit.squared_distance < best.squared_distance ||
            (hit.squared_distance == best.squared_distance && leaf_face.face < best_face)) {
          best = hit;
          best_face = leaf_face.face;
        }
      }
    } else {
      std::uint32_t near_child = current + 1, far_child = node.begin;
      double near_distance =
          squared_distance_to_box(position, nodes_[near_child].lo, nodes_[near_child].hi);
      double far_distance =
          squared_distance_to_box(position, nodes_[far_child].lo, nodes_[far_child].hi);
      if (far_distance < near_distance) {
        std::swap(near_child, far_child);
        std::swap(near_distance, far_distance);
      }
      // "<=", not "<": a box at exactly the best distance may hold a tie with a lower face id.
      if (far_distance <= best.squared_distance) stack[pending++] = {far_child, far_distance};
      if (near_distance <= best.squared_distance) {
        current = near_child;
        continue;
      }
    }
    // Resume with the latest postponed subtree (the deepest, so usually the nearest) that can
    // still beat or tie the best.
    bool resumed = false;
    while (pending > 0) {
      const Pending next = stack[--pending];
      if (next.box_squared_distance <= best.squared_distance) {
        current = next.node;
        resumed = true;
        break;
      }
    }
    if (!resumed) break;
  }
  GEOPROX_ASSERT(best_face < mesh_->num_faces(), "closest-point query visited no face");

  ClosestPointResult result;
  const Triangle& t = mesh_->face(best_face);
  result.point = SurfacePoint::face(best_face, best.bary[0], best.bary[1], best.bary[2]);
  for (int corner = 0; corner < 3; ++corner) {
    if (best.bary[corner] == 1) result.point = SurfacePoint::vertex(t[corner]);
  }
  result.position = best.position;
  result.distance = std::sqrt(best.squared_distance);
  return result;
}

}  // namespace geoprox
