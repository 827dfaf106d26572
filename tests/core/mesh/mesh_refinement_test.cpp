// Tests of core/mesh/mesh_refinement.h: no edge left longer than the limit; the same surface (area,
// every part's corners where its barycentrics in its input face say, every new vertex where its
// input point says, exact geodesic distances between the same points equal on both meshes);
// ids kept; angles of each part at least half the smallest of its input face; a mesh with no
// long edge comes back unchanged; points carried over; bad options.
#include "core/mesh/mesh_refinement.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "tests/core/test_meshes.h"
#include "tests/core/test_support.h"

namespace geoprox {
namespace {

using namespace test_meshes;
using test_support::fmt;
using test_support::spot;

double longest_edge(const std::vector<Vec3>& positions, const std::vector<Triangle>& faces) {
  double longest = 0;
  for (const Triangle& t : faces) {
    for (int k = 0; k < 3; ++k)
      longest = std::max(longest, dist(positions[t[k]], positions[t[(k + 1) % 3]]));
  }
  return longest;
}

bool same_position(const Vec3& a, const Vec3& b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

double area(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 u = b - a, v = c - a;
  return 0.5 * norm(Vec3{u.y * v.z - u.z * v.y, u.z * v.x - u.x * v.z, u.x * v.y - u.y * v.x});
}

double smallest_angle(const Vec3& a, const Vec3& b, const Vec3& c) {
  double smallest = std::numbers::pi;
  const Vec3 p[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) {
    const Vec3 u = p[(k + 1) % 3] - p[k], v = p[(k + 2) % 3] - p[k];
    const double cosine = (u.x * v.x + u.y * v.y + u.z * v.z) / (norm(u) * norm(v));
    smallest = std::min(smallest, std::acos(std::clamp(cosine, -1.0, 1.0)));
  }
  return smallest;
}

/// Everything a refinement must keep, on `input` refined to edges of at most `limit`.
RefinedMesh check_refinement(const TriangleMesh& input, double limit, const std::string& what,
                             bool check_angles = true) {
  SCOPED_TRACE(what);
  const RefinedMesh r = refine_long_edges(input, {.max_edge_length = limit});
  const TriangleMesh refined(r.positions, r.faces);  // loads: conforming and oriented
  EXPECT_LE(longest_edge(r.positions, r.faces), limit);
  EXPECT_EQ(r.input_vertices, input.num_vertices());
  EXPECT_EQ(r.input_faces, input.num_faces());
  EXPECT_EQ(r.new_vertex_source.size(), r.positions.size() - input.num_vertices());
  EXPECT_EQ(r.source_face.size(), r.faces.size());
  const double scale = longest_edge(input.positions(), input.faces());
  std::uint32_t moved = 0;
  for (std::uint32_t v = 0; v < input.num_vertices(); ++v) {
    moved += !same_position(r.positions[v], input.position(v));
  }
  EXPECT_EQ(moved, 0u) << "input vertices moved";
  // Every new vertex is where its input point is.
  for (std::size_t k = 0; k < r.new_vertex_source.size(); ++k) {
    const Vec3 at = r.new_vertex_source[k].position(input);
    EXPECT_LE(dist(at, r.positions[input.num_vertices() + k]), 1e-12 * scale)
        << "vertex " << input.num_vertices() + k << " at " << r.new_vertex_source[k].to_string();
  }
  // Every part's corners are where its barycentrics in its input face say; the parts of each
  // input face add up to its area; a face not split is the input's face with its id.
  std::vector<double> parts_area(input.num_faces(), 0);
  std::vector<double> smallest_part_angle(input.num_faces(), std::numbers::pi);
  for (std::uint32_t f = 0; f < r.faces.size(); ++f) {
    const std::uint32_t g = r.source_face[f];
    if (g >= input.num_faces()) {
      ADD_FAILURE() << "face " << f << " has source " << g;
      continue;
    }
    if (f < input.num_faces()) {
      EXPECT_EQ(g, f) << "face " << f << " lost its id";
    }
    const Triangle& t = r.faces[f];
    for (int k = 0; k < 3; ++k) {
      EXPECT_LE(dist(input.face_point(g, r.source_bary[f][k]), r.positions[t[k]]), 1e-12 * scale)
          << "face " << f << " corner " << k;
    }
    parts_area[g] += area(r.positions[t[0]], r.positions[t[1]], r.positions[t[2]]);
    smallest_part_angle[g] =
        std::min(smallest_part_angle[g],
                 smallest_angle(r.positions[t[0]], r.positions[t[1]], r.positions[t[2]]));
  }
  int failures = 0;
  for (std::uint32_t g = 0; g < input.num_faces(); ++g) {
    const Triangle& t = input.face(g);
    const Vec3 &a = input.position(t[0]), &b = input.position(t[1]), &c = input.position(t[2]);
    if (std::abs(parts_area[g] - area(a, b, c)) > 1e-9 * area(a, b, c) + 1e-15 * scale * scale &&
        ++failures <= 5) {
      ADD_FAILURE() << "face " << g << ": parts of area " << fmt(parts_area[g]) << ", face "
                    << fmt(area(a, b, c));
    }
    // Longest-edge bisection never makes a part much thinner than its face (half its angle).
    if (check_angles && smallest_part_angle[g] < 0.5 * smallest_angle(a, b, c) * (1 - 1e-9) &&
        ++failures <= 5) {
      ADD_FAILURE() << "face " << g << ": a part's angle " << fmt(smallest_part_angle[g])
                    << " against the face's " << fmt(smallest_angle(a, b, c));
    }
  }
  EXPECT_EQ(failures, 0);
  return r;
}

TEST(MeshRefinement, LongFacedStripIsSplitOnlyWhereLong) {
  const TestMesh m = make_test_mesh(long_faced_strip());
  const RefinedMesh r = check_refinement(*m.mesh, 0.3, "strip");
  EXPECT_GT(r.faces.size(), m.mesh->num_faces());
  // The 10 x 10 grid's faces (edges 0.1 and 0.141) are not split: the first 200 faces keep
  // their corners, except those beside the long faces, which conformity may split.
  std::size_t grid_faces_kept = 0;
  for (std::uint32_t f = 0; f < 200; ++f) grid_faces_kept += r.faces[f] == m.mesh->face(f);
  EXPECT_GE(grid_faces_kept, 180u);
}

TEST(MeshRefinement, SameSurfaceOnSpotAndACube) {
  const TestMesh& s = spot();
  const double mean = s.geometry->mean_edge_length();
  check_refinement(*s.mesh, 1.5 * mean, "spot, 1.5 mean edges");
  check_refinement(*s.mesh, 0.7 * mean, "spot, 0.7 mean edges");
  const Cube cube = cube_surface(3, 1.0);
  const TestMesh c = make_test_mesh(cube.data);
  check_refinement(*c.mesh, 0.1, "cube");
}

TEST(MeshRefinement, ExactDistancesAreTheSameOnBothMeshes) {
  // The same surface, so the same geodesic distance between the same points, whichever of
  // the two triangulations carries it.
  for (const auto& [name, mesh_data, limit] :
       {std::tuple<const char*, MeshData, double>{"strip", long_faced_strip(), 0.3},
        {"cube", cube_surface(3, 1.0).data, 0.1},
        {"bumps", ugly_bumps(3, 6), 0.05}}) {
    SCOPED_TRACE(name);
    const TestMesh m = make_test_mesh(mesh_data);
    const RefinedMesh r = refine_long_edges(*m.mesh, {.max_edge_length = limit});
    const TestMesh refined = make_test_mesh({r.positions, r.faces, {}});
    ASSERT_GT(refined.mesh->num_faces(), m.mesh->num_faces());
    Rng rng(11);
    // Face points, vertices and points on edges, in turn.
    auto any = [&](std::uint32_t k) {
      const auto faces = static_cast<std::uint32_t>(m.mesh->num_faces());
      if (k % 3 == 1)
        return SurfacePoint::vertex(rng.below(static_cast<std::uint32_t>(m.mesh->num_vertices())));
      if (k % 3 == 2)
        return SurfacePoint::edge(rng.below(static_cast<std::uint32_t>(m.mesh->num_edges())),
                                  rng.uniform());
      const auto b = rng.barycentrics(1e-3);
      return SurfacePoint::face(rng.below(faces), b[0], b[1], b[2]);
    };
    ExactGeodesicSolver on_input(*m.mesh, *m.geometry);
    ExactGeodesicSolver on_refined(*refined.mesh, *refined.geometry);
    for (std::uint32_t k = 0; k < 6; ++k) {
      const SurfacePoint s = any(k);
      const SurfacePoint s2 = r.to_refined(*m.mesh, s);
      EXPECT_LE(dist(s.position(*m.mesh), s2.position(*refined.mesh)), 1e-12)
          << s.to_string() << " -> " << s2.to_string();
      on_input.solve(s);
      on_refined.solve(s2);
      for (std::uint32_t j = 0; j < 20; ++j) {
        const SurfacePoint t = any(k + j + 1);
        const SurfacePoint t2 = r.to_refined(*m.mesh, t);
        const double a = on_input.distance(t), b = on_refined.distance(t2);
        EXPECT_LE(std::abs(a - b), 1e-9 * std::max(a, 1.0))
            << s.to_string() << " to " << t.to_string() << ": " << fmt(a) << " on the input, "
            << fmt(b) << " refined";
      }
    }
  }
}

TEST(MeshRefinement, ClosedTwoFaceSurface) {
  // Two faces over the same three vertices, either way round (a closed surface that loads):
  // split across their long sides as usual, both would draw their inner edges between the same
  // vertices. They are fanned around their centroids instead (found by the mesh_io fuzzer).
  MeshData d;
  d.positions = {{2, 1, 0}, {3, 1, 0}, {0, 2, 0}};
  d.faces = {{0, 1, 2}, {0, 2, 1}};
  const TestMesh m = make_test_mesh(d);
  for (double limit : {1.6, 0.5, 0.2}) {
    const RefinedMesh r =
        check_refinement(*m.mesh, limit, "two-face surface, limit " + fmt(limit), false);
    EXPECT_GT(r.faces.size(), 2u);
  }
}

TEST(MeshRefinement, NothingLongNothingChanges) {
  const TestMesh& s = spot();
  const RefinedMesh r = refine_long_edges(*s.mesh, {.max_edge_length = 1.0});
  EXPECT_EQ(r.rounds, 0u);
  EXPECT_EQ(r.edges_split, 0u);
  ASSERT_EQ(r.positions.size(), s.mesh->num_vertices());
  for (std::uint32_t v = 0; v < s.mesh->num_vertices(); ++v) {
    ASSERT_TRUE(same_position(r.positions[v], s.mesh->position(v))) << v;
  }
  EXPECT_EQ(r.faces, s.mesh->faces());
  // Points stay what they are (a vertex, or the same face point).
  EXPECT_EQ(r.to_refined(*s.mesh, SurfacePoint::vertex(7)).to_string(), "v:7");
  const SurfacePoint f = r.to_refined(*s.mesh, SurfacePoint::face(12, 0.25, 0.25, 0.5));
  EXPECT_EQ(f.kind, SurfacePoint::Kind::Face);
  EXPECT_EQ(f.id, 12u);
  EXPECT_NEAR(f.bary[2], 0.5, 1e-15);
}

TEST(MeshRefinement, RefusesBadOptions) {
  const TestMesh m = make_test_mesh(long_faced_strip());
  auto reason = [&](const MeshRefinementOptions& options) {
    try {
      refine_long_edges(*m.mesh, options);
    } catch (const InvalidInput& e) {
      return e.reason();
    }
    return std::string("accepted");
  };
  EXPECT_EQ(reason({.max_edge_length = 0}), "BadOption");
  EXPECT_EQ(reason({.max_edge_length = -1}), "BadOption");
  EXPECT_EQ(reason({.max_edge_length = std::nan("")}), "BadOption");
  EXPECT_EQ(reason({.max_edge_length = kInfinity}), "BadOption");
  EXPECT_EQ(reason({.max_edge_length = 1e-3, .max_faces = 10000}), "RefinementTooLarge");
  EXPECT_EQ(reason({.max_edge_length = 0.3}), "accepted");
}

}  // namespace
}  // namespace geoprox
