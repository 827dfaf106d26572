// Tests of core/mesh/closest_point.h: agreement with an independent brute force over every face
// (jittered flat grid, cube surface, spot.obj), bitwise independence from the leaf size (leaf
// size F is the plain loop over all faces), points on the surface and vertices snapping to
// themselves, feet of perpendiculars, corners and boundary edges, exact ties going to the lowest
// face id, zero-area faces (collinear and coincident corners), slivers, isolated vertices,
// refused positions and options, and concurrent queries.
#include "core/mesh/closest_point.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "core/base/errors.h"
#include "core/mesh/mesh_io.h"
#include "tests/core/test_meshes.h"
#include "tests/core/test_support.h"

namespace geoprox {
namespace {

using namespace test_meshes;
using test_support::fmt;

constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------------------------
// Independent reference: per face, the orthogonal projection when it falls inside (barycentrics
// from the 2x2 normal equations) and the closest point of each edge; the minimum over all faces.

Vec3 closest_on_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 e = b - a;
  const double ee = dot(e, e);
  const double t = ee > 0 ? std::clamp(dot(p - a, e) / ee, 0.0, 1.0) : 0.0;
  return a + t * e;
}

double reference_face_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  double best = std::min({dist(p, closest_on_segment(p, a, b)),
                          dist(p, closest_on_segment(p, b, c)),
                          dist(p, closest_on_segment(p, c, a))});
  const Vec3 ab = b - a, ac = c - a;
  const Vec3 n = cross(ab, ac);
  const double nn = dot(n, n);
  if (nn > 0) {
    const Vec3 q = p - (dot(p - a, n) / nn) * n;
    const Vec3 aq = q - a;
    const double d00 = dot(ab, ab), d01 = dot(ab, ac), d11 = dot(ac, ac);
    const double d20 = dot(aq, ab), d21 = dot(aq, ac);
    const double det = d00 * d11 - d01 * d01;
    const double s = (d11 * d20 - d01 * d21) / det;
    const double t = (d00 * d21 - d01 * d20) / det;
    if (s >= 0 && t >= 0 && s + t <= 1) best = std::min(best, dist(p, q));
  }
  return best;
}

struct Reference {
  double distance = kInf;
  std::uint32_t face = 0;
};

Reference brute_force(const TriangleMesh& mesh, const Vec3& p) {
  Reference r;
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
    const Triangle& t = mesh.face(f);
    const double d = reference_face_distance(p, mesh.position(t[0]), mesh.position(t[1]),
                                             mesh.position(t[2]));
    if (d < r.distance) r = {d, f};
  }
  return r;
}

/// Kinds of answers seen, so that tests can check they exercised vertices, edges and interiors.
struct Coverage {
  int vertex = 0;
  int edge = 0;      ///< Kind::Face with one zero barycentric
  int interior = 0;  ///< Kind::Face with three positive barycentrics
  int mismatches = 0;
  std::string first_mismatch;
};

