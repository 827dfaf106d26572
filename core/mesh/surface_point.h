// A point on a triangle mesh: a vertex, a point on an edge, or a point inside a face.
//
// Face points use barycentric coordinates in the order of that face's vertices in the file;
// edge points use t in [0, 1] from edge_origin(e) to edge_target(e) (see core/mesh/mesh.h).
// validate() refuses ids out of range (VertexOutOfRange, EdgeOutOfRange, FaceOutOfRange), and
// barycentrics that are not finite, negative beyond 1e-12 or do not sum to 1 within 1e-5
// (BadBarycentric); an edge parameter outside [0, 1] is BadEdgeParameter. The sum's tolerance
// covers barycentrics rounded to six decimals; parse_surface_point divides them by their sum.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "core/mesh/mesh.h"

namespace geoprox {

/// How far below 0 a barycentric coordinate may be (rounding noise).
inline constexpr double kBarycentricNegativeTolerance = 1e-12;
/// How far from 1 barycentrics may sum: three coordinates rounded to six decimals are off by up
/// to 1.5e-6 together.
inline constexpr double kBarycentricSumTolerance = 1e-5;
/// Sums within this of 1 are rounding: parse_surface_point takes such barycentrics as they are.
inline constexpr double kBarycentricRoundingTolerance = 1e-12;

struct SurfacePoint {
  enum class Kind : std::uint8_t { Vertex, Edge, Face };

  Kind kind = Kind::Vertex;
  std::uint32_t id = 0;               ///< vertex, edge or face id
  double t = 0;                       ///< edge parameter (Kind::Edge)
  std::array<double, 3> bary{1, 0, 0};  ///< barycentrics (Kind::Face)

  static SurfacePoint vertex(std::uint32_t v) { return {Kind::Vertex, v, 0, {1, 0, 0}}; }
  static SurfacePoint edge(std::uint32_t e, double t) { return {Kind::Edge, e, t, {1, 0, 0}}; }
  static SurfacePoint face(std::uint32_t f, double b0, double b1, double b2) {
    return {Kind::Face, f, 0, {b0, b1, b2}};
  }

  /// Throws InvalidInput with a concrete reason if the point does not exist on `mesh`.
  void validate(const TriangleMesh& mesh) const;
  Vec3 position(const TriangleMesh& mesh) const;
  /// Some face containing the point and the point's barycentrics in it (vertices: the face of
  /// their first outgoing halfedge; isolated vertices throw InvalidInput).
  std::pair<std::uint32_t, std::array<double, 3>> in_face(const TriangleMesh& mesh) const;
  /// "v:12", "e:7:0.25" or "f:5:0.2:0.3:0.5" at full precision.
  std::string to_string() const;
};

/// Barycentrics accepted off the simplex name their normalized point: divides `bary` by its sum
/// when that sum is within kBarycentricSumTolerance of 1 but off by more than rounding
/// (kBarycentricRoundingTolerance); other coordinates, NaN included, stay as they are, so that a
/// point written back and read again is the same point.
void normalize_barycentrics(std::array<double, 3>& bary);

/// Parses the command-line point syntax `v:ID`, `e:ID:t`, `f:ID:b0:b1:b2`; throws InvalidInput
/// (BadPointSyntax) naming the text. Does not check ids against a mesh: call validate().
SurfacePoint parse_surface_point(const std::string& text);

}  // namespace geoprox
