#include "core/mesh/refinement_map.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>

#include "core/base/errors.h"

namespace geoprox {

SurfacePoint simplest_point_in_face(const TriangleMesh& mesh, std::uint32_t face,
                                    const std::array<double, 3>& bary) {
  for (int k = 0; k < 3; ++k) {
    if (bary[k] == 1) return SurfacePoint::vertex(mesh.face(face)[k]);
  }
  for (int k = 0; k < 3; ++k) {
    if (bary[k] != 0) continue;
    // On the side from corner k + 1 to corner k + 2, halfedge 3 face + (k + 1) % 3.
    const std::uint32_t h = 3 * face + (k + 1) % 3;
    const std::uint32_t e = mesh.edge_of(h);
    const double t = bary[(k + 2) % 3];  // the share of the side's end
    return mesh.edge_origin(e) == mesh.origin(h) ? SurfacePoint::edge(e, t)
                                                  : SurfacePoint::edge(e, 1 - t);
  }
  return SurfacePoint::face(face, bary[0], bary[1], bary[2]);
}

std::pair<double, std::array<double, 3>> barycentrics_in_part(
    const std::array<double, 3>& b, const std::array<std::array<double, 3>, 3>& corners) {
  // Solve b = sum l_k corners_k in two coordinates (the third follows from both summing to 1).
  const auto& B = corners;
  const double u1 = B[1][1] - B[0][1], u2 = B[1][2] - B[0][2];
  const double v1 = B[2][1] - B[0][1], v2 = B[2][2] - B[0][2];
  const double r1 = b[1] - B[0][1], r2 = b[2] - B[0][2];
  const double det = u1 * v2 - u2 * v1;
  if (det == 0) return {-std::numeric_limits<double>::infinity(), {1, 0, 0}};
  const double l1 = (r1 * v2 - r2 * v1) / det, l2 = (u1 * r2 - u2 * r1) / det;
  const double l0 = 1 - l1 - l2;
  const double c0 = std::max(l0, 0.0), c1 = std::max(l1, 0.0), c2 = std::max(l2, 0.0);
  const double sum = c0 + c1 + c2;
  return {std::min({l0, l1, l2}), {c0 / sum, c1 / sum, c2 / sum}};
}

namespace {

[[noreturn]] void throw_not_a_refinement(const std::string& what) {
  throw InvalidInput(ErrorCode::InvalidGraph, "the refinement map is inconsistent: " + what);
}

}  // namespace

RefinementMap::RefinementMap(const TriangleMesh& input, const TriangleMesh& refined,
                             std::span<const std::uint32_t> source_face,
                             std::span<const CornerBarys> source_bary)
    : input_(&input), refined_(&refined), source_face_(source_face), source_bary_(source_bary) {
  if (source_face.size() != refined.num_faces() || source_bary.size() != refined.num_faces()) {
    throw_not_a_refinement("one source face and three barycentrics per face of the refined mesh");
  }
  if (refined.num_vertices() < input.num_vertices()) {
    throw_not_a_refinement("the refined mesh has fewer vertices than the input");
  }
  part_offsets_.assign(input.num_faces() + 1, 0);
  for (std::size_t g = 0; g < source_face.size(); ++g) {
    if (source_face[g] >= input.num_faces()) {
      throw_not_a_refinement("face " + std::to_string(g) + " lies in input face " +
                             std::to_string(source_face[g]) + ", out of range");
    }
    for (const Bary& b : source_bary[g]) {
      const double sum = b[0] + b[1] + b[2];
      if (!(std::min({b[0], b[1], b[2]}) >= 0 && std::abs(sum - 1) <= kBarycentricSumTolerance)) {
        throw_not_a_refinement("a corner of face " + std::to_string(g) +
                               " is off its input face's simplex");
      }
    }
    ++part_offsets_[source_face[g] + 1];
  }
  for (std::size_t f = 0; f < input.num_faces(); ++f) part_offsets_[f + 1] += part_offsets_[f];
  parts_.resize(source_face.size());
  std::vector<std::uint32_t> next(part_offsets_.begin(), part_offsets_.end() - 1);
  for (std::size_t g = 0; g < source_face.size(); ++g) {
    parts_[next[source_face[g]]++] = static_cast<std::uint32_t>(g);
  }
}

SurfacePoint RefinementMap::to_refined(const SurfacePoint& point) const {
  if (point.kind == SurfacePoint::Kind::Vertex) return point;
  const auto [f, b] = point.in_face(*input_);
  double best_low = -std::numeric_limits<double>::infinity();
  SurfacePoint best = SurfacePoint::face(f, b[0], b[1], b[2]);
  for (std::uint32_t i = part_offsets_[f]; i < part_offsets_[f + 1]; ++i) {
    const std::uint32_t g = parts_[i];
    const auto [low, in_part] = barycentrics_in_part(b, source_bary_[g]);
    if (low > best_low) {
      best_low = low;
      best = SurfacePoint::face(g, in_part[0], in_part[1], in_part[2]);
    }
  }
  return best;
}

SurfacePoint RefinementMap::to_input(const SurfacePoint& point) const {
  if (point.kind == SurfacePoint::Kind::Vertex && point.id < input_->num_vertices()) return point;
  // The point's face on the refined mesh and its barycentrics there, then in the input face.
  std::uint32_t g = 0;
  Bary b{};
  if (point.kind == SurfacePoint::Kind::Edge) {
    // Along the edge's first halfedge, which runs from edge_origin to edge_target as t does.
    const std::uint32_t h = refined_->edge_halfedge(point.id);
    g = TriangleMesh::face_of(h);
    b[h % 3] = 1 - point.t;
    b[(h % 3 + 1) % 3] = point.t;
  } else {
    std::tie(g, b) = point.in_face(*refined_);
  }
  const CornerBarys& B = source_bary_[g];
  Bary in{};
  for (int k = 0; k < 3; ++k) {
    for (int c = 0; c < 3; ++c) in[c] += b[k] * B[k][c];
  }
  return simplest_point_in_face(*input_, source_face_[g], in);
}

}  // namespace geoprox