/// Checks one answer against the brute force and the result's own invariants: the point exists
/// on the mesh, sits at `position`, is `distance` away, and no face is closer (tolerance `tol`).
void check_against_brute_force(const TriangleMesh& mesh, const ClosestPointIndex& index,
                               const Vec3& query, double tol, Coverage& coverage) {
  const ClosestPointResult r = index.closest(query);
  const Reference ref = brute_force(mesh, query);
  std::string problem;
  try {
    r.point.validate(mesh);
  } catch (const Error& e) {
    problem += std::string(" invalid point: ") + e.what() + ";";
  }
  if (problem.empty()) {
    if (dist(r.point.position(mesh), r.position) > tol) problem += " point/position differ;";
    if (r.point.kind == SurfacePoint::Kind::Face) {
      const auto& b = r.point.bary;
      if (b[0] < 0 || b[1] < 0 || b[2] < 0) problem += " negative barycentric;";
      if (std::abs(b[0] + b[1] + b[2] - 1) > 1e-12) problem += " barycentrics do not sum to 1;";
      if (b[0] == 1 || b[1] == 1 || b[2] == 1) problem += " corner reported as a face point;";
      const int zeros = (b[0] == 0) + (b[1] == 0) + (b[2] == 0);
      (zeros == 0 ? coverage.interior : coverage.edge) += 1;
    } else if (r.point.kind == SurfacePoint::Kind::Vertex) {
      coverage.vertex += 1;
    } else {
      problem += " edge kind returned;";
    }
  }
  if (std::abs(r.distance - dist(query, r.position)) > 1e-15 * (1 + r.distance)) {
    problem += " distance is not |query - position|;";
  }
  if (!(std::abs(r.distance - ref.distance) <= tol)) {
    problem += " distance " + fmt(r.distance) + " vs brute force " + fmt(ref.distance) +
               " (face " + std::to_string(ref.face) + ");";
  }
  if (!problem.empty()) {
    if (coverage.mismatches++ == 0) {
      coverage.first_mismatch = "query (" + fmt(query.x) + ", " + fmt(query.y) + ", " +
                                fmt(query.z) + ") -> " + r.point.to_string() + ":" + problem;
    }
  }
}

void print_coverage(const char* mesh, const Coverage& c) {
  std::printf("%s: %d vertex, %d edge, %d interior answers\n", mesh, c.vertex, c.edge, c.interior);
}

Vec3 random_in_box(Rng& rng, const Vec3& lo, const Vec3& hi) {
  return {rng.uniform(lo.x, hi.x), rng.uniform(lo.y, hi.y), rng.uniform(lo.z, hi.z)};
}

Vec3 random_unit(Rng& rng) {
  for (;;) {
    const Vec3 v{rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)};
    const double n = norm(v);
    if (n > 0.1 && n <= 1) return (1.0 / n) * v;
  }
}

std::pair<Vec3, Vec3> bounds(const TriangleMesh& mesh) {
  Vec3 lo = mesh.position(0), hi = lo;
  for (const Vec3& p : mesh.positions()) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  return {lo, hi};
}

/// spot.obj from the repository (shipped in data/meshes), loaded once.
const TriangleMesh* spot() {
  static const TriangleMesh* cached = [] {
    const std::string path = std::string(GEOPROX_SOURCE_DIR) + "/data/meshes/spot.obj";
    if (!std::filesystem::exists(path)) return static_cast<TriangleMesh*>(nullptr);
    return new TriangleMesh(load_mesh(path));
  }();
  return cached;
}

/// Flat jittered grid on [0, 1]^2 (z = 0), 20 x 20 cells.
TriangleMesh jittered_grid() {
  GridOptions o;
  o.nx = o.ny = 20;
  o.hx = o.hy = 0.05;
  o.jitter = 0.15;
  o.seed = 7;
  MeshData d = flat_grid(o);
  return TriangleMesh(std::move(d.positions), std::move(d.faces));
}

TriangleMesh single_triangle(const Vec3& a, const Vec3& b, const Vec3& c) {
  return TriangleMesh({a, b, c}, {Triangle{0, 1, 2}});
}

void expect_same_result(const ClosestPointResult& a, const ClosestPointResult& b,
                        const std::string& what) {
  EXPECT_EQ(a.point.kind, b.point.kind) << what;
  EXPECT_EQ(a.point.id, b.point.id) << what;
  EXPECT_EQ(a.point.bary, b.point.bary) << what;
  EXPECT_EQ(a.position.x, b.position.x) << what;
  EXPECT_EQ(a.position.y, b.position.y) << what;
  EXPECT_EQ(a.position.z, b.position.z) << what;
  EXPECT_EQ(a.distance, b.distance) << what;
}

// ---------------------------------------------------------------------------------------------
// Against brute force

