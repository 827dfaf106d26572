#include "core/mesh/intrinsic_geometry.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "core/base/errors.h"
#include "core/base/tuning.h"

namespace geoprox {

namespace {

// Heron's formula in Kahan's ordering: accurate for needles and caps.
double triangle_area(double a, double b, double c) {
  double s[3] = {a, b, c};
  std::sort(s, s + 3, [](double x, double y) { return x > y; });
  const double p = (s[0] + (s[1] + s[2])) * (s[2] - (s[0] - s[1])) * (s[2] + (s[0] - s[1])) *
                   (s[0] + (s[1] - s[2]));
  return 0.25 * std::sqrt(std::max(0.0, p));
}

// Area of face f from its corners' positions: half the cross product of the two sides at the
// corner opposite the longest side, whose rounding (about the product of those sides times the
// unit roundoff) is the least of the three corners'. side[i]: the length of corner i to i + 1.
double position_area(const TriangleMesh& mesh, std::uint32_t f, const double side[3]) {
  const Triangle& t = mesh.face(f);
  const int k = static_cast<int>(std::max_element(side, side + 3) - side);
  const Vec3& apex = mesh.position(t[(k + 2) % 3]);
  return 0.5 * norm(cross(mesh.position(t[k]) - apex, mesh.position(t[(k + 1) % 3]) - apex));
}

}  // namespace

IntrinsicGeometry::IntrinsicGeometry(const TriangleMesh& mesh, const Options& options)
    : mesh_(&mesh) {
  edge_length_.resize(mesh.num_edges());
  for (std::uint32_t e = 0; e < mesh.num_edges(); ++e) {
    edge_length_[e] = norm(mesh.position(mesh.edge_target(e)) - mesh.position(mesh.edge_origin(e)));
  }
  build(options);
}

IntrinsicGeometry::IntrinsicGeometry(const TriangleMesh& mesh, std::vector<double> edge_lengths,
                                     const Options& options)
    : mesh_(&mesh), edge_length_(std::move(edge_lengths)) {
  if (edge_length_.size() != mesh.num_edges()) {
    throw MeshError(ErrorCode::BadEdgeLength, "got " + std::to_string(edge_length_.size()) +
                                                  " edge lengths for a mesh with " +
                                                  std::to_string(mesh.num_edges()) + " edges");
  }
  for (std::uint32_t e = 0; e < edge_length_.size(); ++e) {
    if (!std::isfinite(edge_length_[e]) || edge_length_[e] < 0) {
      throw MeshError(ErrorCode::BadEdgeLength, "edge " + std::to_string(e) + " has length " +
                                                    std::to_string(edge_length_[e]) +
                                                    "; lengths must be finite and non-negative");
    }
  }
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
    const double a = edge_length_[mesh.edge_of(3 * f)];
    const double b = edge_length_[mesh.edge_of(3 * f + 1)];
    const double c = edge_length_[mesh.edge_of(3 * f + 2)];
    const double slack = tuning::kTriangleInequalitySlack * (a + b + c);
    if (a > b + c + slack || b > a + c + slack || c > a + b + slack) {
      throw MeshError(ErrorCode::TriangleInequality,
                      "face " + std::to_string(f) + " has edge lengths " + std::to_string(a) +
                          ", " + std::to_string(b) + ", " + std::to_string(c) +
                          " that violate the triangle inequality");
    }
  }
  build(options);
}

