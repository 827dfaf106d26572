// The same surface points on a mesh and on a refinement of it (core/mesh/mesh_refinement.h): a
// refined mesh keeps the input's vertices first with their ids, and each of its faces lies in one
// input face, its corners at known barycentrics there. A graph built on a refinement answers in
// the input's ids through this map (core/query/geodesic_query.h).
//
// Input -> refined: a vertex stays itself; a point on an input edge or face goes to the refined
// face that holds it (found among the parts of its input face, an index built once). Refined ->
// input: an input vertex stays itself; any other point becomes the point of its input face at
// the barycentrics it has there, given as a point of the input edge when it lies on one.
// Positions agree to rounding (the barycentrics are products of exact dyadic fractions).
//
// Thread safety: nothing changes after construction; any number of threads may map at once.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

/// The point at barycentrics `bary` of face `face`, as the simplest kind that names it: a vertex
/// when it is a corner, a point of an edge when one coordinate is zero, else a face point.
SurfacePoint simplest_point_in_face(const TriangleMesh& mesh, std::uint32_t face,
                                    const std::array<double, 3>& bary);

/// Barycentrics `b` of a face in one of its parts, whose corners lie at `corners` in the face:
/// the smallest of them (negative outside the part, -infinity for a part of zero area) and the
/// barycentrics clamped onto the part. The part holding `b` is the one whose smallest is largest.
std::pair<double, std::array<double, 3>> barycentrics_in_part(
    const std::array<double, 3>& b, const std::array<std::array<double, 3>, 3>& corners);

class RefinementMap {
 public:
  using Bary = std::array<double, 3>;
  using CornerBarys = std::array<Bary, 3>;

  /// `refined` refines `input`: its first input.num_vertices() vertices are the input's, and
  /// refined face g lies in input face source_face[g] with its corners at source_bary[g]. The
  /// meshes and spans must outlive the map (the spans may point into a mapped graph file).
  /// Throws InvalidInput ("InvalidGraph") when the arrays do not describe a refinement of
  /// `input` (sizes, ids out of range, barycentrics off the simplex).
  RefinementMap(const TriangleMesh& input, const TriangleMesh& refined,
                std::span<const std::uint32_t> source_face,
                std::span<const CornerBarys> source_bary);

  const TriangleMesh& input() const { return *input_; }
  const TriangleMesh& refined() const { return *refined_; }

  /// The point of the refined mesh at input point `point` (which must be valid on the input).
  SurfacePoint to_refined(const SurfacePoint& point) const;
  /// The point of the input mesh at refined point `point` (valid on the refined mesh).
  SurfacePoint to_input(const SurfacePoint& point) const;

 private:
  const TriangleMesh* input_;
  const TriangleMesh* refined_;
  std::span<const std::uint32_t> source_face_;
  std::span<const CornerBarys> source_bary_;
  /// Refined faces of each input face, as CSR rows.
  std::vector<std::uint32_t> part_offsets_;
  std::vector<std::uint32_t> parts_;
};

}  // namespace geoprox