TEST(ClosestPointTest, MatchesBruteForceOnFlatGrid) {
  const TriangleMesh mesh = jittered_grid();
  const ClosestPointIndex index(mesh);
  Rng rng(11);
  Coverage coverage;
  for (int i = 0; i < 3000; ++i) {
    // Above, below and beside the square, so that boundary edges and corners are hit too.
    check_against_brute_force(mesh, index, random_in_box(rng, {-0.3, -0.3, -0.5}, {1.3, 1.3, 0.5}),
                              1e-12, coverage);
  }
  for (int i = 0; i < 500; ++i) {
    // In the plane: distance zero inside, positive outside.
    check_against_brute_force(mesh, index, random_in_box(rng, {-0.1, -0.1, 0}, {1.1, 1.1, 0}),
                              1e-12, coverage);
  }
  print_coverage("flat grid", coverage);
  EXPECT_EQ(coverage.mismatches, 0) << coverage.first_mismatch;
  EXPECT_GT(coverage.interior, 1000);  // measured 1499
  EXPECT_GT(coverage.edge, 1000);      // 1566
  EXPECT_GT(coverage.vertex, 200);     // 435
}

TEST(ClosestPointTest, MatchesBruteForceOnCubeSurface) {
  const Cube cube = cube_surface(5, 1.0);
  const TriangleMesh mesh(cube.data.positions, cube.data.faces);
  const ClosestPointIndex index(mesh);
  Rng rng(12);
  Coverage coverage;
  for (int i = 0; i < 3000; ++i) {
    // Inside the cube (closest face of the box) and outside (faces, edges, corners).
    check_against_brute_force(mesh, index, random_in_box(rng, {-0.5, -0.5, -0.5}, {1.5, 1.5, 1.5}),
                              1e-12, coverage);
  }
  print_coverage("cube", coverage);
  EXPECT_EQ(coverage.mismatches, 0) << coverage.first_mismatch;
  EXPECT_GT(coverage.interior, 1000);  // measured 1520
  EXPECT_GT(coverage.edge, 700);       // 1105
  EXPECT_GT(coverage.vertex, 200);     // 375
}

TEST(ClosestPointTest, MatchesBruteForceOnSpot) {
  const TriangleMesh* mesh = spot();
  ASSERT_TRUE(mesh) << "data/meshes/spot.obj not found";
  const ClosestPointIndex index(*mesh);
  const auto [lo, hi] = bounds(*mesh);
  const double diagonal = dist(lo, hi);
  const Vec3 margin = 0.2 * (hi - lo);
  Rng rng(13);
  Coverage coverage;
  for (int i = 0; i < 800; ++i) {
    check_against_brute_force(*mesh, index, random_in_box(rng, lo - margin, hi + margin),
                              1e-12 * diagonal, coverage);
  }
  for (int i = 0; i < 700; ++i) {
    // Near the surface, where many faces are close: up to 2% of the diagonal off a face.
    const Vec3 on = random_face_point(*mesh, rng, 0).position(*mesh);
    const Vec3 query = on + (0.02 * diagonal * rng.uniform()) * random_unit(rng);
    check_against_brute_force(*mesh, index, query, 1e-12 * diagonal, coverage);
  }
  print_coverage("spot", coverage);
  EXPECT_EQ(coverage.mismatches, 0) << coverage.first_mismatch;
  EXPECT_GT(coverage.interior, 550);  // measured 851
  EXPECT_GT(coverage.edge, 250);      // 392
  EXPECT_GT(coverage.vertex, 150);    // 257
}

