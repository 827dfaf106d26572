#include "core/mesh/mesh_repair.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh_io.h"
#include "core/mesh/mesh_report.h"
#include "tests/core/test_support.h"

namespace geoprox {
namespace {

using test_support::corpus_dir;
using test_support::corpus_mesh_file;
using test_support::corpus_skip_reason;
using test_support::shipped_mesh_file;
using test_support::test_data_file;

/// Repairs the soup and checks what every repair promises: the result loads, input vertices
/// keep their positions and ids, copies sit where their vertex is, faces keep their order and
/// corners (up to the recorded turn and the vertex copies). Returns the repaired mesh.
RepairedMesh repair_and_check(const MeshSoup& soup, const MeshRepairOptions& options = {}) {
  RepairedMesh r = repair_mesh(soup.positions, soup.faces, options);
  EXPECT_NO_THROW(TriangleMesh(r.positions, r.faces));
  EXPECT_EQ(r.positions.size(), r.report.vertices_out);
  EXPECT_EQ(r.faces.size(), r.report.faces_out);
  EXPECT_EQ(r.report.vertices_out, r.report.vertices_in + r.report.vertices_added);
  EXPECT_EQ(r.report.faces_out + r.report.degenerate_faces_dropped +
                r.report.duplicate_faces_dropped,
            r.report.faces_in);
  EXPECT_EQ(r.source_vertex.size(), r.positions.size());
  for (std::uint32_t v = 0; v < r.positions.size(); ++v) {
    if (v < soup.positions.size()) {
      EXPECT_EQ(r.source_vertex[v], v);
    } else {
      EXPECT_LT(r.source_vertex[v], soup.positions.size());
    }
    const Vec3& p = r.positions[v];
    const Vec3& q = soup.positions[r.source_vertex[v]];
    EXPECT_TRUE(p.x == q.x && p.y == q.y && p.z == q.z) << "vertex " << v << " moved";
  }
  EXPECT_TRUE(std::is_sorted(r.source_face.begin(), r.source_face.end()));
  for (std::size_t f = 0; f < r.faces.size(); ++f) {
    Triangle input = soup.faces[r.source_face[f]];
    if (r.flipped[f]) std::swap(input[1], input[2]);
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(r.source_vertex[r.faces[f][i]], input[i]) << "face " << f << " corner " << i;
    }
  }
  return r;
}

TEST(MeshRepair, LeavesAManifoldMeshAsItIs) {
  const MeshSoup soup = load_mesh_soup(shipped_mesh_file("spot.obj"));
  const RepairedMesh r = repair_and_check(soup);
  EXPECT_TRUE(r.report.unchanged());
  EXPECT_EQ(r.faces, soup.faces);
  EXPECT_EQ(r.report.vertices_added, 0u);
  std::vector<std::uint32_t> identity(soup.faces.size());
  std::iota(identity.begin(), identity.end(), 0u);
  EXPECT_EQ(r.source_face, identity);
}

TEST(MeshRepair, SplitsABowtieVertex) {
  // Two triangles that share only vertex 0.
  const MeshSoup soup = load_mesh_soup(test_data_file("bowtie.obj"));
  const RepairedMesh r = repair_and_check(soup);
  EXPECT_EQ(r.report.vertices_split, 1u);
  EXPECT_EQ(r.report.vertices_added, 1u);
  // The fan of the lowest face keeps vertex 0; the other gets the copy, vertex 5.
  EXPECT_EQ(r.faces[0], (Triangle{0, 1, 2}));
  EXPECT_EQ(r.faces[1], (Triangle{5, 3, 4}));
  EXPECT_EQ(r.source_vertex[5], 0u);
  const TriangleMesh mesh(r.positions, r.faces);
  EXPECT_EQ(compute_mesh_report(mesh, IntrinsicGeometry(mesh)).components, 2u);
}

TEST(MeshRepair, TurnsAFaceRoundToAgreeWithTheLowestFace) {
  // A unit square whose second triangle runs the diagonal the same way as the first.
  const MeshSoup soup = load_mesh_soup(test_data_file("flipped_face.obj"));
  const RepairedMesh r = repair_and_check(soup);
  EXPECT_EQ(r.report.faces_flipped, 1u);
  EXPECT_EQ(r.report.edges_cut, 0u);
  EXPECT_EQ(r.flipped, (std::vector<std::uint8_t>{0, 1}));
  EXPECT_EQ(r.faces[1], (Triangle{2, 3, 0}));
  // Joined across the diagonal: the geodesic between opposite corners 1 and 3 is the
  // straight line (sqrt 2), not the way round the boundary (2).
  const TriangleMesh mesh(r.positions, r.faces);
  const IntrinsicGeometry geometry(mesh);
  EXPECT_NEAR(exact_geodesic_distances(mesh, geometry, std::vector<GeodesicSource>{
                                                          {SurfacePoint::vertex(1), 0.0}})[3],
              std::sqrt(2.0), 1e-12);

  // Without orienting, the square is cut along its diagonal instead.
  MeshRepairOptions keep_orientation;
  keep_orientation.orient = false;
  const RepairedMesh cut = repair_and_check(soup, keep_orientation);
  EXPECT_EQ(cut.report.faces_flipped, 0u);
  EXPECT_EQ(cut.report.edges_cut, 1u);
  EXPECT_EQ(cut.report.vertices_added, 2u);  // the diagonal's two ends
  EXPECT_EQ(cut.faces[0], soup.faces[0]);
}

TEST(MeshRepair, CutsAnEdgeWithThreeFaces) {
  // Three triangles on the edge 0-1: each keeps its own copy of it.
  const MeshSoup soup = load_mesh_soup(test_data_file("nonmanifold_edge.obj"));
  const RepairedMesh r = repair_and_check(soup);
  EXPECT_EQ(r.report.edges_cut, 1u);
  EXPECT_EQ(r.report.vertices_split, 2u);
  EXPECT_EQ(r.report.vertices_added, 4u);
  EXPECT_EQ(r.report.faces_flipped, 0u);  // a cut edge joins nothing, so orients nothing
  const TriangleMesh mesh(r.positions, r.faces);
  const MeshReport report = compute_mesh_report(mesh, IntrinsicGeometry(mesh));
  EXPECT_EQ(report.components, 3u);
  EXPECT_EQ(report.boundary_edges, 9u);
}

TEST(MeshRepair, DropsRepeatedAndDegenerateFaces) {
  const MeshSoup soup{{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}},
                      {{0, 1, 2}, {0, 2, 3}, {1, 2, 0}, {0, 0, 3}, {2, 1, 0}, {3, 2, 0}},
                      {},
                      6};
  const RepairedMesh r = repair_and_check(soup);
  EXPECT_EQ(r.report.degenerate_faces_dropped, 1u);  // (0 0 3)
  EXPECT_EQ(r.report.duplicate_faces_dropped, 3u);   // a rotation and two turned copies
  EXPECT_EQ(r.source_face, (std::vector<std::uint32_t>{0, 1}));
  EXPECT_EQ(r.faces, (std::vector<Triangle>{{0, 1, 2}, {0, 2, 3}}));
}

