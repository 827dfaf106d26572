// Tests of the corner samples of core/graph/proximity_graph.h and of sparse_sampling_warning's
// rule: shortest paths bend at boundary corners whose angle exceeds pi (the ends of slits that
// repair cuts open, the corners of a CAD model's openings), and graph paths around such a corner
// with no sample on it are longer by a first-order share of the samples' spacing. With the
// corners as samples, graph answers on a plate with slits meet the accuracy aim (mean under
// 0.3%, worst under 2%, fields under 3%, never below exact) against the exact solver.
//
// Mesh: a flat 3 x 3 grid of 0.05 cells with two staggered slits one cell wide and 1.5 long,
// so that paths from one side to the other wrap around their ends (eight corners of angle
// 3 pi / 2). Geometry is made in the test; no files.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "core/base/tuning.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/graph/proximity_graph.h"
#include "core/query/geodesic_query.h"
#include "tests/core/test_meshes.h"

namespace geoprox {
namespace {

using test_meshes::holed_grid;
using test_meshes::make_test_mesh;
using test_meshes::Rng;
using test_meshes::TestMesh;

const TestMesh& slit_plate() {
  static const TestMesh m =
      make_test_mesh(holed_grid(60, 60, 0.05, {{6, 19, 36, 20}, {24, 39, 54, 40}}).data);
  return m;
}

// 150 samples and m_P 10, or with `table1` the defaults (Table 1: 1300 and 22).
ProximityGraph build(const TestMesh& m, bool corners, bool table1 = false) {
  ProximityGraphOptions o;
  o.num_samples = table1 ? 0 : 150;
  o.neighbors = table1 ? 0 : 10;
  o.corner_samples = corners;
  return build_proximity_graph(*m.mesh, *m.geometry, o);
}

struct Errors {
  double mean = 0, max = 0, field_max = 0;
  int below_exact = 0;
};

// Graph answers (default query options) against full exact solves: random face points, pairs
// from 12 sources to 40 targets each, and the field of each source at every vertex.
Errors measure(const TestMesh& m, const ProximityGraph& g) {
  const GeodesicQuery query(*m.mesh, *m.geometry, g.view());
  QueryScratch scratch = query.make_scratch();
  ExactGeodesicSolver solver(*m.mesh, *m.geometry);
  Rng rng(43);
  Errors e;
  int pairs = 0;
  for (int k = 0; k < 12; ++k) {
    const SurfacePoint s = test_meshes::random_face_point(*m.mesh, rng);
    solver.solve(s);
    for (int j = 0; j < 40; ++j) {
      const SurfacePoint t = test_meshes::random_face_point(*m.mesh, rng);
      const double exact = solver.distance(t);
      if (!(exact > 0)) continue;
      const double err = (query.distance(s, t, scratch).distance - exact) / exact;
      e.below_exact += err < -1e-9;
      e.mean += std::abs(err);
      e.max = std::max(e.max, std::abs(err));
      ++pairs;
    }
    const DistanceField field = query.field(std::span<const SurfacePoint>(&s, 1), scratch);
    for (std::uint32_t v = 0; v < m.mesh->num_vertices(); ++v) {
      const double exact = solver.distance(v);
      if (!(exact > 0)) continue;
      const double err = (field.distances[v] - exact) / exact;
      e.below_exact += err < -1e-9;
      e.field_max = std::max(e.field_max, std::abs(err));
    }
  }
  e.mean /= pairs;
  return e;
}

// The boundary vertices whose angle exceeds pi by more than the corner threshold.
std::vector<std::uint32_t> reflex_corners(const TestMesh& m) {
  std::vector<std::uint32_t> out;
  for (std::uint32_t v = 0; v < m.mesh->num_vertices(); ++v) {
    if (m.mesh->is_boundary_vertex(v) &&
        m.geometry->angle_sum(v) > std::numbers::pi + tuning::kCornerSampleTurn) {
      out.push_back(v);
    }
  }
  return out;
}

TEST(CornerSamples, SlitEndsAreSamplesOnTopOfTheFarthestPoints) {
  const TestMesh& m = slit_plate();
  const std::vector<std::uint32_t> corners = reflex_corners(m);
  ASSERT_EQ(corners.size(), 8u);  // two slits, four corners of angle 3 pi / 2 each
  const ProximityGraph with = build(m, true), without = build(m, false);
  EXPECT_EQ(with.stats.corner_samples, 8u);
  EXPECT_EQ(without.stats.corner_samples, 0u);
  EXPECT_EQ(with.sample_vertex.size(), 158u);
  EXPECT_EQ(without.sample_vertex.size(), 150u);
  for (std::uint32_t v : corners) {
    EXPECT_NE(std::find(with.sample_vertex.begin(), with.sample_vertex.end(), v),
              with.sample_vertex.end())
        << "corner vertex " << v << " is no sample";
  }
  // The link radius is that of the 150 farthest-point samples: the density elsewhere.
  EXPECT_DOUBLE_EQ(with.link_radius, without.link_radius);
}

TEST(CornerSamples, GraphAnswersAroundSlitsMeetTheAim) {
  const TestMesh& m = slit_plate();
  const Errors with = measure(m, build(m, true, true));
  const Errors without = measure(m, build(m, false, true));
  std::printf(
      "[ info ] slit plate, pairs mean / max, fields max: with corner samples %.4f%% / "
      "%.4f%%, %.4f%%; without %.4f%% / %.4f%%, %.4f%%\n",
      100 * with.mean, 100 * with.max, 100 * with.field_max, 100 * without.mean, 100 * without.max,
      100 * without.field_max);
  EXPECT_LT(with.mean, 0.003);
  EXPECT_LT(with.max, 0.02);
  EXPECT_LT(with.field_max, 0.03);
  EXPECT_EQ(with.below_exact, 0);
  EXPECT_EQ(without.below_exact, 0);
  // Without them the paths around the slits' ends are what is off.
  EXPECT_LT(with.mean, without.mean);
  EXPECT_LT(with.max, without.max);
}

// The warning's rule: Theorem 4.2 bounds the error exactly when rho > 2r.
TEST(SparseSamplingWarning, FiresExactlyWhenTheBoundIsInfinite) {
  ProximityGraphView v;
  v.link_radius = 1;
  for (const double r : {0.1, 0.4, 0.4999}) {
    v.covering_radius = r;
    EXPECT_TRUE(std::isfinite(v.error_bound())) << r;
    EXPECT_EQ(sparse_sampling_warning(v), "") << r;
  }
  for (const double r : {0.5, 0.6, 1.0}) {
    v.covering_radius = r;
    EXPECT_TRUE(std::isinf(v.error_bound())) << r;
    const std::string warning = sparse_sampling_warning(v);
    EXPECT_NE(warning.find("Theorem 4.2"), std::string::npos) << r << ": " << warning;
  }
  v.covering_radius = 1.5;  // beyond the link radius: the long-face text
  EXPECT_NE(sparse_sampling_warning(v).find("beyond the link radius"), std::string::npos);
  v.link_radius = 0;  // unknown (imported): no bound, but nothing refutes one either
  v.covering_radius = 0.6;
  EXPECT_EQ(sparse_sampling_warning(v), "");
}

TEST(SparseSamplingWarning, BuiltGraphs) {
  // The slit plate's default graph is dense enough for the bound: no warning.
  const TestMesh& m = slit_plate();
  const ProximityGraph clean = build(m, true);
  ASSERT_LT(2 * clean.covering_radius, clean.link_radius);
  EXPECT_EQ(sparse_sampling_warning(clean.view(), &clean.stats), "");
  // Few samples per link disk (a small link radius) leave points beyond half of it from every
  // sample: no bound, and a warning, though every point has a sample within rho.
  ProximityGraphOptions sparse;
  sparse.num_samples = 150;
  sparse.neighbors = 10;
  sparse.link_samples = 3;
  const ProximityGraph g = build_proximity_graph(*m.mesh, *m.geometry, sparse);
  ASSERT_GE(2 * g.covering_radius, g.link_radius);
  ASSERT_LE(g.covering_radius, g.link_radius);
  EXPECT_TRUE(std::isinf(g.view().error_bound()));
  const std::string warning = sparse_sampling_warning(g.view(), &g.stats);
  EXPECT_NE(warning.find("Theorem 4.2"), std::string::npos) << warning;
  EXPECT_NE(warning.find("--link-samples"), std::string::npos) << warning;
}

}  // namespace
}  // namespace geoprox
