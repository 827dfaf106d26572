// OpenMesh as the independent reference reader of core/mesh (docs/meshes.md): its readers read
// the shipped meshes and the small files of every format as geoprox does.
#include <gtest/gtest.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

#include "core/mesh/mesh_io.h"
#include "tests/core/test_support.h"

namespace geoprox {
namespace {

using test_support::shipped_mesh_file;
using test_support::test_data_file;

// OpenMesh's readers, an independent implementation, read the shipped meshes and the small
// files of every format as geoprox does: the same vertices in the same order (to a float's last
// bit: OpenMesh holds floats) and the same faces (up to where each starts its corner cycle).

using OpenMeshTriangles = OpenMesh::TriMesh_ArrayKernelT<>;

/// t turned so that its smallest vertex comes first (same cycle, same orientation).
Triangle canonical_rotation(Triangle t) {
  std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
  return t;
}

bool same_float(double openmesh_value, double geoprox_value) {
  const float a = static_cast<float>(openmesh_value);
  const float b = static_cast<float>(geoprox_value);
  return a == b || std::nextafter(b, a) == a;
}

TEST(MeshIoReference, OpenMeshReadsTheSameVerticesAndFaces) {
  for (const std::string& path :
       {shipped_mesh_file("spot.obj"), shipped_mesh_file("blade.off"),
        shipped_mesh_file("plane_holes.obj"), shipped_mesh_file("cheese.off"),
        shipped_mesh_file("ChineseDragon-10kv.off"), test_data_file("octahedron.ply"),
        test_data_file("octahedron_binary.ply"), test_data_file("tetrahedron_ascii.stl"),
        test_data_file("tetrahedron_binary.stl")}) {
    SCOPED_TRACE(path);
    const TriangleMesh mesh = load_mesh(path);
    OpenMeshTriangles reference;
    ASSERT_TRUE(OpenMesh::IO::read_mesh(reference, path));
    ASSERT_EQ(reference.n_vertices(), mesh.num_vertices());
    ASSERT_EQ(reference.n_faces(), mesh.num_faces());
    std::size_t moved = 0, different_faces = 0;
    for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
      const OpenMeshTriangles::Point& p =
          reference.point(OpenMesh::VertexHandle(static_cast<int>(v)));
      const Vec3& q = mesh.position(v);
      moved += !same_float(p[0], q.x) || !same_float(p[1], q.y) || !same_float(p[2], q.z);
    }
    for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
      Triangle corners{};
      std::size_t i = 0;
      for (const OpenMesh::VertexHandle& v :
           reference.fv_range(OpenMesh::FaceHandle(static_cast<int>(f)))) {
        if (i < 3) corners[i] = static_cast<std::uint32_t>(v.idx());
        ++i;
      }
      different_faces += i != 3 || canonical_rotation(corners) != canonical_rotation(mesh.face(f));
    }
    EXPECT_EQ(moved, 0u);
    EXPECT_EQ(different_faces, 0u);
  }
}

}  // namespace
}  // namespace geoprox
