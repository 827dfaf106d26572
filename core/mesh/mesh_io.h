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
//  - Polygons with more than three corners are refused (NonTriangleFace) naming the face.
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
// NonTriangleFace, NonFiniteCoordinate, VertexOutOfRange, DegenerateFaceIndices, TooLarge, and
// whatever TriangleMesh refuses (mesh.h), with the path prefixed.
//
// Thread safety: the functions share no state; any number of loads may run at once.
#pragma once

#include <string>
#include <vector>

#include "core/mesh/mesh.h"

namespace geoprox {

/// Reads the mesh file at `path` into a TriangleMesh (ids in file order).
TriangleMesh load_mesh(const std::string& path);

/// The file's vertices and triangles in file order, read and checked as load_mesh reads them
/// (format, syntax, indices in range, STL welding, strips, no polygons), but not yet made into
/// a TriangleMesh: for core/mesh/mesh_repair.h, which repairs what TriangleMesh would refuse.
struct MeshSoup {
  std::vector<Vec3> positions;
  std::vector<Triangle> faces;
};
MeshSoup load_mesh_soup(const std::string& path);

}  // namespace geoprox
