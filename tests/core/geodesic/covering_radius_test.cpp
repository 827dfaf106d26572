// Tests of core/geodesic/covering_radius.h: analytic covering radii on flat meshes (a square, a strip of
// long faces) and a cube, where the farthest point is inside a face, on an edge or at a vertex;
// on spot.obj against a dense barycentric grid of exact distances in every face (a lower bound,
// and with the Lipschitz bound an upper one); the faces beyond a threshold; a component without
// a sample; bad input.
#include "core/geodesic/covering_radius.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
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

constexpr double kTolerance = CoveringRadiusOptions{}.relative_tolerance;

std::vector<SurfacePoint> vertices(std::initializer_list<std::uint32_t> ids) {
  std::vector<SurfacePoint> out;
  for (std::uint32_t v : ids) out.push_back(SurfacePoint::vertex(v));
  return out;
}

std::vector<SurfacePoint> every_vertex(const TriangleMesh& mesh) {
  std::vector<SurfacePoint> out;
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) out.push_back(SurfacePoint::vertex(v));
  return out;
}

/// The answer brackets the analytic r: never below it, at most the tolerance above, and the
/// point reported is as far as it says.
void expect_radius(const TestMesh& m, const CoveringRadius& c, std::span<const SurfacePoint> samples,
                   double r, const std::string& what) {
  SCOPED_TRACE(what);
  EXPECT_GE(c.radius, r * (1 - 1e-12)) << fmt(c.radius) << " vs " << fmt(r);
  EXPECT_LE(c.radius, r * (1 + kTolerance)) << fmt(c.radius) << " vs " << fmt(r);
  EXPECT_LE(c.attained, r * (1 + 1e-12)) << fmt(c.attained) << " vs " << fmt(r);
  EXPECT_LE(c.attained, c.radius);
  EXPECT_GE(c.attained, c.radius / (1 + kTolerance) * (1 - 1e-12));
  ExactGeodesicSolver solver(*m.mesh, *m.geometry);
  std::vector<GeodesicSource> sources;
  for (const SurfacePoint& s : samples) sources.push_back({s, 0.0});
  solver.solve(sources);
  EXPECT_EQ(solver.distance(c.farthest), c.attained) << c.farthest.to_string();
}

MeshData unit_square() {
  MeshData d;
  d.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  d.faces = {{0, 1, 2}, {0, 2, 3}};
  return d;
}

TEST(CoveringRadius, SquareWithItsCornersIsCoveredFromItsCentre) {
  const TestMesh m = make_test_mesh(unit_square());
  const auto samples = vertices({0, 1, 2, 3});
  const CoveringRadius c = covering_radius(*m.mesh, *m.geometry, samples);
  expect_radius(m, c, samples, std::numbers::sqrt2 / 2, "four corners");
  EXPECT_EQ(c.vertex_radius, 0.0);
  EXPECT_GT(c.evaluations, 0u);
  // The centre, on the diagonal both faces share.
  const Vec3 p = c.farthest.position(*m.mesh);
  EXPECT_NEAR(p.x, 0.5, 0.01);
  EXPECT_NEAR(p.y, 0.5, 0.01);
}

TEST(CoveringRadius, FarthestVertexNeedsNoSplitting) {
  const TestMesh m = make_test_mesh(unit_square());
  const auto samples = vertices({0});
  const CoveringRadius c = covering_radius(*m.mesh, *m.geometry, samples);
  expect_radius(m, c, samples, std::numbers::sqrt2, "one corner");
  EXPECT_EQ(c.vertex_radius, std::numbers::sqrt2);
  EXPECT_EQ(c.farthest.kind, SurfacePoint::Kind::Vertex);
  EXPECT_EQ(c.farthest.id, 2u);
}

TEST(CoveringRadius, LongFacesHoldPointsFarFromEveryVertex) {
  // Every vertex is a sample, yet the middle of the long faces is 4.51 away from all of them.
  const TestMesh m = make_test_mesh(long_faced_strip());
  const auto samples = every_vertex(*m.mesh);
  CoveringRadiusOptions options;
  options.beyond = 1.0;
  const CoveringRadius c = covering_radius(*m.mesh, *m.geometry, samples, options);
  expect_radius(m, c, samples, 99.25 / 18 - 1, "long-faced strip");
  EXPECT_EQ(c.vertex_radius, 0.0);
  const Vec3 p = c.farthest.position(*m.mesh);
  EXPECT_NEAR(p.x, 99.25 / 18, 0.01);
  EXPECT_NEAR(p.y, 0.5, 0.01);
  // Each of the eleven long faces reaches beyond 1 from every vertex; no grid face does.
  EXPECT_EQ(c.faces_beyond, 11u);
  EXPECT_NEAR(c.area_beyond, 9.0, 1e-12);
}