TEST(MeshRepair, KeepsAClosedSurfaceOfTwoFaces) {
  // A triangle and its reverse, alone on their edges: a closed surface (a flat pillow), which
  // loads. Beside a square it stays; the same reverse laid on the square's first face goes.
  const MeshSoup soup{{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {5, 0, 0}, {6, 0, 0}, {5, 1, 0}},
                      {{0, 1, 2}, {0, 2, 3}, {4, 5, 6}, {4, 6, 5}},
                      {},
                      4};
  EXPECT_NO_THROW(TriangleMesh(soup.positions, soup.faces));
  const RepairedMesh pillow = repair_and_check(soup);
  EXPECT_TRUE(pillow.report.unchanged());
  EXPECT_EQ(pillow.faces, soup.faces);
  MeshSoup doubled = soup;
  doubled.faces.push_back({0, 2, 1});
  EXPECT_THROW(TriangleMesh(doubled.positions, doubled.faces), MeshError);
  const RepairedMesh r = repair_and_check(doubled);
  EXPECT_EQ(r.report.duplicate_faces_dropped, 1u);
  EXPECT_EQ(r.faces, soup.faces);
}

// A band of `n` quads (two triangles each) around a circle, given a half twist: a Moebius strip.
MeshSoup moebius_strip(int n) {
  MeshSoup soup;
  constexpr double kPi = 3.14159265358979323846;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * kPi * i / n;
    for (double s : {-0.3, 0.3}) {
      const double r = 1 + s * std::cos(a / 2);
      soup.positions.push_back({r * std::cos(a), r * std::sin(a), s * std::sin(a / 2)});
    }
  }
  for (int i = 0; i < n; ++i) {
    const auto lo = static_cast<std::uint32_t>(2 * i), hi = lo + 1;
    // The last quad closes the band onto the first column the other way up.
    const bool closing = i == n - 1;
    const std::uint32_t nlo = closing ? 1u : lo + 2, nhi = closing ? 0u : hi + 2;
    soup.faces.push_back({lo, nlo, nhi});
    soup.faces.push_back({lo, nhi, hi});
  }
  return soup;
}

