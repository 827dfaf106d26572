// Repair of triangle soups that TriangleMesh refuses (no paper: the cut-and-split treatment of
// non-manifold meshes, as in Gueziec, Taubin, Lazarus and Horn, "Cutting and stitching:
// converting sets of polygons to manifold surfaces", IEEE TVCG 2001).
//
// TriangleMesh takes only oriented 2-manifolds and names the first face that is not (mesh.h);
// scanned and modelled meshes often are not: a vertex where two sheets touch, faces turned the
// wrong way round, edges with three or more faces and triangles listed twice. repair_mesh
// turns such a soup into a mesh TriangleMesh accepts, changing as little as it can and saying
// what it changed:
//  1. faces that repeat a vertex index are dropped, and so are faces over the same three
//     vertices as an earlier face (either orientation; but a face and its reverse that share
//     their edges with no other face are a closed surface of two faces, and both stay);
//  2. an edge with three or more faces is cut: each face along it gets it as a boundary;
//  3. faces are turned round (corners 1 and 2 swapped) so that each connected sheet is
//     consistently oriented, the way that turns fewer of its faces (a tie: as its lowest face
//     in file order); an edge no orientation can make consistent (a Moebius strip) is cut;
//  4. a vertex whose faces form several fans keeps its id for the fan of its lowest face and
//     gets a copy, appended after the input's vertices, for each other fan.
// Vertices keep their ids (copies come after them, in order of the vertex they copy); faces
// keep their order, less those dropped. Nothing else changes: positions are copied bit for bit,
// and no face is moved. Coordinates that are not finite are not repaired (TriangleMesh still
// refuses them).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/base/errors.h"
#include "core/mesh/mesh.h"

namespace geoprox {

struct MeshRepairOptions {
  /// Turn faces round to make each sheet's orientation consistent (step 3). Off: a pair of
  /// faces that run their common edge the same way is cut there instead, and no face turns.
  bool orient = true;
};

/// What repair_mesh changed (counts; all zero, and the output the input, for a mesh that
/// TriangleMesh accepts as it is).
struct MeshRepairReport {
  std::size_t vertices_in = 0, faces_in = 0;
  std::size_t vertices_out = 0, faces_out = 0;
  std::size_t degenerate_faces_dropped = 0;  ///< faces that repeat a vertex index
  std::size_t duplicate_faces_dropped = 0;   ///< same three vertices as an earlier face
  std::size_t edges_cut = 0;          ///< edges with 3+ faces, or that no orientation fixes
  std::size_t faces_flipped = 0;      ///< faces turned round (corners 1 and 2 swapped)
  std::size_t vertices_split = 0;     ///< input vertices whose faces formed several fans
  std::size_t vertices_added = 0;     ///< copies appended after the input's vertices

  /// True when the output is the input (nothing dropped, cut, turned or split).
  bool unchanged() const {
    return degenerate_faces_dropped + duplicate_faces_dropped + edges_cut + faces_flipped +
               vertices_split ==
           0;
  }
};

struct RepairedMesh {
  std::vector<Vec3> positions;
  std::vector<Triangle> faces;
  /// Per output vertex: the input vertex it is (ids below the input's count) or copies.
  std::vector<std::uint32_t> source_vertex;
  /// Per output face: its id in the input.
  std::vector<std::uint32_t> source_face;
  /// Per output face: 1 if it was turned round (its corners 1 and 2 swapped: barycentric
  /// coordinates in the input's corner order swap their last two entries).
  std::vector<std::uint8_t> flipped;
  MeshRepairReport report;
};

/// True for the reasons TriangleMesh refuses a mesh for that repair_mesh fixes
/// (NonManifoldVertex, NonManifoldEdge, InconsistentOrientation, DegenerateFaceIndices): what
/// error messages point to repair for.
bool repair_fixes(ErrorCode code);

/// What `report` says changed, counts that are not zero only, for one line of a log or of
/// standard error: "3 duplicate faces dropped, 2 edges cut, 5 vertices split (+5 copies)";
/// "nothing changed" when report.unchanged().
std::string describe_repair_changes(const MeshRepairReport& report);

/// Repairs a triangle soup (positions and faces as read from a file) as described above. The
/// result is accepted by TriangleMesh unless a coordinate is not finite. Throws MeshError
/// (EmptyMesh, VertexOutOfRange) when there is nothing to repair into a mesh.
RepairedMesh repair_mesh(const std::vector<Vec3>& positions, const std::vector<Triangle>& faces,
                         const MeshRepairOptions& options = {});

}  // namespace geoprox