TEST(ClosestPointTest, ResultsDoNotDependOnLeafSize) {
  // Leaf size F makes one leaf: the query is then the plain loop over every face in id order.
  // Every other tree must give the same answer bit for bit (pruning is exact, ties go by id).
  const TriangleMesh* mesh = spot();
  ASSERT_TRUE(mesh) << "data/meshes/spot.obj not found";
  const auto num_faces = static_cast<std::uint32_t>(mesh->num_faces());
  const ClosestPointIndex brute(*mesh, {.leaf_size = num_faces});
  EXPECT_EQ(brute.num_nodes(), 1u);
  const auto [lo, hi] = bounds(*mesh);
  const double diagonal = dist(lo, hi);
  Rng rng(14);
  std::vector<Vec3> queries;
  for (int i = 0; i < 300; ++i)
    queries.push_back(random_in_box(rng, lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo)));
  for (int i = 0; i < 300; ++i) {
    const Vec3 on = random_face_point(*mesh, rng, 0).position(*mesh);
    queries.push_back(on + (0.01 * diagonal * rng.uniform()) * random_unit(rng));
  }
  // Vertices: exact ties between all the faces around them.
  for (std::uint32_t v = 0; v < mesh->num_vertices(); v += 97) queries.push_back(mesh->position(v));
  std::vector<ClosestPointResult> expected;
  for (const Vec3& q : queries) expected.push_back(brute.closest(q));
  for (std::uint32_t leaf_size : {1u, 2u, 3u, 4u, 8u, 64u, num_faces / 2}) {
    const ClosestPointIndex index(*mesh, {.leaf_size = leaf_size});
    for (std::size_t i = 0; i < queries.size(); ++i) {
      expect_same_result(index.closest(queries[i]), expected[i],
                         "leaf_size " + std::to_string(leaf_size) + ", query " + std::to_string(i));
    }
  }
}

TEST(ClosestPointTest, NodeCountFollowsLeafSize) {
  const TriangleMesh mesh = jittered_grid();  // 800 faces
  const auto num_faces = mesh.num_faces();
  // Median splits of 800 faces: leaf_size 1 is a full binary tree with F leaves.
  EXPECT_EQ(ClosestPointIndex(mesh, {.leaf_size = 1}).num_nodes(), 2 * num_faces - 1);
  // 800 -> 400 -> 200 -> 100 -> 50 -> 25 -> 12/13 -> 6/7 -> 3/4: 256 leaves of 3 or 4.
  EXPECT_EQ(ClosestPointIndex(mesh).num_nodes(), 511u);
  EXPECT_EQ(ClosestPointIndex(mesh, {.leaf_size = 800}).num_nodes(), 1u);
  EXPECT_EQ(ClosestPointIndex(mesh, {.leaf_size = 799}).num_nodes(), 3u);
  EXPECT_EQ(ClosestPointIndex(mesh, {.leaf_size = std::numeric_limits<std::uint32_t>::max()})
                .num_nodes(),
            1u);
}

// ---------------------------------------------------------------------------------------------
// Known answers

TEST(ClosestPointTest, SurfacePointsSnapToThemselves) {
  const TriangleMesh* mesh = spot();
  ASSERT_TRUE(mesh) << "data/meshes/spot.obj not found";
  const ClosestPointIndex index(*mesh);
  const double diagonal = bbox_diagonal(*mesh);
  Rng rng(15);
  for (int i = 0; i < 1000; ++i) {
    const SurfacePoint p = random_face_point(*mesh, rng, 0.02);
    const Vec3 at = p.position(*mesh);
    const ClosestPointResult r = index.closest(at);
    ASSERT_EQ(r.point.kind, SurfacePoint::Kind::Face) << p.to_string();
    EXPECT_EQ(r.point.id, p.id) << p.to_string();
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.point.bary[c], p.bary[c], 1e-9) << p.to_string();
    EXPECT_LT(r.distance, 1e-14 * diagonal) << p.to_string();
    EXPECT_LT(dist(r.position, at), 1e-14 * diagonal) << p.to_string();
  }
  // A vertex's own position is that vertex, at distance exactly zero.
  for (std::uint32_t v = 0; v < mesh->num_vertices(); ++v) {
    const ClosestPointResult r = index.closest(mesh->position(v));
    ASSERT_EQ(r.point.kind, SurfacePoint::Kind::Vertex) << "vertex " << v;
    EXPECT_EQ(r.point.id, v);
    EXPECT_EQ(r.distance, 0.0) << "vertex " << v;
  }
}

