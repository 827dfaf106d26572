// Mesh file loading through OpenMesh's readers (OBJ, OFF, PLY ascii/binary, STL ascii/binary).
//
// OpenMesh parses the file; geoprox captures the raw vertices and faces in file order through its
// own importer and builds a TriangleMesh itself, so ids are exactly file order and nothing is
// dropped or reordered silently: a face that OpenMesh would drop (complex edge, non-manifold
// vertex) makes loading fail with a MeshError naming that face and its vertex ids.
//  - STL: duplicated corners (bit-identical coordinates) are welded, in order of first use.
//  - Polygons with more than three corners are refused (NonTriangleFace) naming the face.
//  - PLY triangle strips (element `tristrips`, list `vertex_indices`, as Stanford's scans and
//    igea.ply store them; OpenMesh reads only their vertices) are unrolled here: strip
//    s0 s1 s2 s3 ... gives (s0 s1 s2), (s2 s1 s3), (s2 s3 s4), ... (every other triangle
//    turned round, to keep the strip's orientation); -1 ends a strip, every record starts one,
//    and triangles that repeat a vertex (the joins of stitched strips) are dropped. Face ids
//    are the kept triangles in that order. Every index is checked where it is read, kept or
//    not. A file with both faces and strips, or with strips before the vertices, is refused.
//  - Missing/unreadable/unparseable files throw FileError (FileNotFound, UnsupportedFormat,
//    ParseError).
#pragma once

#include <string>
#include <vector>

#include "core/mesh/mesh.h"

namespace geoprox {

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