TEST(CoveringRadius, CubeCornersAndFaceCentres) {
  // Side 2, each face a 4 x 4 grid: the corners leave the face centres sqrt(2) away (inside
  // the faces' grids, on a vertex); the face centres leave the corners sqrt(2) away.
  const Cube cube = cube_surface(4, 2.0);
  const TestMesh m = make_test_mesh(cube.data);
  std::vector<SurfacePoint> corners, centres;
  for (std::uint32_t v = 0; v < m.mesh->num_vertices(); ++v) {
    const Vec3& p = m.mesh->position(v);
    int on_side = 0, middle = 0;
    for (double x : {p.x, p.y, p.z}) {
      on_side += x == 0 || x == 2;
      middle += x == 1;
    }
    if (on_side == 3) corners.push_back(SurfacePoint::vertex(v));
    if (on_side == 1 && middle == 2) centres.push_back(SurfacePoint::vertex(v));
  }
  ASSERT_EQ(corners.size(), 8u);
  ASSERT_EQ(centres.size(), 6u);
  const CoveringRadius from_corners = covering_radius(*m.mesh, *m.geometry, corners);
  expect_radius(m, from_corners, corners, std::numbers::sqrt2, "cube corners");
  const CoveringRadius from_centres = covering_radius(*m.mesh, *m.geometry, centres);
  expect_radius(m, from_centres, centres, std::numbers::sqrt2, "cube face centres");
  EXPECT_NEAR(from_centres.vertex_radius, std::numbers::sqrt2, 1e-12);
}

TEST(CoveringRadius, SpotAgainstADenseGridOfExactDistances) {
  const TestMesh& m = spot();
  const TriangleMesh& mesh = *m.mesh;
  std::vector<SurfacePoint> samples;
  for (std::uint32_t v = 0; v < mesh.num_vertices(); v += 73) {
    samples.push_back(SurfacePoint::vertex(v));
  }
  ExactGeodesicSolver solver(mesh, *m.geometry);
  CoveringRadiusOptions options;
  options.beyond = 0.5;  // set below from the radius found
  const CoveringRadius first = covering_radius(solver, samples, options);
  options.beyond = 0.8 * first.radius;
  const CoveringRadius c = covering_radius(solver, samples, options);
  EXPECT_EQ(c.radius, first.radius) << "the same solve twice";
  EXPECT_GE(c.radius, c.vertex_radius);

  // Every face on a grid of step 1/8 in barycentrics: the largest value is a lower bound of r,
  // and no point is more than (longest side / 8) / sqrt(3) from a grid point.
  constexpr int kSteps = 8;
  double grid_max = 0, cell_bound = 0;
  std::size_t must_count = 0, may_count = 0;
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
    double face_max = 0, longest = 0;
    for (int k = 0; k < 3; ++k) longest = std::max(longest, m.geometry->edge_length(mesh.edge_of(3 * f + k)));
    for (int i = 0; i <= kSteps; ++i) {
      for (int j = 0; i + j <= kSteps; ++j) {
        const double b1 = double(i) / kSteps, b2 = double(j) / kSteps;
        face_max = std::max(face_max, solver.distance(SurfacePoint::face(f, 1 - b1 - b2, b1, b2)));
      }
    }
    const double face_bound = longest / kSteps / std::sqrt(3.0);
    grid_max = std::max(grid_max, face_max);
    cell_bound = std::max(cell_bound, face_bound);
    must_count += face_max > options.beyond * (1 + kTolerance);
    may_count += face_max + face_bound > options.beyond;
  }
  EXPECT_GE(c.radius, grid_max * (1 - 1e-12)) << fmt(c.radius) << " vs grid " << fmt(grid_max);
  EXPECT_LE(c.radius, (grid_max + cell_bound) * (1 + kTolerance))
      << fmt(c.radius) << " vs grid " << fmt(grid_max) << " + " << fmt(cell_bound);
  EXPECT_LE(c.radius, c.attained * (1 + kTolerance) * (1 + 1e-12));
  EXPECT_EQ(solver.distance(c.farthest), c.attained);
  EXPECT_GT(c.radius, c.vertex_radius) << "spot's farthest point is inside a face";
  EXPECT_GE(c.faces_beyond, must_count);
  EXPECT_LE(c.faces_beyond, may_count);
  EXPECT_GT(must_count, 0u);
  RecordProperty("radius", fmt(c.radius));
  RecordProperty("vertex_radius", fmt(c.vertex_radius));
  RecordProperty("evaluations", static_cast<int>(c.evaluations));
}

