// Refinement of long edges by longest-edge bisection: Rivara, "Algorithms for refining
// triangular grids suitable for adaptive and multigrid techniques", Int. J. Numer. Methods Eng.
// 20(4), 1984. Each round marks every edge longer than the limit, closes the marks so that a face
// with a marked edge has its longest edge marked too, and splits every face by its marked edges,
// the longest first (into 2, 3 or 4). Both faces of an edge see the same mark, so the result is
// conforming; bisecting across longest edges keeps the smallest angles bounded away from zero
// (for repeated longest-edge bisection, at least half the input's: Rosenberg & Stenger 1975; the
// tests check that bound face by face). New vertices are midpoints of edges, so the surface is
// the same: only faces longer than the limit, and the neighbours conformity needs, are split.
// Two faces over the same three vertices (a closed two-face surface) are fanned around their
// centroids instead, whatever the angles.
//
// What it is for: a proximity graph's samples are vertices, and a region of faces several link
// radii long holds none, so graph answers through it can be far off (docs/queries.md, "Known
// limitation"; geoprox build warns). Refining those faces gives the sampling vertices there.
//
// Ids: the input's vertices keep theirs (new ones are appended) and so does every face that is
// not split; a split face's first part keeps its id and the others are appended. Each face of
// the result knows the input face it lies in and its corners' barycentrics there, so points can
// be carried over (RefinedMesh::to_refined).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

struct MeshRefinementOptions {
  /// No edge of the result is longer than this (mesh units, > 0; positions' chords).
  double max_edge_length = 0;
  /// Refuse (InvalidInput "RefinementTooLarge") rather than make more faces than this.
  std::size_t max_faces = 50'000'000;
};

struct RefinedMesh {
  using Bary = std::array<double, 3>;

  std::vector<Vec3> positions;  ///< the input's vertices first (ids kept), then the new ones
  std::vector<Triangle> faces;  ///< faces below the input's count keep its ids (see above)
  /// Per face: the input face it lies in, and its corners' barycentrics there.
  std::vector<std::uint32_t> source_face;
  std::vector<std::array<Bary, 3>> source_bary;
  /// Per new vertex (id minus the input's vertex count): where it lies on the input mesh, a
  /// point on an input edge or inside an input face.
  std::vector<SurfacePoint> new_vertex_source;
  std::size_t input_vertices = 0;
  std::size_t input_faces = 0;
  std::size_t rounds = 0;       ///< bisection rounds run
  std::size_t edges_split = 0;  ///< over all rounds

  /// The same surface point on the refined mesh (a vertex stays a vertex; a point on an input
  /// edge or face goes to the refined face that holds it). `point` must be valid on the input.
  /// Scans every face: for a few points (a client mapping many reads --map's parts instead).
  SurfacePoint to_refined(const TriangleMesh& input, const SurfacePoint& point) const;
};

/// Throws InvalidInput ("BadOption") unless max_edge_length is finite and positive, and
/// ("RefinementTooLarge") past max_faces.
RefinedMesh refine_long_edges(const TriangleMesh& mesh, const MeshRefinementOptions& options);

}  // namespace geoprox