// Over 100 lines: its stages run in order, each reading the arrays the one before filled.
void IntrinsicGeometry::build(const Options& options) {
  const TriangleMesh& mesh = *mesh_;
  const std::size_t nh = mesh.num_halfedges();
  crossing_.assign(nh, HalfedgeCrossing{});
  angle_sum_.assign(mesh.num_vertices(), 0);
  corner_angle_.assign(nh, 0);
  // Lengths that are the positions' chords to the last bit (computed from them, here or in a
  // graph file) take their layouts from the positions (see the constructors): Heron's formula
  // lays zero-area faces out above rounding, which lengthens paths across rows of them. Other
  // lengths (a metric) have only themselves.
  lengths_are_chords_ = true;
  bool exact_chords = true;
  for (std::uint32_t e = 0; e < mesh.num_edges() && lengths_are_chords_; ++e) {
    const double chord =
        norm(mesh.position(mesh.edge_target(e)) - mesh.position(mesh.edge_origin(e)));
    lengths_are_chords_ =
        std::abs(edge_length_[e] - chord) <= tuning::kChordRelativeTolerance * chord;
    exact_chords = exact_chords && edge_length_[e] == chord;
  }
  face_area_.resize(mesh.num_faces());
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
    double side[3];
    for (std::uint32_t i = 0; i < 3; ++i) side[i] = edge_length_[mesh.edge_of(3 * f + i)];
    face_area_[f] =
        exact_chords ? position_area(mesh, f, side) : triangle_area(side[0], side[1], side[2]);
  }
  double total = 0;
  for (double l : edge_length_) total += l;
  mean_edge_length_ = edge_length_.empty() ? 0 : total / static_cast<double>(edge_length_.size());
  const double degenerate_area =
      options.degenerate_area_ratio * mean_edge_length_ * mean_edge_length_;

  degenerate_face_.assign(mesh.num_faces(), 0);
  thin_face_.assign(mesh.num_faces(), 0);
  std::vector<double> longest_side(mesh.num_faces(), 0);
  for (std::uint32_t h = 0; h < nh; ++h) {
    // h = a->b; lengths of ab, bc, ca.
    const double ab = edge_length_[mesh.edge_of(h)];
    const double bc = edge_length_[mesh.edge_of(TriangleMesh::next(h))];
    const double ca = edge_length_[mesh.edge_of(TriangleMesh::prev(h))];
    HalfedgeCrossing& crossing = crossing_[h];
    crossing.origin = mesh.origin(h);
    crossing.target = mesh.target(h);
    crossing.opposite = mesh.opposite_vertex(h);
    crossing.twin_prev = mesh.twin(TriangleMesh::prev(h));
    crossing.twin_next = mesh.twin(TriangleMesh::next(h));
    HalfedgeLayout& lay = crossing.layout;
    lay.length = ab;
    if (ab > 0) {
      // Height from the face's area (above) rather than sqrt(ca^2 - cx^2), which cancels
      // catastrophically for caps and needles; every halfedge of a face then lays it out with
      // the same area, so unfoldings across it agree to rounding. Where c projects onto ab
      // comes from the same source as the area: the lengths' formula divides their rounding
      // by ab, which only a height from the same lengths compensates (with the positions'
      // height beside a very short side, c would be off its distances, and a window carried
      // across the face could come out nearer than its parent).
      if (exact_chords) {
        const Vec3& a = mesh.position(mesh.origin(h));
        const Vec3 ac = mesh.position(mesh.opposite_vertex(h)) - a;
        lay.cx = dot(ac, mesh.position(mesh.target(h)) - a) / ab;
      } else {
        lay.cx = (ab * ab + ca * ca - bc * bc) / (2 * ab);
      }
      lay.cy = std::min(ca, 2 * face_area_[h / 3] / ab);
    } else {
      lay.cx = 0;
      lay.cy = ca;
    }
    // Angle at corner a from the layout (atan2 stays accurate for needles and caps).
    double angle;
    if (ab <= 0 || ca <= 0) {
      angle = 0;
    } else {
      angle = std::atan2(lay.cy, lay.cx);
    }
    corner_angle_[h] = angle;
    angle_sum_[mesh.origin(h)] += angle;
    if (h % 3 == 0) {
      const double area = face_area_[h / 3];
      degenerate_face_[h / 3] = area <= degenerate_area ? 1 : 0;
      // Height over the longest side, relative to it.
      const double longest = longest_side[h / 3] = std::max({ab, bc, ca});
      thin_face_[h / 3] =
          !degenerate_face_[h / 3] && 2 * area < options.thin_face_ratio * longest * longest;
    }
  }

  // The layout on a short side from the lengths puts the far corner where the other two sides'
  // difference says, which is noise: unfolded through it, the face is not the face (its far corner
  // can be off by much more than the short side's length). It is taken instead from the layout on
  // the face's longest side, turned: the same triangle, so everything placed in its frame (the
  // face's frame when that side is side 0: points, targets, directions) keeps the distances within
  // the face. The angles at its ends stay as uncertain as they are; solvers let no window through
  // such a side (short_sides).
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
    double side[3];
    for (int i = 0; i < 3; ++i)
      side[i] = edge_length_[mesh.edge_of(3 * f + static_cast<std::uint32_t>(i))];
    const int k = static_cast<int>(std::max_element(side, side + 3) - side);
    auto is_short_here = [&](int j) {
      return side[j] > 0 && side[j] < tuning::kShortEdgeRatio * longest_side[f];
    };
    if (!is_short_here((k + 1) % 3) && !is_short_here((k + 2) % 3)) continue;
    const HalfedgeLayout& base = crossing_[3 * f + static_cast<std::uint32_t>(k)].layout;
    Vec2 corner[3];
    corner[k] = {0, 0};
    corner[(k + 1) % 3] = {base.length, 0};
    corner[(k + 2) % 3] = {base.cx, base.cy};
    for (int j = 0; j < 3; ++j) {
      if (j == k || !is_short_here(j)) continue;
      const Vec2 from = corner[j], to = corner[(j + 1) % 3], far = corner[(j + 2) % 3];
      const double dx = to.x - from.x, dy = to.y - from.y, n = std::sqrt(dx * dx + dy * dy);
      if (!(n > 0)) continue;
      const double ex = dx / n, ey = dy / n, qx = far.x - from.x, qy = far.y - from.y;
      const std::uint32_t h = 3 * f + static_cast<std::uint32_t>(j);
      HalfedgeLayout& lay = crossing_[h].layout;
      lay.cx = ex * qx + ey * qy;
      lay.cy = std::max(0.0, ex * qy - ey * qx);
      const double angle = std::atan2(lay.cy, lay.cx);
      angle_sum_[mesh.origin(h)] += angle - corner_angle_[h];
      corner_angle_[h] = angle;
    }
  }

  // Short edges: against the longest side of either face they bound.
  std::vector<double> longest_beside(mesh.num_edges(), 0);
  for (std::uint32_t h = 0; h < nh; ++h) {
    double& beside = longest_beside[mesh.edge_of(h)];
    beside = std::max(beside, longest_side[h / 3]);
  }
  auto is_short = [&](std::uint32_t h) {
    const std::uint32_t e = mesh.edge_of(h);
    return edge_length_[e] < tuning::kShortEdgeRatio * longest_beside[e];
  };
  for (std::uint32_t h = 0; h < nh; ++h) {
    HalfedgeCrossing& crossing = crossing_[h];
    crossing.short_sides = (is_short(h) ? HalfedgeCrossing::kShortSide : 0) |
                           (is_short(TriangleMesh::prev(h)) ? HalfedgeCrossing::kShortPrev : 0) |
                           (is_short(TriangleMesh::next(h)) ? HalfedgeCrossing::kShortNext : 0);
    // No window goes through a short side: the record names no halfedge beyond it.
    if (crossing.short_sides & HalfedgeCrossing::kShortPrev) crossing.twin_prev = -1;
    if (crossing.short_sides & HalfedgeCrossing::kShortNext) crossing.twin_next = -1;
  }

  pseudo_source_.assign(mesh.num_vertices(), 0);
  const double saddle = 2 * std::numbers::pi * (1 + tuning::kSaddleAngleTolerance);
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    if (mesh.is_boundary_vertex(v) || angle_sum_[v] > saddle) pseudo_source_[v] = 1;
  }
  degenerate_vertex_.assign(mesh.num_vertices(), 0);
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
    // A face with a short side (against either face it bounds: a small face beside a large one
    // can be neither zero-area nor thin) has its corners emit in every direction all the same:
    // its records hide the halfedges beyond that side. (Each record flags all three sides.)
    const bool has_short_side = crossing_[3 * f].short_sides != 0;
    if (degenerate_face_[f] || thin_face_[f] || has_short_side) {
      for (std::uint32_t v : mesh.face(f)) pseudo_source_[v] = degenerate_vertex_[v] = 1;
    }
  }
}

Vec2 IntrinsicGeometry::face_corner(std::uint32_t f, int corner) const {
  const HalfedgeLayout& lay = layout(3 * f);
  if (corner == 0) return {0, 0};
  if (corner == 1) return {lay.length, 0};
  return {lay.cx, lay.cy};
}

Vec2 IntrinsicGeometry::face_point(std::uint32_t f, const double bary[3]) const {
  const HalfedgeLayout& lay = layout(3 * f);
  return {bary[1] * lay.length + bary[2] * lay.cx, bary[2] * lay.cy};
}

}  // namespace geoprox