TEST(ClosestPointTest, PointAboveFaceInteriorSnapsToFoot) {
  // A tilted triangle: the foot of the perpendicular from either side, at height 0.7.
  const Vec3 a{0.1, 0.2, 0.3}, b{1.3, 0.4, -0.2}, c{0.4, 1.1, 0.6};
  const TriangleMesh triangle = single_triangle(a, b, c);
  const ClosestPointIndex triangle_index(triangle);
  const Vec3 normal = normalized(cross(b - a, c - a));
  const std::array<double, 3> bary{0.2, 0.3, 0.5};
  const Vec3 foot = triangle.face_point(0, bary);
  for (double height : {0.7, -0.7}) {
    const ClosestPointResult r = triangle_index.closest(foot + height * normal);
    ASSERT_EQ(r.point.kind, SurfacePoint::Kind::Face);
    EXPECT_EQ(r.point.id, 0u);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(r.point.bary[k], bary[k], 1e-14) << k;
    EXPECT_LT(dist(r.position, foot), 1e-14);
    EXPECT_NEAR(r.distance, 0.7, 1e-14);
  }

  // On the flat grid the foot of any point above a face's interior is in that face.
  const TriangleMesh mesh = jittered_grid();
  const ClosestPointIndex index(mesh);
  Rng rng(16);
  for (int i = 0; i < 500; ++i) {
    const SurfacePoint p = random_face_point(mesh, rng, 0.01);
    Vec3 query = p.position(mesh);
    query.z = rng.uniform(-2, 2);
    const ClosestPointResult r = index.closest(query);
    ASSERT_EQ(r.point.kind, SurfacePoint::Kind::Face) << p.to_string();
    EXPECT_EQ(r.point.id, p.id) << p.to_string();
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(r.point.bary[k], p.bary[k], 1e-12) << p.to_string();
    EXPECT_NEAR(r.distance, std::abs(query.z), 1e-15) << p.to_string();
    EXPECT_EQ(r.position.z, 0.0);
  }

  // Outside the cube, above the middle of its top face (z = 1).
  const Cube cube = cube_surface(4, 1.0);
  const TriangleMesh cube_mesh(cube.data.positions, cube.data.faces);
  const ClosestPointResult r = ClosestPointIndex(cube_mesh).closest({0.3, 0.6, 1.25});
  EXPECT_EQ(cube.data.face_tag[r.point.id], 1);
  EXPECT_NEAR(r.distance, 0.25, 1e-15);
  EXPECT_NEAR(dist(r.position, {0.3, 0.6, 1.0}), 0, 1e-15);
}

TEST(ClosestPointTest, CornerQueriesSnapToVertices) {
  const Cube cube = cube_surface(3, 2.0);
  const TriangleMesh mesh(cube.data.positions, cube.data.faces);
  const ClosestPointIndex index(mesh);
  for (double x : {0.0, 2.0}) {
    for (double y : {0.0, 2.0}) {
      for (double z : {0.0, 2.0}) {
        // Out along a direction that stays in the corner's normal cone.
        const Vec3 corner{x, y, z};
        const Vec3 out{x > 0 ? 0.5 : -0.5, y > 0 ? 0.3 : -0.3, z > 0 ? 0.4 : -0.4};
        const ClosestPointResult r = index.closest(corner + out);
        ASSERT_EQ(r.point.kind, SurfacePoint::Kind::Vertex);
        EXPECT_EQ(mesh.position(r.point.id).x, x);
        EXPECT_EQ(mesh.position(r.point.id).y, y);
        EXPECT_EQ(mesh.position(r.point.id).z, z);
        EXPECT_EQ(r.position.x, x);
        EXPECT_EQ(r.position.y, y);
        EXPECT_EQ(r.position.z, z);
        EXPECT_DOUBLE_EQ(r.distance, std::sqrt(0.5));
      }
    }
  }

  // Beyond the corner of a flat grid: its corner vertex. Beyond a boundary edge: onto the edge.
  GridOptions o;
  o.nx = o.ny = 4;
  o.hx = o.hy = 0.25;
  MeshData d = flat_grid(o);
  const TriangleMesh grid(std::move(d.positions), std::move(d.faces));
  const ClosestPointIndex grid_index(grid);
  const ClosestPointResult corner = grid_index.closest({-1, -2, 0.5});
  ASSERT_EQ(corner.point.kind, SurfacePoint::Kind::Vertex);
  EXPECT_EQ(corner.point.id, grid_vertex(o, 0, 0));
  EXPECT_DOUBLE_EQ(corner.distance, std::sqrt(1 + 4 + 0.25));
  const ClosestPointResult far_corner = grid_index.closest({3, 1.5, 0});
  ASSERT_EQ(far_corner.point.kind, SurfacePoint::Kind::Vertex);
  EXPECT_EQ(far_corner.point.id, grid_vertex(o, 4, 4));

  const ClosestPointResult edge = grid_index.closest({0.3, -0.5, 0.2});
  ASSERT_EQ(edge.point.kind, SurfacePoint::Kind::Face);
  EXPECT_EQ(std::count(edge.point.bary.begin(), edge.point.bary.end(), 0.0), 1);
  EXPECT_NEAR(edge.position.x, 0.3, 1e-15);
  EXPECT_EQ(edge.position.y, 0.0);
  EXPECT_EQ(edge.position.z, 0.0);
  EXPECT_NEAR(edge.distance, std::hypot(0.5, 0.2), 1e-15);
}

