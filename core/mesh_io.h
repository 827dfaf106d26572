// Mesh file loading through OpenMesh's readers (OBJ, OFF, PLY ascii/binary, STL ascii/binary).
//
// OpenMesh parses the file; geoprox captures the raw vertices and faces in file order through its
// own importer and builds a TriangleMesh itself, so ids are exactly file order and nothing is
// dropped or reordered silently: a face that OpenMesh would drop (complex edge, non-manifold
// vertex) makes loading fail with a MeshError naming that face and its vertex ids.
//  - STL: duplicated corners (bit-identical coordinates) are welded, in order of first use.
//  - Polygons with more than three corners are refused (NonTriangleFace) naming the face.
//  - Missing/unreadable/unparseable files throw FileError (FileNotFound, UnsupportedFormat,
//    ParseError).
#pragma once

#include <string>

#include "core/mesh.h"

namespace geoprox {

TriangleMesh load_mesh(const std::string& path);

}  // namespace geoprox