TEST(MeshRepair, CutsAMoebiusStripOnceAndKeepsItInOnePiece) {
  const MeshSoup soup = moebius_strip(24);
  EXPECT_THROW(TriangleMesh(soup.positions, soup.faces), MeshError);
  const RepairedMesh r = repair_and_check(soup);
  EXPECT_EQ(r.report.edges_cut, 1u);
  const TriangleMesh mesh(r.positions, r.faces);
  const IntrinsicGeometry geometry(mesh);
  const MeshReport report = compute_mesh_report(mesh, geometry);
  EXPECT_EQ(report.components, 1u);  // a band cut across once is one strip
  EXPECT_EQ(report.boundary_loops, 1u);
  const std::vector<double> d = exact_geodesic_distances(
      mesh, geometry, std::vector<GeodesicSource>{{SurfacePoint::vertex(0), 0.0}});
  for (std::size_t v = 0; v < d.size(); ++v) EXPECT_TRUE(std::isfinite(d[v])) << "vertex " << v;
}

TEST(MeshRepair, OrientsAProjectivePlaneByCuttingIt) {
  // The six-vertex projective plane: closed and non-orientable. The cuts that orientation
  // needs part every fan they open (two cuts at each vertex they touch), so no two faces are
  // left running an edge the same way.
  MeshSoup soup;
  for (int i = 0; i < 6; ++i) {
    const double a = 1.1 * i;
    soup.positions.push_back({std::cos(a), std::sin(a), 0.3 * i - 0.7});
  }
  soup.faces = {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 5}, {0, 5, 1},
                {1, 2, 4}, {2, 3, 5}, {3, 4, 1}, {4, 5, 2}, {5, 1, 3}};
  EXPECT_THROW(TriangleMesh(soup.positions, soup.faces), MeshError);
  const RepairedMesh r = repair_and_check(soup);
  EXPECT_GE(r.report.edges_cut, 1u);
  EXPECT_GE(r.report.vertices_split, 1u);
  EXPECT_EQ(r.report.faces_out, 10u);
}

