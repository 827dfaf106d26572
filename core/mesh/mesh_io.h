// Mesh file loading: OBJ, OFF (ascii), PLY (ascii and binary) and STL (ascii and binary),
// chosen by the file's extension (any case).
//
// geoprox reads each file once, with its own strict reader per format, and keeps what the file
// says: vertex and face ids are exactly file order, coordinates keep the file's precision (the
// decimal digits of OBJ, OFF and ascii PLY as doubles, binary PLY doubles, STL's floats), and
// nothing is dropped, merged or reordered silently. A record that cannot be read exactly makes
// loading fail with an error naming the file, the line when there is one, and the face or
// vertex. Only geometry is read: texture coordinates, normals, colours and materials are
// skipped.
//  - STL: corners are welded when their coordinates are equal as floats (bit-identical, or
//    +0 and -0), numbered in order of first use; a facet with two welded corners is refused.
//  - Polygons (OBJ, OFF and PLY faces of more than three corners) are triangulated over their
//    corners (core/mesh/polygon_triangulation.h). Triangle ids follow the file's face records
//    in order: record k of c corners becomes c - 2 consecutive triangles, all of polygon k
//    (MeshSoup::face_polygon). A file of triangles only loads exactly as it reads. A face of
//    fewer than 3 corners, with a repeated corner, or with all its corners on one line is
//    refused (DegenerateFaceIndices), and so is one of more than tuning::kMaxPolygonCorners
//    corners (TooLarge).
//  - PLY triangle strips (element `tristrips`, list `vertex_indices`, as some scanned meshes
//    store them) are unrolled: strip s0 s1 s2 s3 ... gives (s0 s1 s2), (s2 s1 s3), (s2 s3 s4),
//    ... (every other triangle turned round, to keep the strip's orientation); -1 ends a strip,
//    every record starts one, and triangles that repeat a vertex (the joins of stitched strips)
//    are dropped. Face ids are the kept triangles in that order. Every index is checked where it
//    is read, kept or not. A file with both faces and strips, or with strips before the
//    vertices, is refused.
//
// Errors (core/base/errors.h): FileError with FileNotFound (missing, a directory, unreadable),
// UnsupportedFormat (unknown extension, binary OFF, PLY faces and strips together) or
// ParseError (syntax); MeshError for content: EmptyMesh (a 0-byte file, or no faces),
// NonFiniteCoordinate, VertexOutOfRange, DegenerateFaceIndices, TooLarge, and whatever
// TriangleMesh refuses (mesh.h), with the path prefixed.
//
// Thread safety: the functions share no state; any number of loads may run at once.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh/mesh.h"
#include "core/mesh/mesh_repair.h"

namespace geoprox {

/// Reads the mesh file at `path` into a TriangleMesh (ids in file order; polygons triangulated,
/// their triangles numbered as above).
TriangleMesh load_mesh(const std::string& path);

/// The file's vertices and triangles in file order, read and checked as load_mesh reads them
/// (format, syntax, indices in range, STL welding, strips, polygons triangulated), but not yet
/// made into a TriangleMesh: for core/mesh/mesh_repair.h, which repairs what TriangleMesh would
/// refuse.
struct MeshSoup {
  std::vector<Vec3> positions;
  std::vector<Triangle> faces;
  /// Per triangle: the file's polygon (face record, in file order) it is part of. Empty when
  /// every face record of the file is a triangle: triangle ids are then the file's face ids.
  std::vector<std::uint32_t> face_polygon;
  /// Face records in the file (polygons of any corner count).
  std::size_t polygons = 0;
};
MeshSoup load_mesh_soup(const std::string& path);

struct MeshLoadOptions {
  /// Repair what TriangleMesh refuses (core/mesh/mesh_repair.h, the rules of `geoprox repair`)
  /// instead of refusing it. Default off: a mesh that is not an oriented manifold is an error.
  bool repair = false;
};

/// A mesh file as geoprox serves it: the triangles, how they map to the file's polygons, and
/// what repair changed.
struct LoadedMeshFile {
  TriangleMesh mesh;
  /// Per face of `mesh`: the file's polygon it is part of (MeshSoup::face_polygon after repair
  /// dropped faces); empty when the face ids are the file's.
  std::vector<std::uint32_t> face_polygon;
  std::size_t polygons = 0;  ///< face records in the file
  /// What repair changed, when loaded with options.repair (report.unchanged() if nothing).
  std::optional<MeshRepairReport> repair;

  /// The file's polygon of face f (f itself when the file's faces are all triangles).
  std::uint32_t polygon_of(std::uint32_t f) const {
    return face_polygon.empty() ? f : face_polygon[f];
  }
};

/// Reads, triangulates and (when asked) repairs the mesh file at `path`. Throws what
/// load_mesh throws; with repair, only what repair cannot fix (EmptyMesh, non-finite
/// coordinates) and file errors.
LoadedMeshFile load_mesh_file(const std::string& path, const MeshLoadOptions& options = {});

}  // namespace geoprox
