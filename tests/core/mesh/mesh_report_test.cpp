// compute_mesh_report / format_mesh_report on hand-made and shipped meshes.
#include "core/mesh/mesh_report.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh_io.h"
#include "tests/core/test_support.h"

namespace geoprox {
namespace {

using test_support::shipped_mesh_file;
using test_support::test_data_file;

MeshReport report_of(const TriangleMesh& mesh) {
  const IntrinsicGeometry geometry(mesh);
  return compute_mesh_report(mesh, geometry);
}

MeshReport report_of_file(const std::string& path) { return report_of(load_mesh(path)); }

/// An n x m torus grid: genus 1, closed.
TriangleMesh torus(std::uint32_t n, std::uint32_t m) {
  std::vector<Vec3> positions;
  std::vector<Triangle> faces;
  for (std::uint32_t i = 0; i < n; ++i) {
    for (std::uint32_t j = 0; j < m; ++j) {
      const double u = 2 * std::numbers::pi * i / n;
      const double v = 2 * std::numbers::pi * j / m;
      positions.push_back(
          {(3 + std::cos(v)) * std::cos(u), (3 + std::cos(v)) * std::sin(u), std::sin(v)});
    }
  }
  auto id = [&](std::uint32_t i, std::uint32_t j) { return (i % n) * m + (j % m); };
  for (std::uint32_t i = 0; i < n; ++i) {
    for (std::uint32_t j = 0; j < m; ++j) {
      faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  }
  return TriangleMesh(std::move(positions), std::move(faces));
}

TEST(MeshReport, OctahedronIsARegularSphere) {
  const MeshReport r = report_of_file(test_data_file("octahedron.ply"));
  EXPECT_EQ(r.vertices, 6u);
  EXPECT_EQ(r.faces, 8u);
  EXPECT_EQ(r.edges, 12u);
  EXPECT_EQ(r.isolated_vertices, 0u);
  EXPECT_EQ(r.boundary_edges, 0u);
  EXPECT_EQ(r.boundary_loops, 0u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.genus_per_component, std::vector<long>{0});
  EXPECT_EQ(r.degenerate_faces, 0u);
  EXPECT_EQ(r.thin_faces, 0u);
  EXPECT_EQ(r.obtuse_faces, 0u);
  EXPECT_EQ(r.saddle_vertices, 0u);  // angle sum 4 x 60 degrees
  EXPECT_EQ(r.bbox_min.x, -1.0);
  EXPECT_EQ(r.bbox_min.z, -1.0);
  EXPECT_EQ(r.bbox_max.y, 1.0);
  EXPECT_NEAR(r.mean_edge_length, std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(r.min_edge_length, std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(r.max_edge_length, std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(r.total_area, 4 * std::sqrt(3.0), 1e-12);        // 8 equilateral faces of side sqrt 2
  EXPECT_NEAR(r.lo_quality_mean, std::sqrt(3.0) / 12, 1e-12);  // 0.1443
  EXPECT_NEAR(r.lo_quality_min, std::sqrt(3.0) / 12, 1e-12);
}

TEST(MeshReport, TorusHasGenusOne) {
  const MeshReport r = report_of(torus(12, 8));
  EXPECT_EQ(r.vertices, 96u);
  EXPECT_EQ(r.faces, 192u);
  EXPECT_EQ(r.edges, 288u);
  EXPECT_EQ(r.boundary_loops, 0u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.genus_per_component, std::vector<long>{1});
  // The inner ring of a torus has negative curvature: angle sums above 2 pi.
  EXPECT_GT(r.saddle_vertices, 0u);
}

TEST(MeshReport, HoleGivesTwoBoundaryLoops) {
  const MeshReport r = report_of_file(test_data_file("hole.obj"));
  EXPECT_EQ(r.faces, 16u);
  EXPECT_EQ(r.edges, 32u);
  EXPECT_EQ(r.boundary_edges, 16u);  // 12 outside, 4 around the hole
  EXPECT_EQ(r.boundary_loops, 2u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.genus_per_component, std::vector<long>{0});
  EXPECT_EQ(r.saddle_vertices, 0u);  // every vertex is on a boundary
  EXPECT_DOUBLE_EQ(r.total_area, 8.0);
  EXPECT_EQ(r.obtuse_faces, 0u);  // right triangles are not obtuse
}

TEST(MeshReport, TwoComponentsInOrderOfLowestFace) {
  const MeshReport r = report_of_file(test_data_file("two_components.obj"));
  EXPECT_EQ(r.components, 2u);
  EXPECT_EQ(r.genus_per_component, (std::vector<long>{0, 0}));
  EXPECT_EQ(r.boundary_loops, 1u);  // the square's rim; the tetrahedron is closed
  EXPECT_EQ(r.boundary_edges, 4u);
  EXPECT_EQ(r.edges, 6u + 5u);
  EXPECT_EQ(r.bbox_max.x, 6.0);
}

TEST(MeshReport, TorusAndSquareComponentsKeepTheirGenus) {
  // The torus comes first (lowest face), the square second.
  const TriangleMesh t = torus(6, 5);
  std::vector<Vec3> positions = t.positions();
  std::vector<Triangle> faces = t.faces();
  const auto base = static_cast<std::uint32_t>(positions.size());
  for (const Vec3& p : {Vec3{10, 0, 0}, Vec3{11, 0, 0}, Vec3{11, 1, 0}, Vec3{10, 1, 0}}) {
    positions.push_back(p);
  }
  faces.push_back({base, base + 1, base + 2});
  faces.push_back({base, base + 2, base + 3});
  const MeshReport r = report_of(TriangleMesh(std::move(positions), std::move(faces)));
  EXPECT_EQ(r.components, 2u);
  EXPECT_EQ(r.genus_per_component, (std::vector<long>{1, 0}));
  EXPECT_EQ(r.boundary_loops, 1u);
}

TEST(MeshReport, IsolatedVertexCountedButOutsideTheBox) {
  const MeshReport r = report_of_file(test_data_file("isolated_vertex.obj"));
  EXPECT_EQ(r.vertices, 5u);
  EXPECT_EQ(r.isolated_vertices, 1u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.genus_per_component, std::vector<long>{0});
  EXPECT_EQ(r.boundary_loops, 1u);
  EXPECT_EQ(r.bbox_max.x, 1.0);  // the isolated vertex at (5, 5, 5) is not on the surface
  EXPECT_EQ(r.bbox_max.z, 0.0);
}

TEST(MeshReport, NeedleAndCap) {
  const MeshReport r = report_of_file(test_data_file("needle.obj"));
  EXPECT_EQ(r.faces, 4u);
  EXPECT_EQ(r.degenerate_faces, 1u);  // the cap (zero area); the needle has area 1e-7
  EXPECT_EQ(r.thin_faces, 1u);        // the needle: height 1.4e-7 over its longest side of 1.41
  EXPECT_EQ(r.obtuse_faces, 2u);      // cap (180 degrees) and needle; faces 0, 1 are right
  EXPECT_EQ(r.saddle_vertices, 0u);   // vertex 2 is interior and flat: 90 + 90 + 180 degrees
  EXPECT_EQ(r.boundary_loops, 1u);
  EXPECT_EQ(r.genus_per_component, std::vector<long>{0});
  EXPECT_EQ(r.lo_quality_min, 0.0);
  // Areas come from edge lengths; for a needle whose long sides differ from half its base by
  // ~1e-14, length rounding costs a few digits: 1e-7 comes out within 0.2%.
  EXPECT_NEAR(r.total_area, 1.0 + 1e-7, 1e-9);
  EXPECT_GT(r.total_area, 1.0 + 0.9e-7);
  EXPECT_NEAR(r.min_edge_length, std::hypot(0.5000001, 0.4999999), 1e-12);  // needle's short sides
  EXPECT_EQ(r.max_edge_length, 2.0);                                        // the cap's long side
}

TEST(MeshReport, SaddleVertex) {
  // A centre vertex with six neighbours alternately above and below its plane: each angle at the
  // centre is acos(0.2) = 78.5 degrees, 471 degrees in all.
  std::vector<Vec3> positions = {{0, 0, 0}};
  for (int k = 0; k < 6; ++k) {
    const double a = k * std::numbers::pi / 3;
    positions.push_back({std::cos(a), std::sin(a), k % 2 ? -0.5 : 0.5});
  }
  std::vector<Triangle> faces;
  for (std::uint32_t k = 0; k < 6; ++k) faces.push_back({0, 1 + k, 1 + (k + 1) % 6});
  const TriangleMesh mesh(std::move(positions), std::move(faces));
  const IntrinsicGeometry geometry(mesh);
  EXPECT_NEAR(geometry.angle_sum(0), 6 * std::acos(0.2), 1e-12);
  const MeshReport r = compute_mesh_report(mesh, geometry);
  EXPECT_EQ(r.saddle_vertices, 1u);
  EXPECT_EQ(r.boundary_loops, 1u);
  EXPECT_EQ(r.boundary_edges, 6u);
}

TEST(MeshReport, ShippedMeshes) {
  const MeshReport spot = report_of_file(shipped_mesh_file("spot.obj"));
  EXPECT_EQ(spot.components, 1u);
  EXPECT_EQ(spot.genus_per_component, std::vector<long>{0});
  EXPECT_EQ(spot.boundary_loops, 0u);
  EXPECT_EQ(spot.edges, 8784u);  // closed genus 0: E = V + F - 2

  const MeshReport plane = report_of_file(shipped_mesh_file("plane_holes.obj"));
  EXPECT_EQ(plane.boundary_loops, 27u);
  EXPECT_EQ(plane.components, 1u);
  EXPECT_EQ(plane.genus_per_component, std::vector<long>{0});

  const MeshReport cheese = report_of_file(shipped_mesh_file("cheese.off"));
  EXPECT_EQ(cheese.components, 1u);
  EXPECT_EQ(cheese.boundary_loops, 0u);
  EXPECT_EQ(cheese.genus_per_component, std::vector<long>{133});

  const MeshReport dragon = report_of_file(shipped_mesh_file("ChineseDragon-10kv.off"));
  EXPECT_EQ(dragon.boundary_loops, 2u);
  EXPECT_EQ(dragon.genus_per_component, std::vector<long>{0});

  const MeshReport blade = report_of_file(shipped_mesh_file("blade.off"));
  EXPECT_EQ(blade.boundary_loops, 2u);
  EXPECT_EQ(blade.genus_per_component, std::vector<long>{0});
  EXPECT_LT(blade.lo_quality_mean, 0.05);  // poor triangulation (spot: 0.12)
  EXPECT_GT(spot.lo_quality_mean, 0.1);
}

TEST(MeshReport, FormatIsAlignedLabelValueLines) {
  const std::string text = format_mesh_report(report_of_file(test_data_file("two_components.obj")));
  EXPECT_NE(text.find("vertices: 8\n"), std::string::npos) << text;
  EXPECT_NE(text.find("faces: 6\n"), std::string::npos) << text;
  EXPECT_NE(text.find("boundary loops: 1\n"), std::string::npos) << text;
  EXPECT_NE(text.find("components: 2\n"), std::string::npos) << text;
  EXPECT_NE(text.find("genus: 0 0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("Lo quality: "), std::string::npos) << text;
  // Every line has its colon in the same column.
  std::istringstream lines(text);
  std::string line;
  std::size_t colon = std::string::npos;
  int count = 0;
  while (std::getline(lines, line)) {
    ++count;
    const std::size_t at = line.find(": ");
    ASSERT_NE(at, std::string::npos) << line;
    if (colon == std::string::npos) colon = at;
    EXPECT_EQ(at, colon) << line;
  }
  EXPECT_GE(count, 15);
  EXPECT_EQ(text.back(), '\n');
}

}  // namespace
}  // namespace geoprox