TEST(ClosestPointTest, ExactTiesGoToTheLowestFaceId) {
  // Dyadic coordinates: every computation is exact, so the two faces of an edge tie exactly
  // above its midpoint, and the faces around a vertex tie above the vertex.
  GridOptions o;
  o.nx = o.ny = 8;
  o.hx = o.hy = 0.125;
  MeshData d = flat_grid(o);
  const TriangleMesh mesh(std::move(d.positions), std::move(d.faces));
  for (std::uint32_t leaf_size : {1u, 4u, 128u}) {
    const ClosestPointIndex index(mesh, {.leaf_size = leaf_size});
    int interior_edges = 0;
    for (std::uint32_t e = 0; e < mesh.num_edges(); ++e) {
      const std::uint32_t h = mesh.edge_halfedge(e);
      if (mesh.twin(h) < 0) continue;
      ++interior_edges;
      const std::uint32_t lowest =
          std::min(TriangleMesh::face_of(h),
                   TriangleMesh::face_of(static_cast<std::uint32_t>(mesh.twin(h))));
      const Vec3 midpoint =
          0.5 * (mesh.position(mesh.edge_origin(e)) + mesh.position(mesh.edge_target(e)));
      const ClosestPointResult r = index.closest(midpoint + Vec3{0, 0, 0.25});
      ASSERT_EQ(r.point.kind, SurfacePoint::Kind::Face) << "edge " << e;
      EXPECT_EQ(r.point.id, lowest) << "edge " << e << ", leaf_size " << leaf_size;
      std::array<double, 3> sorted = r.point.bary;
      std::sort(sorted.begin(), sorted.end());
      EXPECT_EQ(sorted, (std::array<double, 3>{0, 0.5, 0.5})) << "edge " << e;
      EXPECT_EQ(r.distance, 0.25);
    }
    // 72 horizontal + 72 vertical + 64 diagonal edges, 32 of them on the boundary.
    EXPECT_EQ(interior_edges, 176);
  }
}

// ---------------------------------------------------------------------------------------------
// Degenerate and thin faces, isolated vertices

