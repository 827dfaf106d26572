// Tests of core/geodesic_spline: on a flat grid geodesic de Casteljau / de Boor are the planar
// algorithms; on a curved mesh the curve interpolates the Bezier ends and lies on the surface.
#include "core/apps/geodesic_spline.h"

#include <gtest/gtest.h>

#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <string>
#include <vector>

#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/apps/exponential_map.h"
#include "core/query/geodesic_query.h"
#include "core/graph/proximity_graph.h"
#include "tests/core/application_test_support.h"
#include "tests/core/test_meshes.h"
#include "tests/core/test_support.h"

namespace geoprox {
namespace {

using namespace test_meshes;
using test_support::fmt;

const TestMesh& grid() { return jittered_unit_grid(); }

const GraphEnv& grid_env() {
  static const GraphEnv env(grid(), 100, 8);
  return env;
}

Vec3 planar_bezier(const std::vector<Vec3>& p, double t) {
  const double s = 1 - t;
  return (s * s * s) * p[0] + (3 * s * s * t) * p[1] + (3 * s * t * t) * p[2] + (t * t * t) * p[3];
}

/// Uniform cubic B-spline over all pieces, global parameter in [0, n - 3].
Vec3 planar_bspline(const std::vector<Vec3>& p, double global) {
  const std::size_t pieces = p.size() - 3;
  const std::size_t i = std::min(static_cast<std::size_t>(global), pieces - 1);
  const double t = global - static_cast<double>(i);
  const double b0 = (1 - t) * (1 - t) * (1 - t) / 6, b1 = (3 * t * t * t - 6 * t * t + 4) / 6,
               b2 = (-3 * t * t * t + 3 * t * t + 3 * t + 1) / 6, b3 = t * t * t / 6;
  return b0 * p[i] + b1 * p[i + 1] + b2 * p[i + 2] + b3 * p[i + 3];
}

std::vector<Vec3> positions_of(const TriangleMesh& mesh, const std::vector<SurfacePoint>& points) {
  std::vector<Vec3> out;
  for (const SurfacePoint& p : points) out.push_back(p.position(mesh));
  return out;
}

double worst_planar_error(const GeodesicSplineResult& r, const std::vector<Vec3>& control,
                          SplineType type) {
  double worst = 0;
  const std::size_t n = r.curve.size();
  for (std::size_t k = 0; k < n; ++k) {
    Vec3 expected;
    if (type == SplineType::Bezier) {
      const double pieces = static_cast<double>((control.size() - 1) / 3);
      const double s = pieces * static_cast<double>(k) / static_cast<double>(n - 1);
      const std::size_t piece = std::min(static_cast<std::size_t>(s), (control.size() - 1) / 3 - 1);
      const std::vector<Vec3> local(control.begin() + 3 * piece, control.begin() + 3 * piece + 4);
      expected = planar_bezier(local, s - static_cast<double>(piece));
    } else {
      const double pieces = static_cast<double>(control.size() - 3);
      expected = planar_bspline(control, pieces * static_cast<double>(k) / static_cast<double>(n - 1));
    }
    worst = std::max(worst, norm(r.curve[k].position - expected));
  }
  return worst;
}

const std::vector<SurfacePoint> kGridControl = {
    SurfacePoint::vertex(26), SurfacePoint::face(900, 0.2, 0.3, 0.5), SurfacePoint::vertex(200),
    SurfacePoint::edge(1500, 0.3), SurfacePoint::vertex(598), SurfacePoint::face(300, 0.6, 0.2, 0.2),
    SurfacePoint::vertex(580)};

TEST(GeodesicSpline, ExactGeodesicsOnAFlatGridGiveThePlanarCurves) {
  const TriangleMesh& mesh = *grid().mesh;
  GeodesicSpline spline(mesh, *grid().geometry);
  const std::vector<Vec3> control = positions_of(mesh, kGridControl);
  GeodesicSplineOptions options;
  options.geodesics = SplineGeodesics::Exact;
  options.samples = 41;
  for (SplineType type : {SplineType::Bezier, SplineType::BSpline}) {
    options.type = type;
    for (std::size_t count : {std::size_t{4}, std::size_t{7}}) {
      const std::vector<SurfacePoint> points(kGridControl.begin(), kGridControl.begin() + count);
      const std::vector<Vec3> positions(control.begin(), control.begin() + count);
      const GeodesicSplineResult r = spline.compute(points, options);
      ASSERT_EQ(r.curve.size(), 41u);
      ASSERT_EQ(r.control_polygon.size(), count - 1);
      const double worst = worst_planar_error(r, positions, type);
      EXPECT_LT(worst, 1e-9) << (type == SplineType::Bezier ? "bezier " : "bspline ") << count;
      // Control polygon legs are straight: their points lie on the chord.
      for (std::size_t i = 0; i + 1 < count; ++i) {
        const Vec3 a = positions[i], b = positions[i + 1];
        for (const PathPoint& p : r.control_polygon[i]) {
          EXPECT_LT(norm(cross(p.position - a, b - a)) / norm(b - a), 1e-9);
        }
      }
    }
  }
}

TEST(GeodesicSpline, GraphGeodesicsOnAFlatGridGiveThePlanarCurves) {
  const GraphEnv& env = grid_env();
  GeodesicSpline spline(env.query);
  const std::vector<Vec3> control = positions_of(env.mesh, kGridControl);
  GeodesicSplineOptions options;
  options.samples = 41;
  for (SplineType type : {SplineType::Bezier, SplineType::BSpline}) {
    options.type = type;
    const GeodesicSplineResult r = spline.compute(kGridControl, options);
    const double worst = worst_planar_error(r, control, type);
    // The graph's answer bounds an exact goal-directed solve: the geodesics are exact.
    EXPECT_LT(worst, 1e-9) << (type == SplineType::Bezier ? "bezier" : "bspline");
  }
}

// ---------------------------------------------------------------------------------------------
// Random flat grids: geodesics through vertices whose angle sum is 2 pi, along boundary edges and
// along chains of collinear edges, with control points on vertices, edges and faces; splines in
// both modes, paths between the first two control points, and the exponential map from the
// first.

struct GridCase {
  std::string name;
  TestMesh mesh;
  bool convex = true;  ///< no holes: geodesics are straight segments
  double size = 0;     ///< the grid's diagonal
};

/// Grid case `seed`: 2 to 24 cells a side, cell sizes from 0.01 to 3, every diagonal one way or
/// alternating, a random rotation in space, and for a quarter of the seeds a few interior cells
/// left out (holes: the domain is not convex).
GridCase random_grid(std::uint64_t seed) {
  Rng rng(seed * 7919 + 17);
  GridOptions o;
  o.nx = 2 + static_cast<int>(rng.below(23));
  o.ny = 2 + static_cast<int>(rng.below(23));
  const double h = std::pow(10.0, rng.uniform(-2, 0.5));
  o.hx = h;
  o.hy = rng.below(2) ? h : h * rng.uniform(0.5, 2);
  o.alternate_diagonals = rng.below(2) == 1;
  GridCase out;
  if (seed % 4 == 3 && o.nx >= 4 && o.ny >= 4) {
    const int hx = 1 + static_cast<int>(rng.below(static_cast<std::uint32_t>(o.nx - 2)));
    const int hy = 1 + static_cast<int>(rng.below(static_cast<std::uint32_t>(o.ny - 2)));
    o.remove_cell = [hx, hy](int i, int j) { return i == hx && j == hy; };
    out.convex = false;
  }
  MeshData d = flat_grid(o);
  // A rotation in space: about z, then tilted about x (the surface stays flat).
  const double a = rng.uniform(0, 2 * std::numbers::pi), b = rng.uniform(0, std::numbers::pi);
  for (Vec3& p : d.positions) {
    const Vec3 r{std::cos(a) * p.x - std::sin(a) * p.y, std::sin(a) * p.x + std::cos(a) * p.y, 0};
    p = {r.x, std::cos(b) * r.y, std::sin(b) * r.y};
  }
  out.name = "seed " + std::to_string(seed) + ": " + std::to_string(o.nx) + " x " +
             std::to_string(o.ny) + " cells of " + fmt(o.hx) + " x " + fmt(o.hy) +
             (o.alternate_diagonals ? ", alternating" : ", one-way") + " diagonals" +
             (out.convex ? "" : ", a hole");
  out.size = std::hypot(o.nx * o.hx, o.ny * o.hy);
  out.mesh = make_test_mesh(std::move(d));
  return out;
}

SurfacePoint random_point(const TriangleMesh& mesh, Rng& rng) {
  switch (rng.below(3)) {
    case 0: return SurfacePoint::vertex(rng.below(static_cast<std::uint32_t>(mesh.num_vertices())));
    case 1: return SurfacePoint::edge(rng.below(static_cast<std::uint32_t>(mesh.num_edges())),
                                      rng.uniform());
    default: {
      const std::array<double, 3> b = rng.barycentrics(0);
      return SurfacePoint::face(rng.below(static_cast<std::uint32_t>(mesh.num_faces())), b[0], b[1],
                                b[2]);
    }
  }
}

/// Runs `cases` random grids in both modes; returns the failures, one line each. Each case runs
/// under a deadline (a hang guard, not a timing), so that a runaway solve fails with its case.
std::vector<std::string> run_grid_cases(std::uint64_t first, std::uint64_t cases) {
  std::vector<std::string> failures;
  for (std::uint64_t seed = first; seed < first + cases; ++seed) {
    GridCase c = random_grid(seed);
    const TriangleMesh& mesh = *c.mesh.mesh;
    const GraphEnv env(c.mesh, 0, 0);
    GeodesicSpline spline(env.query);
    Rng rng(seed);
    GeodesicSplineOptions options;
    options.type = rng.below(2) ? SplineType::Bezier : SplineType::BSpline;
    const std::size_t count = options.type == SplineType::Bezier ? (rng.below(2) ? 4 : 7)
                                                                 : 4 + rng.below(3);
    std::vector<SurfacePoint> control;
    for (std::size_t k = 0; k < count; ++k) control.push_back(random_point(mesh, rng));
    const std::vector<Vec3> positions = positions_of(mesh, control);
    options.samples = 2 + rng.below(30);
    QueryInterrupt deadline;
    deadline.deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    options.interrupt = &deadline;
    std::string points;
    for (const SurfacePoint& p : control) {
      points += ' ';
      points += p.to_string();
    }
    for (SplineGeodesics mode : {SplineGeodesics::Exact, SplineGeodesics::Graph}) {
      options.geodesics = mode;
      const char* mode_name = mode == SplineGeodesics::Exact ? "exact" : "graph";
      try {
        const GeodesicSplineResult r = spline.compute(control, options);
        if (r.curve.size() != options.samples) {
          failures.push_back(c.name + ", " + mode_name + ": " + std::to_string(r.curve.size()) +
                             " curve points");
          continue;
        }
        // Both modes are exact up to rounding on a convex grid (the graph bounds the solves).
        const double worst = c.convex ? worst_planar_error(r, positions, options.type) : 0;
        const double allowed = (mode == SplineGeodesics::Exact ? 1e-9 : 5e-3) * c.size;
        const double end_error = norm(r.curve.front().position - positions.front());
        if (worst > allowed || (options.type == SplineType::Bezier && end_error > 1e-9 * c.size)) {
          failures.push_back(c.name + ", " + mode_name + ": off the planar curve by " +
                             fmt(worst / c.size) + " of the grid (ends " +
                             fmt(end_error / c.size) + "), control" + points);
        }
      } catch (const std::exception& e) {
        failures.push_back(c.name + ", " + mode_name + ": " + e.what() + ", control" + points);
      }
    }
    // Paths between the first two control points: the graph's path is as long as its distance
    // and never shorter than the straight line; the exact path is the straight line on a convex
    // grid.
    try {
      QueryScratch scratch = env.query.make_scratch();
      scratch.set_interrupt(&deadline);
      const double straight = norm(positions[1] - positions[0]);
      const PathResult graph_path = env.query.path(control[0], control[1], scratch);
      const PathResult exact_path = env.query.exact_path(control[0], control[1], scratch);
      double length = 0;
      for (std::size_t k = 1; k < graph_path.points.size(); ++k) {
        length += norm(graph_path.points[k].position - graph_path.points[k - 1].position);
      }
      if (std::abs(length - graph_path.distance) > 1e-9 * c.size ||
          graph_path.distance < straight - 1e-9 * c.size ||
          (c.convex && std::abs(exact_path.distance - straight) > 1e-9 * c.size)) {
        failures.push_back(c.name + ", path" + points + ": graph " + fmt(graph_path.distance) +
                           " (polyline " + fmt(length) + "), exact " +
                           fmt(exact_path.distance) + ", straight " + fmt(straight));
      }
    } catch (const std::exception& e) {
      failures.push_back(c.name + ", path" + points + ": " + e.what());
    }
    // The exponential map from the first control point: on a convex grid the exact one is an
    // isometry of the plane (distances and the distances between mapped vertices); the graph's
    // distances are never below exact.
    ExponentialMap map(env.query);
    ExponentialMapOptions map_options;
    map_options.radius = 0.4 * c.size;
    map_options.interrupt = &deadline;
    const std::string map_name = c.name + ", expmap from " + control[0].to_string();
    try {
      map_options.mode = ExponentialMapMode::Exact;
      const ExponentialMapResult exact = map.compute(control[0], map_options);
      map_options.mode = ExponentialMapMode::Graph;
      const ExponentialMapResult graph = map.compute(control[0], map_options);
      const Vec3 source = control[0].position(mesh);
      double worst = 0;
      const ExponentialMapVertex* previous = nullptr;
      for (const ExponentialMapVertex& m : exact.vertices) {
        const Vec3 at = mesh.position(m.vertex);
        worst = std::max(worst, std::abs(m.distance - norm(at - source)));
        if (previous) {
          const double planar = std::hypot(m.u - previous->u, m.v - previous->v);
          worst = std::max(worst, std::abs(planar - norm(at - mesh.position(previous->vertex))));
        }
        previous = &m;
      }
      if (c.convex && worst > 1e-9 * c.size) {
        failures.push_back(map_name + ": exact map off the plane's by " + fmt(worst / c.size));
      }
      for (const ExponentialMapVertex& m : graph.vertices) {
        if (m.distance < norm(mesh.position(m.vertex) - source) * (1 - 1e-9)) {
          failures.push_back(map_name + ": graph distance below the straight line at v:" +
                             std::to_string(m.vertex));
          break;
        }
      }
    } catch (const std::exception& e) {
      failures.push_back(map_name + ": " + e.what());
    }
  }
  return failures;
}

TEST(GeodesicSpline, RandomGridsGivePlanarSplinesPathsAndMaps) {
  const std::vector<std::string> failures = run_grid_cases(0, 120);
  for (const std::string& f : failures) ADD_FAILURE() << f;
}

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitized = true;  // sanitizers reserve terabytes of address space
#else
constexpr bool kSanitized = false;
#endif

[[noreturn]] void run_capped_grid_cases() {
  const rlimit cap{rlim_t{2} << 30, rlim_t{2} << 30};
  if (setrlimit(RLIMIT_AS, &cap) != 0) std::_Exit(2);
  const std::vector<std::string> failures = run_grid_cases(1000, 40);
  for (const std::string& f : failures) std::fprintf(stderr, "%s\n", f.c_str());
  std::_Exit(failures.empty() ? 0 : 1);
}

TEST(GeodesicSpline, RandomGridsStayUnderAnAddressSpaceCap) {
  if (kSanitized) GTEST_SKIP() << "an address-space cap does not combine with sanitizers";
  // In a child process capped at 2 GiB of address space (a grid case needs a few MiB): a
  // runaway allocation fails there as bad_alloc, named by its case, instead of taking the
  // machine.
  // The child re-executes this test alone ("threadsafe"): a fork of a process whose OpenMP
  // threads are running would hang in its first parallel region.
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(run_capped_grid_cases(), ::testing::ExitedWithCode(0), "");
}

TEST(GeodesicSpline, TheIssueGridBezierIsThePlanarOne) {
  // A 21 x 21-vertex grid over [0, 1]^2 at spacing 0.05, vertex id row * 21 + column, every
  // cell split along one diagonal: the case of the report (v:21 v:150 v:250 v:418, 3 samples).
  const TestMesh m = make_test_mesh(flat_grid({.nx = 20, .ny = 20, .hx = 0.05, .hy = 0.05,
                                               .alternate_diagonals = false}));
  const GraphEnv env(m, 0, 0);
  GeodesicSpline spline(env.query);
  const std::vector<SurfacePoint> control = {SurfacePoint::vertex(21), SurfacePoint::vertex(150),
                                             SurfacePoint::vertex(250), SurfacePoint::vertex(418)};
  const std::vector<Vec3> positions = positions_of(*m.mesh, control);
  GeodesicSplineOptions options;
  options.samples = 3;
  for (SplineGeodesics mode : {SplineGeodesics::Exact, SplineGeodesics::Graph}) {
    options.geodesics = mode;
    const GeodesicSplineResult r = spline.compute(control, options);
    ASSERT_EQ(r.curve.size(), 3u);
    // The middle point is (P0 + 3 P1 + 3 P2 + P3) / 8 = (0.53125, 0.4625).
    EXPECT_NEAR(r.curve[1].position.x, 0.53125, 1e-9);
    EXPECT_NEAR(r.curve[1].position.y, 0.4625, 1e-9);
    EXPECT_LT(worst_planar_error(r, positions, SplineType::Bezier), 1e-9);
  }
}

TEST(GeodesicSpline, BezierInterpolatesItsEndsAndJunctionsOnACurvedMesh) {
  const TestMesh& spot = test_support::spot();
  const GraphEnv env(spot, 0, 0);
  GeodesicSpline spline(env.query);
  // Control points close enough for the construction to be well defined (Nava-Yazdani &
  // Polthier): a walk away from vertex 10 in steps of ~0.15 (spot is ~2.6 across).
  std::vector<SurfacePoint> control = {SurfacePoint::vertex(10)};
  {
    ExactGeodesicSolver from_start(env.mesh, env.geometry), from_previous(env.mesh, env.geometry);
    from_start.solve(control[0]);
    for (int k = 1; k < 7; ++k) {
      from_previous.solve(control.back());
      std::int64_t best = -1;
      for (std::uint32_t v = 0; v < env.mesh.num_vertices(); ++v) {
        if (std::abs(from_previous.distance(v) - 0.15) < 0.03 &&
            (best < 0 || from_start.distance(v) > from_start.distance(static_cast<std::uint32_t>(best)))) {
          best = v;
        }
      }
      ASSERT_GE(best, 0);
      control.push_back(SurfacePoint::vertex(static_cast<std::uint32_t>(best)));
    }
  }
  std::vector<Vec3> exact_curve;
  for (SplineGeodesics geodesics : {SplineGeodesics::Exact, SplineGeodesics::Graph}) {
    GeodesicSplineOptions options;
    options.samples = 101;  // sample 50 is the junction at control point 3
    options.geodesics = geodesics;
    const GeodesicSplineResult r = spline.compute(control, options);
    ASSERT_EQ(r.curve.size(), 101u);
    EXPECT_EQ(r.curve.front().point.to_string(), control.front().to_string());
    EXPECT_EQ(r.curve.back().point.to_string(), control.back().to_string());
    EXPECT_EQ(r.curve[50].point.to_string(), control[3].to_string());
    EXPECT_NE(r.curve[25].point.to_string(), r.curve[75].point.to_string());
    // On the surface: every point is a valid surface point, its position is the point's.
    double step = 0;
    for (std::size_t k = 0; k < r.curve.size(); ++k) {
      EXPECT_NO_THROW(r.curve[k].point.validate(env.mesh)) << k;
      EXPECT_LT(norm(r.curve[k].position - r.curve[k].point.position(env.mesh)), 1e-12) << k;
      if (k > 0) step = std::max(step, norm(r.curve[k].position - r.curve[k - 1].position));
    }
    // A continuous curve: a planar cubic moves at most 3 * (longest leg) per unit parameter,
    // 50 samples per piece here; 1.5 of slack for curvature and graph paths.
    double longest_leg = 0;
    for (const auto& leg : r.control_polygon) {
      double length = 0;
      for (std::size_t k = 1; k < leg.size(); ++k) length += norm(leg[k].position - leg[k - 1].position);
      longest_leg = std::max(longest_leg, length);
    }
    if (geodesics == SplineGeodesics::Exact) {
      EXPECT_LT(step, 1.5 * 3 * longest_leg / 50) << "longest leg " << fmt(longest_leg);
      for (const PathPoint& p : r.curve) exact_curve.push_back(p.position);
    } else {
      // Graph geodesics longer than the link radius go through samples and are a little off
      // the exact ones (and may switch routes from one sample to the next): the curve stays
      // near the exact curve.
      double deviation = 0;
      for (std::size_t k = 0; k < r.curve.size(); ++k) {
        deviation = std::max(deviation, norm(r.curve[k].position - exact_curve[k]));
      }
      EXPECT_LT(deviation, 0.25 * longest_leg) << "longest leg " << fmt(longest_leg);
      RecordProperty("graph_vs_exact_deviation", fmt(deviation));
    }
    // 6 control legs, then 3 geodesics per sample (fewer at the ends of pieces).
    EXPECT_LE(r.geodesics, 6u + 3u * 101u);
    EXPECT_GT(r.geodesics, 6u + 2u * 101u);
    // Curve points spread over 2 threads (each with its own scratch) are the same points.
    options.threads = 2;
    const GeodesicSplineResult r2 = spline.compute(control, options);
    ASSERT_EQ(r2.curve.size(), r.curve.size());
    for (std::size_t k = 0; k < r.curve.size(); ++k) {
      EXPECT_EQ(r2.curve[k].point.to_string(), r.curve[k].point.to_string()) << k;
    }
    EXPECT_EQ(r2.geodesics, r.geodesics);
  }
}

TEST(GeodesicSpline, PointAlongAPathByIntrinsicArcLength) {
  const TriangleMesh& mesh = *grid().mesh;
  const IntrinsicGeometry& geometry = *grid().geometry;
  const SurfacePoint a = SurfacePoint::vertex(26), b = SurfacePoint::vertex(598);
  const GeodesicPath path = exact_geodesic_path(mesh, geometry, a, b);
  ASSERT_GT(path.points.size(), 5u);
  const Vec3 pa = a.position(mesh), pb = b.position(mesh);
  for (double u : {0.0, 0.1, 0.25, 0.5, 0.77, 1.0}) {
    const SurfacePoint p = point_along_path(mesh, geometry, path.points, u);
    EXPECT_NO_THROW(p.validate(mesh));
    EXPECT_LT(norm(p.position(mesh) - ((1 - u) * pa + u * pb)), 1e-12) << u;
  }
  EXPECT_EQ(point_along_path(mesh, geometry, path.points, 0).to_string(), a.to_string());
  EXPECT_EQ(point_along_path(mesh, geometry, path.points, 1).to_string(), b.to_string());
  EXPECT_THROW(point_along_path(mesh, geometry, {}, 0.5), InvalidInput);
}

TEST(GeodesicSpline, RefusesBadInput) {
  const TriangleMesh& mesh = *grid().mesh;
  GeodesicSpline exact_only(mesh, *grid().geometry);
  auto reason = [&](std::vector<SurfacePoint> control, GeodesicSplineOptions options) {
    try {
      exact_only.compute(control, options);
    } catch (const InvalidInput& e) {
      return e.reason();
    }
    return std::string("accepted");
  };
  GeodesicSplineOptions exact;
  exact.geodesics = SplineGeodesics::Exact;
  const std::vector<SurfacePoint> five(kGridControl.begin(), kGridControl.begin() + 5);
  const std::vector<SurfacePoint> three(kGridControl.begin(), kGridControl.begin() + 3);
  EXPECT_EQ(reason(five, exact), "BadControlPoints");  // Bezier: 3k + 1
  exact.type = SplineType::BSpline;
  EXPECT_EQ(reason(three, exact), "BadControlPoints");
  EXPECT_EQ(reason(five, exact), "accepted");
  exact.samples = 1;
  EXPECT_EQ(reason(five, exact), "BadSamples");
  exact.samples = 10;
  EXPECT_EQ(reason({SurfacePoint::vertex(0), SurfacePoint::vertex(1), SurfacePoint::vertex(2),
                    SurfacePoint::vertex(99999)},
                   exact),
            "VertexOutOfRange");
  GeodesicSplineOptions graph;
  EXPECT_EQ(reason(std::vector<SurfacePoint>(kGridControl.begin(), kGridControl.begin() + 4), graph),
            "NoGraph");
}

}  // namespace
}  // namespace geoprox