TEST(CoveringRadius, UglyMeshesGiveABoundAboveEveryPointSeen) {
  // Needles, slivers, caps, zero-area faces and coincident vertices (test_meshes.h), flat and
  // bumpy, with a few vertices as samples: the search ends, never below the distance at any
  // vertex or face centre, and the point it reports is as far as it says.
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    for (double thinnest : {6.0, 15.0}) {
      const TestMesh m =
          make_test_mesh(seed % 2 ? ugly_rectangle(seed, thinnest) : ugly_bumps(seed, thinnest));
      const TriangleMesh& mesh = *m.mesh;
      const std::string what = "seed " + std::to_string(seed) + ", thinnest " + fmt(thinnest);
      std::vector<SurfacePoint> samples;
      for (std::uint32_t v = static_cast<std::uint32_t>(seed % 5); v < mesh.num_vertices(); v += 17) {
        if (!mesh.is_isolated_vertex(v)) samples.push_back(SurfacePoint::vertex(v));
      }
      ExactGeodesicSolver solver(mesh, *m.geometry);
      CoveringRadiusOptions options;
      options.beyond = 0;  // every face with a point off the samples
      const CoveringRadius c = covering_radius(solver, samples, options);
      ASSERT_TRUE(std::isfinite(c.radius)) << what;
      double seen = 0;
      for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
        seen = std::max(seen, solver.distance(SurfacePoint::face(f, 1.0 / 3, 1.0 / 3, 1.0 / 3)));
      }
      for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
        if (!mesh.is_isolated_vertex(v)) seen = std::max(seen, solver.distance(v));
      }
      EXPECT_GE(c.radius, seen) << what;
      EXPECT_LE(c.radius, c.attained * (1 + kTolerance) * (1 + 1e-12)) << what;
      EXPECT_EQ(solver.distance(c.farthest), c.attained) << what;
      EXPECT_GT(c.faces_beyond, 0u) << what;
      EXPECT_LE(c.faces_beyond, mesh.num_faces()) << what;
    }
  }
}

TEST(CoveringRadius, ComponentWithoutASampleIsInfinitelyFar) {
  GridOptions a{.nx = 3, .ny = 3};
  GridOptions b{.nx = 3, .ny = 3, .x0 = 5};
  const TestMesh m = make_test_mesh(concatenate(flat_grid(a), flat_grid(b)));
  const CoveringRadius c = covering_radius(*m.mesh, *m.geometry, vertices({0}));
  EXPECT_EQ(c.radius, kInfinity);
  EXPECT_EQ(c.vertex_radius, kInfinity);
  EXPECT_GE(c.farthest.id, 16u) << "a vertex of the second grid";
}

TEST(CoveringRadius, RefusesBadInput) {
  const TestMesh m = make_test_mesh(unit_square());
  auto reason = [&](std::span<const SurfacePoint> samples, const CoveringRadiusOptions& options) {
    try {
      covering_radius(*m.mesh, *m.geometry, samples, options);
    } catch (const InvalidInput& e) {
      return e.reason();
    }
    return std::string("accepted");
  };
  const auto corner = vertices({0});
  EXPECT_EQ(reason({}, {}), "BadGraphSize");
  EXPECT_EQ(reason(vertices({4}), {}), "VertexOutOfRange");
  EXPECT_EQ(reason(corner, {.relative_tolerance = 0}), "BadOption");
  EXPECT_EQ(reason(corner, {.relative_tolerance = std::nan("")}), "BadOption");
  EXPECT_EQ(reason(corner, {.beyond = -1}), "BadOption");
  EXPECT_EQ(reason(corner, {.beyond = std::nan("")}), "BadOption");
}

}  // namespace
}  // namespace geoprox