TEST(ClosestPointTest, ZeroAreaFacesGiveFiniteExactAnswers) {
  // Collinear corners: the face is the segment from (0,0,0) to (3,0,0).
  {
    const TriangleMesh mesh = single_triangle({0, 0, 0}, {1, 0, 0}, {3, 0, 0});
    const ClosestPointIndex index(mesh);
    const ClosestPointResult r = index.closest({2, 1, 0});
    ASSERT_EQ(r.point.kind, SurfacePoint::Kind::Face);
    EXPECT_NO_THROW(r.point.validate(mesh));
    EXPECT_NEAR(dist(r.position, {2, 0, 0}), 0, 1e-15);
    EXPECT_NEAR(dist(r.point.position(mesh), {2, 0, 0}), 0, 1e-15);
    EXPECT_NEAR(r.distance, 1, 1e-15);
    const ClosestPointResult before = index.closest({-1, 0, 0});
    ASSERT_EQ(before.point.kind, SurfacePoint::Kind::Vertex);
    EXPECT_EQ(before.point.id, 0u);
    EXPECT_EQ(before.distance, 1.0);
    const ClosestPointResult after = index.closest({5, 2, 0});
    ASSERT_EQ(after.point.kind, SurfacePoint::Kind::Vertex);
    EXPECT_EQ(after.point.id, 2u);
    EXPECT_DOUBLE_EQ(after.distance, std::sqrt(8.0));
  }
  // Two coincident corners (a zero-length edge): the face is the segment to the third.
  {
    const TriangleMesh mesh = single_triangle({0, 0, 0}, {0, 0, 0}, {1, 0, 0});
    const ClosestPointResult r = ClosestPointIndex(mesh).closest({0.5, 1, 0});
    EXPECT_NEAR(dist(r.position, {0.5, 0, 0}), 0, 1e-15);
    EXPECT_NEAR(r.distance, 1, 1e-15);
    EXPECT_NO_THROW(r.point.validate(mesh));
  }
  // Three coincident corners: the face is a point.
  {
    const TriangleMesh mesh = single_triangle({1, 1, 1}, {1, 1, 1}, {1, 1, 1});
    const ClosestPointResult r = ClosestPointIndex(mesh).closest({0, 0, 0});
    ASSERT_EQ(r.point.kind, SurfacePoint::Kind::Vertex);
    EXPECT_DOUBLE_EQ(r.distance, std::sqrt(3.0));
  }
  // A flat grid with a zero-area face among caps: the surface is still the square [0, 1]^2,
  // so the answer to (x, y, z) over it is (x, y, 0) at distance |z|.
  {
    MeshData d = cap_grid(4, 4, 0.25, 1e-3, {{1, 2}, {2, 2}});
    const TriangleMesh mesh(std::move(d.positions), std::move(d.faces));
    const ClosestPointIndex index(mesh);
    Rng rng(17);
    Coverage coverage;
    for (int i = 0; i < 2000; ++i) {
      // Half the queries right around the degenerate cells' diagonals.
      const Vec3 query = i % 2 == 0 ? random_in_box(rng, {-0.2, -0.2, -0.5}, {1.2, 1.2, 0.5})
                                    : random_in_box(rng, {0.25, 0.5, -0.1}, {0.75, 0.75, 0.1});
      check_against_brute_force(mesh, index, query, 1e-14, coverage);
      if (query.x >= 0 && query.x <= 1 && query.y >= 0 && query.y <= 1) {
        const ClosestPointResult r = index.closest(query);
        EXPECT_NEAR(r.distance, std::abs(query.z), 1e-15);
        EXPECT_NEAR(r.position.x, query.x, 1e-15);
        EXPECT_NEAR(r.position.y, query.y, 1e-15);
      }
    }
    print_coverage("cap grid", coverage);
    EXPECT_EQ(coverage.mismatches, 0) << coverage.first_mismatch;
  }
}

TEST(ClosestPointTest, SliverFaceKeepsAccurateBarycentrics) {
  // Heights 1e-7 and 2e-8 over a unit edge (just above the 1.5e-8 at which a face counts as
  // degenerate). Measured: Ericson's interior formula (va, vb, vc from products of dot products)
  // is off by 2e-4 and 1.4e-2 in barycentrics, 2e-11 and 2.6e-3 in position; the sub-triangle
  // normals by about 1e-16 in both.
  for (double height : {1e-7, 2e-8}) {
    const TriangleMesh mesh = single_triangle({0, 0, 0}, {1, 0, 0}, {0.5, height, 0});
    const ClosestPointIndex index(mesh);
    for (const std::array<double, 3>& bary : {std::array<double, 3>{0.25, 0.25, 0.5},
                                              std::array<double, 3>{0.6, 0.1, 0.3},
                                              std::array<double, 3>{0.05, 0.9, 0.05}}) {
      const Vec3 foot = mesh.face_point(0, bary);
      const ClosestPointResult r = index.closest(foot + Vec3{0, 0, 0.5});
      ASSERT_EQ(r.point.kind, SurfacePoint::Kind::Face);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(r.point.bary[k], bary[k], 1e-12) << height;
      EXPECT_NEAR(dist(r.position, foot), 0, 1e-14) << height;
      EXPECT_NEAR(r.distance, 0.5, 1e-15) << height;
    }
  }
}