// A torus or an open grid of a x b quads, then up to five random edits: a face turned round, a
// face repeated, a face repeated reversed, two vertices glued into one, a face removed.
MeshSoup damaged_grid(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const auto a = static_cast<std::uint32_t>(3 + rng() % 5),
             b = static_cast<std::uint32_t>(3 + rng() % 5);
  const bool closed = rng() % 2 == 0;
  constexpr double kTwoPi = 6.283185307179586;
  MeshSoup soup;
  for (std::uint32_t j = 0; j < b; ++j) {
    for (std::uint32_t i = 0; i < a; ++i) {
      const double u = kTwoPi * i / a, v = kTwoPi * j / b;
      soup.positions.push_back(closed ? Vec3{(2 + std::cos(v)) * std::cos(u),
                                             (2 + std::cos(v)) * std::sin(u), std::sin(v)}
                                      : Vec3{double(i), double(j), 0.1 * ((7 * i + 3 * j) % 5)});
    }
  }
  for (std::uint32_t j = 0; j < (closed ? b : b - 1); ++j) {
    for (std::uint32_t i = 0; i < (closed ? a : a - 1); ++i) {
      const std::uint32_t p = j * a + i, q = j * a + (i + 1) % a;
      const std::uint32_t r = (j + 1) % b * a + (i + 1) % a, t = (j + 1) % b * a + i;
      soup.faces.push_back({p, q, r});
      soup.faces.push_back({p, r, t});
    }
  }
  const auto pick = [&rng](std::size_t n) { return static_cast<std::size_t>(rng() % n); };
  for (int k = 0, edits = static_cast<int>(rng() % 6); k < edits; ++k) {
    std::vector<Triangle>& faces = soup.faces;
    switch (rng() % 5) {
      case 0: {
        Triangle& t = faces[pick(faces.size())];
        std::swap(t[1], t[2]);
        break;
      }
      case 1: faces.push_back(faces[pick(faces.size())]); break;
      case 2: {
        Triangle t = faces[pick(faces.size())];
        std::swap(t[0], t[1]);
        faces.push_back(t);
        break;
      }
      case 3: {
        const auto keep = static_cast<std::uint32_t>(pick(a * b));
        const auto gone = static_cast<std::uint32_t>(pick(a * b));
        for (Triangle& t : faces) std::replace(t.begin(), t.end(), gone, keep);
        break;
      }
      default:
        if (faces.size() > 2)
          faces.erase(faces.begin() + static_cast<std::ptrdiff_t>(pick(faces.size())));
    }
  }
  return soup;
}

TEST(MeshRepair, DamagedGridsAndToriLoadAfterRepair) {
  // 3000 damaged meshes (100,000 passed the same checks once): whatever the damage, the
  // repaired mesh loads (repair_and_check) and an exact solve runs on it; a mesh that loaded
  // as it was comes out unchanged.
  std::size_t loaded_as_they_were = 0;
  for (std::uint64_t seed = 1; seed <= 3000; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const MeshSoup soup = damaged_grid(seed);
    bool loads = true;
    try {
      TriangleMesh(soup.positions, soup.faces);
    } catch (const MeshError&) {
      loads = false;
    }
    MeshRepairOptions options;
    options.orient = seed % 4 != 0;
    const RepairedMesh r = repair_and_check(soup, options);
    if (loads) {
      ++loaded_as_they_were;
      EXPECT_TRUE(r.report.unchanged());
      EXPECT_EQ(r.faces, soup.faces);
    }
    if (r.faces.empty()) continue;
    const TriangleMesh mesh(r.positions, r.faces);
    const IntrinsicGeometry geometry(mesh);
    ExactGeodesicSolver solver(mesh, geometry);
    solver.solve(SurfacePoint::vertex(r.faces[0][0]));
    EXPECT_EQ(solver.distance(r.faces[0][0]), 0.0);
  }
  // Both kinds are there: meshes the edits left valid, and damaged ones.
  EXPECT_GT(loaded_as_they_were, 300u);
  EXPECT_LT(loaded_as_they_were, 2700u);
}