TEST(ClosestPointTest, IsolatedVerticesAreIgnored) {
  GridOptions o;
  o.nx = o.ny = 4;
  o.hx = o.hy = 0.25;
  MeshData d = flat_grid(o);
  d.positions.push_back({0.5, 0.5, 5});  // used by no face
  const auto isolated = static_cast<std::uint32_t>(d.positions.size() - 1);
  const TriangleMesh mesh(std::move(d.positions), std::move(d.faces));
  ASSERT_TRUE(mesh.is_isolated_vertex(isolated));
  const ClosestPointResult r = ClosestPointIndex(mesh).closest({0.4, 0.6, 4.9});
  EXPECT_FALSE(r.point.kind == SurfacePoint::Kind::Vertex && r.point.id == isolated);
  EXPECT_EQ(r.position.z, 0.0);
  EXPECT_NEAR(r.distance, 4.9, 1e-15);
}

// ---------------------------------------------------------------------------------------------
// Refusals and concurrency

TEST(ClosestPointTest, NonFiniteOrHugePositionThrowsBadPosition) {
  const TriangleMesh mesh = jittered_grid();
  const ClosestPointIndex index(mesh);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const Vec3& bad : {Vec3{nan, 0, 0}, Vec3{0, nan, 0}, Vec3{0, 0, nan}, Vec3{kInf, 0, 0},
                          Vec3{0, -kInf, 0}, Vec3{0, 0, 1e200}}) {
    try {
      index.closest(bad);
      ADD_FAILURE() << "no exception for (" << bad.x << ", " << bad.y << ", " << bad.z << ")";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.reason(), "BadPosition") << e.what();
    }
  }
  // Large but representable distances are still answered.
  const ClosestPointResult r = index.closest({0, 0, 1e100});
  EXPECT_DOUBLE_EQ(r.distance, 1e100);
}

TEST(ClosestPointTest, ZeroLeafSizeThrowsBadLeafSize) {
  const TriangleMesh mesh = jittered_grid();
  try {
    ClosestPointIndex index(mesh, {.leaf_size = 0});
    ADD_FAILURE() << "no exception";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.reason(), "BadLeafSize");
  }
}

TEST(ClosestPointTest, ConcurrentQueriesMatchSerialOnes) {
  const TriangleMesh* mesh = spot();
  ASSERT_TRUE(mesh) << "data/meshes/spot.obj not found";
  const ClosestPointIndex index(*mesh);
  const auto [lo, hi] = bounds(*mesh);
  Rng rng(18);
  std::vector<Vec3> queries;
  for (int i = 0; i < 2000; ++i) queries.push_back(random_in_box(rng, lo, hi));
  std::vector<ClosestPointResult> serial;
  for (const Vec3& q : queries) serial.push_back(index.closest(q));
  constexpr int kThreads = 4;
  std::vector<std::vector<ClosestPointResult>> parallel(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (const Vec3& q : queries) parallel[t].push_back(index.closest(q));
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (int t = 0; t < kThreads; ++t) {
    ASSERT_EQ(parallel[t].size(), serial.size());
    for (std::size_t i = 0; i < serial.size(); ++i) {
      expect_same_result(parallel[t][i], serial[i],
                         "thread " + std::to_string(t) + ", query " + std::to_string(i));
    }
  }
}

}  // namespace
}  // namespace geoprox