TEST(MeshRepair, DescribesWhatChangedInOneLine) {
  MeshRepairReport report;
  EXPECT_EQ(describe_repair_changes(report), "nothing changed");
  report.duplicate_faces_dropped = 3;
  report.edges_cut = 2;
  report.vertices_split = 5;
  report.vertices_added = 5;
  EXPECT_EQ(describe_repair_changes(report),
            "3 duplicate faces dropped, 2 edges cut, 5 vertices split (+5 copies)");
  report = {};
  report.degenerate_faces_dropped = 1;
  report.faces_flipped = 1;
  report.vertices_split = 1;
  report.vertices_added = 2;
  EXPECT_EQ(describe_repair_changes(report),
            "1 degenerate face dropped, 1 face flipped, 1 vertex split (+2 copies)");
}

TEST(MeshRepair, FixesTheManifoldReasonsOnly) {
  for (ErrorCode code : {ErrorCode::NonManifoldVertex, ErrorCode::NonManifoldEdge,
                         ErrorCode::InconsistentOrientation, ErrorCode::DegenerateFaceIndices}) {
    EXPECT_TRUE(repair_fixes(code)) << error_code_name(code);
  }
  for (ErrorCode code : {ErrorCode::EmptyMesh, ErrorCode::NonFiniteCoordinate,
                         ErrorCode::VertexOutOfRange, ErrorCode::TooLarge}) {
    EXPECT_FALSE(repair_fixes(code)) << error_code_name(code);
  }
}

TEST(MeshRepair, RefusesWhatIsNoMesh) {
  EXPECT_THROW(repair_mesh({{0, 0, 0}}, {}), MeshError);
  EXPECT_THROW(repair_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 3}}), MeshError);
}

TEST(MeshRepair, RepairsTheDirtyMeshesSoThatTheyLoad) {
  // pig.stl is shipped; the others are not redistributable: they are in the optional corpus only.
  for (const char* name : {"teapot.obj", "truck.obj", "happy-buddha-dirty.ply"}) {
    if (!corpus_mesh_file(name)) GTEST_SKIP() << corpus_skip_reason(name);
  }
  const std::string shared = corpus_dir();
  struct Case {
    std::string path;
    std::size_t duplicates, flipped, split;
  };
  // The counts as repaired on 2026-11-27. Of the 1650 duplicates the README counts in
  // happy-buddha, two are a face and its reverse alone on their edges, and stay.
  for (const Case& c : {Case{shipped_mesh_file("pig.stl"), 0, 0, 421},
                        Case{shared + "/teapot.obj", 0, 0, 38},
                        Case{shared + "/truck.obj", 0, 729, 119},
                        Case{shared + "/happy-buddha-dirty.ply", 1648, 62, 3240}}) {
    SCOPED_TRACE(c.path);
    EXPECT_THROW(load_mesh(c.path), MeshError);
    const MeshSoup soup = load_mesh_soup(c.path);
    const RepairedMesh r = repair_and_check(soup);
    EXPECT_EQ(r.report.duplicate_faces_dropped, c.duplicates);
    EXPECT_EQ(r.report.faces_flipped, c.flipped);
    EXPECT_EQ(r.report.vertices_split, c.split);
    // Exact geodesics run on the result: both ways along a side of a face in the middle of
    // the file, the side itself.
    const TriangleMesh mesh(r.positions, r.faces);
    const IntrinsicGeometry geometry(mesh);
    const Triangle& t = mesh.face(static_cast<std::uint32_t>(mesh.num_faces() / 2));
    ExactGeodesicSolver solver(mesh, geometry);
    solver.solve(SurfacePoint::vertex(t[0]));
    const std::vector<double> from_a = solver.vertex_distances();
    solver.solve(SurfacePoint::vertex(t[1]));
    const double side = norm(mesh.position(t[0]) - mesh.position(t[1]));
    EXPECT_NEAR(from_a[t[1]], side, 1e-9 * side);  // no path is shorter than the chord
    EXPECT_NEAR(solver.distance(t[0]), side, 1e-9 * side);
  }
}

}  // namespace
}  // namespace geoprox
