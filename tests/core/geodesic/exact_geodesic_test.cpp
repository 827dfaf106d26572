// Tests of core/geodesic/exact_geodesic.h: analytic truth on synthetic surfaces (flat grids, cube, prism,
// cone, a saddle, planar domains with a notch or a hole), invariants on real meshes (symmetry,
// triangle inequality, paths, bounded and K-target solves, several sources, reuse) and
// robustness on ugly meshes (needles, caps, zero-area faces, boundaries, two components).
//
// Distances are compared to 1e-9 relative: |got - expected| <= 1e-9 * max(|expected|, floor),
// floor = 1e-4 * the mesh's bounding-box diagonal (so a zero distance must be zero to ~1e-13).
// On the ugly meshes (needles, slivers, caps, zero-area faces) the floor is the whole diagonal:
// there IntrinsicGeometry's layouts alone are off by up to ~2e-10 of the diagonal (cy computed
// as sqrt(ca^2 - cx^2) cancels for caps, cx = (ab^2+ca^2-bc^2)/2ab for a 1e-6 edge), so 1e-9 of
// the diagonal is what any solver reading those layouts can promise.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/geodesic/window_propagation.h"
#include "core/mesh/mesh_io.h"
#include "tests/core/test_meshes.h"
#include "tests/core/test_support.h"

namespace geoprox {
namespace {

using namespace test_meshes;

constexpr double kRel = 1e-9;

std::string fmt(double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

std::string fmt(const Vec3& p) { return "(" + fmt(p.x) + ", " + fmt(p.y) + ", " + fmt(p.z) + ")"; }

/// Accumulates many comparisons and reports the number of failures, the first few and the worst.
class Tally {
 public:
  /// floor_fraction: the tolerance floor as a fraction of `scale` (the bounding-box diagonal).
  Tally(std::string what, double scale, double floor_fraction = 1e-4, double rel = kRel)
      : what_(std::move(what)), floor_(floor_fraction * scale), rel_(rel) {}

  bool check(double got, double expected, const std::string& where) {
    ++count_;
    bool ok;
    double err;
    if (std::isinf(expected) || std::isinf(got)) {
      ok = got == expected;
      err = ok ? 0 : std::numeric_limits<double>::infinity();
    } else {
      err = std::abs(got - expected) / std::max(std::abs(expected), floor_);
      ok = err <= rel_;  // false for NaN
      if (std::isnan(got)) err = std::numeric_limits<double>::infinity();
    }
    if (err > worst_ || (!ok && worst_where_.empty())) {
      worst_ = err;
      worst_where_ = where + ": got " + fmt(got) + ", expected " + fmt(expected);
    }
    if (!ok) {
      ++failures_;
      if (examples_.size() < 6) examples_.push_back(where + ": got " + fmt(got) + ", expected " + fmt(expected));
    }
    return ok;
  }

  void fail(const std::string& where) {
    ++count_;
    ++failures_;
    if (examples_.size() < 6) examples_.push_back(where);
  }

  std::size_t count() const { return count_; }

  ::testing::AssertionResult result() const {
    if (failures_ == 0 && count_ > 0) return ::testing::AssertionSuccess();
    auto r = ::testing::AssertionFailure();
    r << what_ << ": " << failures_ << " of " << count_ << " checks failed (relative tolerance "
      << rel_ << ")";
    for (const std::string& e : examples_) r << "\n  " << e;
    if (!worst_where_.empty()) r << "\n  worst: " << worst_where_ << " (relative error " << worst_ << ")";
    return r;
  }

 private:
  std::string what_;
  double floor_;
  double rel_;
  std::size_t count_ = 0, failures_ = 0;
  double worst_ = 0;
  std::string worst_where_;
  std::vector<std::string> examples_;
};

/// The largest finite vertex distance of a solve.
double farthest_vertex_distance(const ExactGeodesicSolver& solver, const TriangleMesh& mesh) {
  double farthest = 0;
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    if (std::isfinite(solver.distance(v))) farthest = std::max(farthest, solver.distance(v));
  }
  return farthest;
}

using Truth = std::function<double(const SurfacePoint&)>;

/// Compares the solver's answers with `truth` at every vertex (distance(v), vertex_distances(),
/// distance(SurfacePoint::vertex)), at random face points and at random edge points.
void check_field(const ExactGeodesicSolver& solver, const Truth& truth, Tally& tally, Rng& rng,
                 int face_points = 40, int edge_points = 40,
                 const std::vector<std::uint32_t>& skip_vertices = {}) {
  const TriangleMesh& mesh = solver.mesh();
  const std::vector<double> all = solver.vertex_distances();
  if (all.size() != mesh.num_vertices()) {
    tally.fail("vertex_distances() has " + std::to_string(all.size()) + " entries, mesh has " +
               std::to_string(mesh.num_vertices()) + " vertices");
    return;
  }
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    if (std::find(skip_vertices.begin(), skip_vertices.end(), v) != skip_vertices.end()) continue;
    const double expected = truth(SurfacePoint::vertex(v));
    const std::string where = "vertex " + std::to_string(v) + " at " + fmt(mesh.position(v));
    tally.check(solver.distance(v), expected, "distance(" + where + ")");
    tally.check(all[v], expected, "vertex_distances()[" + where + "]");
    tally.check(solver.distance(SurfacePoint::vertex(v)), expected, "distance(SurfacePoint " + where + ")");
  }
  for (int k = 0; k < face_points; ++k) {
    const SurfacePoint p = random_face_point(mesh, rng);
    tally.check(solver.distance(p), truth(p), "distance(" + p.to_string() + ")");
  }
  for (int k = 0; k < edge_points; ++k) {
    const SurfacePoint p =
        SurfacePoint::edge(rng.below(static_cast<std::uint32_t>(mesh.num_edges())), rng.uniform());
    tally.check(solver.distance(p), truth(p), "distance(" + p.to_string() + ")");
  }
}

bool shares_face(const TriangleMesh& mesh, const SurfacePoint& a, const SurfacePoint& b) {
  const auto fa = incident_faces(mesh, a, 1e-9);
  const auto fb = incident_faces(mesh, b, 1e-9);
  for (std::uint32_t f : fa) {
    if (std::find(fb.begin(), fb.end(), f) != fb.end()) return true;
  }
  return false;
}

bool incident(const TriangleMesh& mesh, const SurfacePoint& p, std::uint32_t face) {
  const auto fs = incident_faces(mesh, p, 1e-9);
  return std::find(fs.begin(), fs.end(), face) != fs.end();
}

/// How to judge end directions: Curved (compare with the end segment only when it lies in the
/// direction's face), Planar (every face frame is in one plane: always compare with the end
/// segment), Straight (flat convex domain: the path is the segment source-target, compare with its
/// exact direction).
enum class Shape { Curved, Planar, Straight };

/// Checks a path from `source` (position) to `target` against the expected distance: length,
/// polyline length, end points, point positions, consecutive points on a common face, unit end
/// directions in a face incident to the end point and parallel to the end segment. On a planar
/// mesh every face frame is in the same plane, so the directions are compared whatever face holds
/// the end segment; otherwise only when the end segment lies in the direction's face (always the
/// case for an end point inside a face).
/// `offset`: the source's offset, included in path.length but not in the polyline.
/// `conditioning` widens the checks that compare the intrinsic path with the 3D positions
/// (polyline length, directions), for meshes whose intrinsic lengths are not those of the 3D
/// triangles; every mesh here passes with 1 (slivers and caps included).
void check_path(const TriangleMesh& mesh, const GeodesicPath& path, const SurfacePoint& source,
                const SurfacePoint& target, double expected, double scale, Shape shape,
                Tally& tally, const std::string& ctx, double offset = 0, double conditioning = 1) {
  const bool planar = shape != Shape::Curved;
  const std::string where = ctx + " path " + source.to_string() + " -> " + target.to_string();
  if (path.points.empty()) {
    tally.fail(where + ": no points");
    return;
  }
  tally.check(path.length, expected, where + ": length");
  double polyline = 0;
  for (std::size_t i = 0; i + 1 < path.points.size(); ++i) {
    polyline += dist(path.points[i + 1].position, path.points[i].position);
  }
  if (!(std::abs(polyline - (expected - offset)) <= 1e-9 * conditioning * std::max(expected, 1e-3 * scale))) {
    tally.fail(where + ": polyline length of " + std::to_string(path.points.size()) + " points: got " +
               fmt(polyline) + ", expected " + fmt(expected - offset));
  }
  const double pos_tol = 1e-10 * scale;
  const Vec3 src = source.position(mesh), dst = target.position(mesh);
  if (!(dist(path.points.front().position, src) <= pos_tol)) {
    tally.fail(where + ": starts at " + fmt(path.points.front().position) + ", source is at " + fmt(src));
  }
  if (!(dist(path.points.back().position, dst) <= pos_tol)) {
    tally.fail(where + ": ends at " + fmt(path.points.back().position) + ", target is at " + fmt(dst));
  }
  for (std::size_t i = 0; i < path.points.size(); ++i) {
    const PathPoint& pp = path.points[i];
    try {
      pp.point.validate(mesh);
    } catch (const Error& e) {
      tally.fail(where + ": point " + std::to_string(i) + " invalid: " + e.what());
      continue;
    }
    const Vec3 p = pp.point.position(mesh);
    if (!(dist(p, pp.position) <= pos_tol)) {
      tally.fail(where + ": point " + std::to_string(i) + " " + pp.point.to_string() + " has position " +
                 fmt(pp.position) + " but lies at " + fmt(p));
    }
    if (i + 1 < path.points.size() && !shares_face(mesh, pp.point, path.points[i + 1].point)) {
      tally.fail(where + ": consecutive points " + std::to_string(i) + " " + pp.point.to_string() +
                 " and " + path.points[i + 1].point.to_string() + " share no face");
    }
  }

  // End directions.
  const FaceDirection ds = path.direction_at_source, dt = path.direction_at_target;
  for (const auto& [d, name] : {std::pair{ds, "direction_at_source"}, std::pair{dt, "direction_at_target"}}) {
    if (!(d.face < mesh.num_faces()) || !(std::abs(std::hypot(d.x, d.y) - 1) <= 1e-12)) {
      tally.fail(where + ": " + name + " (face " + std::to_string(d.face) + ", " + fmt(d.x) + ", " +
                 fmt(d.y) + ") is not a unit vector of a face");
      return;
    }
  }
  // Or, on degenerate geometry, in a face around a vertex at exactly the end point's position.
  auto at_coincident_vertex = [&](const SurfacePoint& p, std::uint32_t f) {
    for (std::uint32_t v : mesh.face(f)) {
      if (dist(mesh.position(v), p.position(mesh)) == 0) return true;
    }
    return false;
  };
  // A source on the long side of a zero-area face leaves through that face: its direction is
  // given in the face across the zero-area one (which has no 2D frame of its own).
  auto across_zero_area = [&](const SurfacePoint& p, std::uint32_t f) {
    for (std::uint32_t g = 0; g < mesh.num_faces(); ++g) {
      const Triangle& t = mesh.face(g);
      const Vec3 n = cross(mesh.position(t[1]) - mesh.position(t[0]), mesh.position(t[2]) - mesh.position(t[0]));
      if (norm(n) != 0 || !incident(mesh, p, g)) continue;
      int shared = 0;
      for (std::uint32_t a : t) {
        for (std::uint32_t b : mesh.face(f)) shared += a == b ? 1 : 0;
      }
      if (shared == 2) return true;
    }
    return false;
  };
  if (!incident(mesh, path.points.front().point, ds.face) &&
      !across_zero_area(path.points.front().point, ds.face) &&
      !at_coincident_vertex(path.points.front().point, ds.face)) {
    tally.fail(where + ": direction_at_source is in face " + std::to_string(ds.face) +
               ", which does not contain the source " + path.points.front().point.to_string());
  }
  if (!incident(mesh, path.points.back().point, dt.face) &&
      !at_coincident_vertex(path.points.back().point, dt.face)) {
    tally.fail(where + ": direction_at_target is in face " + std::to_string(dt.face) +
               ", which does not contain the target " + path.points.back().point.to_string());
  }
  if (source.kind == SurfacePoint::Kind::Face && source.bary[0] > 0 && source.bary[1] > 0 &&
      source.bary[2] > 0 && ds.face != source.id && !across_zero_area(source, ds.face)) {
    tally.fail(where + ": source inside face " + std::to_string(source.id) +
               " but direction_at_source is in face " + std::to_string(ds.face));
  }
  if (target.kind == SurfacePoint::Kind::Face && target.bary[0] > 0 && target.bary[1] > 0 &&
      target.bary[2] > 0 && dt.face != target.id) {
    tally.fail(where + ": target inside face " + std::to_string(target.id) +
               " but direction_at_target is in face " + std::to_string(dt.face));
  }
  if (path.points.size() < 2 || expected - offset == 0) return;
  auto compare = [&](const FaceDirection& d, const PathPoint& from, const PathPoint& to,
                     const char* name) {
    const Vec3 seg = to.position - from.position;
    if (norm(seg) < 1e-6 * scale) return;  // too short to define a direction from positions
    if (!planar && !(incident(mesh, from.point, d.face) && incident(mesh, to.point, d.face))) return;
    const Vec3 want = normalized(seg);
    const Vec3 got = face_direction_3d(mesh, d.face, d.x, d.y);
    if (!(norm(got - want) <= 1e-7 * conditioning)) {
      tally.fail(where + ": " + name + " (face " + std::to_string(d.face) + ", " + fmt(d.x) + ", " +
                 fmt(d.y) + ") is " + fmt(got) + " in 3D, but the end segment runs along " + fmt(want));
    }
  };
  if (shape == Shape::Straight) {
    const Vec3 along = normalized(dst - src);
    for (const auto& [d, want, name] :
         {std::tuple{ds, along, "direction_at_source"}, std::tuple{dt, -1.0 * along, "direction_at_target"}}) {
      const Vec3 got = face_direction_3d(mesh, d.face, d.x, d.y);
      if (!(norm(got - want) <= 1e-7 * conditioning)) {
        tally.fail(where + ": " + name + " (face " + std::to_string(d.face) + ", " + fmt(d.x) + ", " + fmt(d.y) +
                   ") is " + fmt(got) + " in 3D, but the straight path runs along " + fmt(want));
      }
    }
    return;
  }
  compare(ds, path.points[0], path.points[1], "direction_at_source");
  compare(dt, path.points[path.points.size() - 1], path.points[path.points.size() - 2],
          "direction_at_target");
}

std::vector<GeodesicSource> one(const SurfacePoint& p, double offset = 0) {
  return {GeodesicSource{p, offset}};
}

struct FieldCheck {
  Shape shape = Shape::Curved;
  double floor = 1e-4;  ///< Tally floor as a fraction of the bounding-box diagonal
  int paths = 10;
  std::uint64_t seed = 7;
  double conditioning = 1;  ///< see check_path
};

/// Solves from `source` on a fresh solver and checks the whole field and paths to a few points.
void check_single_source(const TestMesh& tm, const SurfacePoint& source, const Truth& truth_from_source,
                         const std::string& ctx, const FieldCheck& fc = {}) {
  ExactGeodesicSolver solver(*tm.mesh, *tm.geometry);
  const double scale = bbox_diagonal(*tm.mesh);
  solver.solve(one(source));
  EXPECT_EQ(solver.radius_reached(), kInfinity) << ctx << ": a full solve reaches everything";
  Rng rng(fc.seed);
  Tally field(ctx + " from " + source.to_string(), scale, fc.floor);
  check_field(solver, truth_from_source, field, rng);
  EXPECT_TRUE(field.result());
  Tally path_tally(ctx + " paths from " + source.to_string(), scale, fc.floor);
  const int paths = fc.paths;
  const Shape planar = fc.shape;
  for (int k = 0; k < paths; ++k) {
    const SurfacePoint target = k % 3 == 2 ? SurfacePoint::vertex(rng.below(static_cast<std::uint32_t>(tm.mesh->num_vertices())))
                                           : random_face_point(*tm.mesh, rng);
    const double expected = truth_from_source(target);
    if (!std::isfinite(expected)) continue;
    check_path(*tm.mesh, solver.path_to(target), source, target, expected, scale, planar, path_tally, ctx, 0,
               fc.conditioning);
  }
  if (paths > 0) {
    EXPECT_TRUE(path_tally.result());
  }
}

Truth euclidean_from(const TriangleMesh& mesh, const SurfacePoint& s) {
  const Vec3 ps = s.position(mesh);
  return [&mesh, ps](const SurfacePoint& q) { return dist(q.position(mesh), ps); };
}

// ---------------------------------------------------------------------------------------------
// The reference distances themselves (no solver involved).

TEST(ExactGeodesicReference, KnownValues) {
  Cube cube = cube_surface(2, 1.0);
  EXPECT_NEAR(cube.polyhedron.distance({0.5, 0.5, 0}, {0.5, 0.5, 1}), 2.0, 1e-15);
  EXPECT_NEAR(cube.polyhedron.distance({0.5, 0.5, 0}, {0.5, 0, 0.5}), 1.0, 1e-15);
  EXPECT_NEAR(cube.polyhedron.distance({0, 0, 0}, {1, 1, 1}), std::sqrt(5.0), 1e-15);
  EXPECT_NEAR(cube.polyhedron.distance({0.2, 0.3, 0}, {0.2, 0.9, 0}), 0.6, 1e-15);
  // Adjacent faces z=0 and y=0 hinge on the x axis: unfold y=0 down.
  EXPECT_NEAR(cube.polyhedron.distance({0.2, 0.3, 0}, {0.7, 0, 0.4}), std::hypot(0.5, 0.7), 1e-15);
  // Opposite faces, near an edge: (0.1, 0.5, 0) to (0.1, 0.5, 1) over the face x=0.
  EXPECT_NEAR(cube.polyhedron.distance({0.1, 0.5, 0}, {0.1, 0.5, 1}), 1.2, 1e-15);
  // Symmetry of the reference on random pairs.
  Rng rng(3);
  for (int k = 0; k < 50; ++k) {
    Vec3 a{rng.uniform(), rng.uniform(), 0}, b{rng.uniform(), rng.uniform(), 1};
    EXPECT_NEAR(cube.polyhedron.distance(a, b), cube.polyhedron.distance(b, a), 1e-14);
    EXPECT_GE(cube.polyhedron.distance(a, b), dist(a, b));
  }

  Prism prism = prism_surface(1.0, 2.0, 4, 1);
  EXPECT_NEAR(prism.side, std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(prism.distance({0, 0}, {2 * prism.side, 0}), 2 * prism.side, 1e-15);
  EXPECT_NEAR(prism.distance({0, 0}, {3 * prism.side, 1}), std::hypot(prism.side, 1.0), 1e-14);

  Fan cone = cone_surface(1.0, std::sqrt(3.0), 64, 2);  // slant 2, Theta close to pi
  EXPECT_LT(cone.total_angle, std::numbers::pi);
  EXPECT_NEAR(cone.distance({1, 0}, {1, cone.total_angle / 2}), 2 * std::sin(cone.total_angle / 4), 1e-14);
  Fan saddle = saddle_surface(8, 0.5, 2);
  EXPECT_GT(saddle.total_angle, 2 * std::numbers::pi + 1);
  EXPECT_NEAR(saddle.distance({0.5, 0}, {0.7, saddle.total_angle / 2}), 1.2, 1e-15);

  PlanarDomain domain{0, 0, 4, 4, {{1, 1, 3, 3}}};
  EXPECT_NEAR(domain.distance({0, 2}, {4, 2}), 2 + 2 * std::sqrt(2.0), 1e-14);
  EXPECT_NEAR(domain.distance({0, 0.5}, {4, 0.5}), 4.0, 1e-15);  // passes below the hole
  EXPECT_NEAR(domain.distance({0, 1}, {4, 1}), 4.0, 1e-15);      // runs along its side
}

// ---------------------------------------------------------------------------------------------
// Flat grids: Euclidean distance.

TestMesh jittered_grid() {
  GridOptions o;
  o.nx = 16;
  o.ny = 12;
  o.hx = o.hy = 0.125;
  o.jitter = 0.2;
  o.seed = 11;
  return make_test_mesh(flat_grid(o));
}

TEST(ExactGeodesicFlat, VertexSources) {
  const TestMesh tm = jittered_grid();
  // Corner, bottom boundary, interior.
  for (std::uint32_t v : {0u, 7u, 5u * 17u + 9u, 17u * 13u - 1u}) {
    const SurfacePoint s = SurfacePoint::vertex(v);
    check_single_source(tm, s, euclidean_from(*tm.mesh, s), "flat grid", {Shape::Straight});
  }
}

TEST(ExactGeodesicFlat, EdgeSources) {
  const TestMesh tm = jittered_grid();
  const TriangleMesh& mesh = *tm.mesh;
  std::vector<SurfacePoint> sources;
  Rng rng(5);
  // Interior edges with asymmetric t (the parameter runs from edge_origin to edge_target).
  for (int k = 0; k < 3; ++k) {
    std::uint32_t e;
    do {
      e = rng.below(static_cast<std::uint32_t>(mesh.num_edges()));
    } while (mesh.is_boundary_edge(e));
    sources.push_back(SurfacePoint::edge(e, 0.3 + 0.2 * k));
  }
  // A boundary edge, and end points t = 0 and t = 1.
  for (std::uint32_t e = 0; e < mesh.num_edges(); ++e) {
    if (mesh.is_boundary_edge(e)) {
      sources.push_back(SurfacePoint::edge(e, 0.8));
      break;
    }
  }
  sources.push_back(SurfacePoint::edge(40, 0.0));
  sources.push_back(SurfacePoint::edge(41, 1.0));
  for (const SurfacePoint& s : sources) {
    check_single_source(tm, s, euclidean_from(mesh, s), "flat grid", {Shape::Straight});
  }
}

TEST(ExactGeodesicFlat, FaceSources) {
  const TestMesh tm = jittered_grid();
  Rng rng(9);
  std::vector<SurfacePoint> sources;
  for (int k = 0; k < 4; ++k) sources.push_back(random_face_point(*tm.mesh, rng));
  sources.push_back(SurfacePoint::face(100, 0.5, 0.5, 0));  // on an edge of the face
  sources.push_back(SurfacePoint::face(101, 0, 0, 1));      // a corner of the face
  sources.push_back(SurfacePoint::face(0, 0.9, 0.05, 0.05));  // near the grid corner
  for (const SurfacePoint& s : sources) {
    check_single_source(tm, s, euclidean_from(*tm.mesh, s), "flat grid", {Shape::Straight});
  }
}

TEST(ExactGeodesicFlat, SeveralSourcesWithOffsets) {
  const TestMesh tm = jittered_grid();
  const TriangleMesh& mesh = *tm.mesh;
  const std::vector<GeodesicSource> sources{
      {SurfacePoint::vertex(3), 0.0},
      {SurfacePoint::edge(200, 0.25), 0.3},
      {SurfacePoint::face(300, 0.2, 0.3, 0.5), 0.15},
      {SurfacePoint::face(17, 0.6, 0.2, 0.2), 0.9},  // probably wins nowhere but near itself
  };
  ExactGeodesicSolver solver(mesh, *tm.geometry);
  solver.solve(sources);
  const double scale = bbox_diagonal(mesh);
  auto truth_all = [&](const SurfacePoint& q, std::int32_t* arg, double* gap) {
    double best = kInfinity, second = kInfinity;
    std::int32_t which = -1;
    for (std::size_t i = 0; i < sources.size(); ++i) {
      const double d = sources[i].offset + dist(q.position(mesh), sources[i].point.position(mesh));
      if (d < best) {
        second = best;
        best = d;
        which = static_cast<std::int32_t>(i);
      } else {
        second = std::min(second, d);
      }
    }
    if (arg) *arg = which;
    if (gap) *gap = second - best;
    return best;
  };
  Tally tally("several sources with offsets", scale);
  Rng rng(1);
  check_field(solver, [&](const SurfacePoint& q) { return truth_all(q, nullptr, nullptr); }, tally, rng);
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    std::int32_t which;
    double gap;
    truth_all(SurfacePoint::vertex(v), &which, &gap);
    if (gap > 1e-9 && solver.nearest_source(v) != which) {
      tally.fail("nearest_source(" + std::to_string(v) + ") = " + std::to_string(solver.nearest_source(v)) +
                 ", expected " + std::to_string(which));
    }
  }
  EXPECT_TRUE(tally.result());
  Tally paths("several sources: paths", scale);
  for (int k = 0; k < 15; ++k) {
    const SurfacePoint t = random_face_point(mesh, rng);
    std::int32_t which;
    double gap;
    const double expected = truth_all(t, &which, &gap);
    const GeodesicPath path = solver.path_to(t);
    if (gap > 1e-9) {
      EXPECT_EQ(path.source_index, static_cast<std::uint32_t>(which)) << t.to_string();
    }
    ASSERT_LT(path.source_index, sources.size());
    // The path's length includes the source's offset; its polyline does not.
    const double off = sources[path.source_index].offset;
    check_path(mesh, path, sources[path.source_index].point, t, expected, scale, Shape::Straight, paths,
               "several sources", off);
  }
  EXPECT_TRUE(paths.result());
}

TEST(ExactGeodesicFlat, PathsAreStraight) {
  const TestMesh tm = jittered_grid();
  const TriangleMesh& mesh = *tm.mesh;
  ExactGeodesicSolver solver(mesh, *tm.geometry);
  const double scale = bbox_diagonal(mesh);
  Rng rng(21);
  Tally tally("flat grid paths", scale);
  for (int k = 0; k < 6; ++k) {
    const SurfacePoint s = k % 2 ? random_face_point(mesh, rng) : SurfacePoint::vertex(rng.below(221));
    solver.solve(s);
    for (int j = 0; j < 8; ++j) {
      const SurfacePoint t = random_face_point(mesh, rng);
      const GeodesicPath path = solver.path_to(t);
      check_path(mesh, path, s, t, dist(s.position(mesh), t.position(mesh)), scale, Shape::Straight, tally, "flat grid");
      // Straight: every point is on the segment s-t.
      const Vec3 a = s.position(mesh), b = t.position(mesh);
      for (const PathPoint& p : path.points) {
        const double off = norm(cross(normalized(b - a), p.position - a));
        if (!(off <= 1e-9 * scale)) tally.fail("path point " + p.point.to_string() + " is " + fmt(off) + " off the segment");
      }
    }
  }
  EXPECT_TRUE(tally.result());
}

TEST(ExactGeodesicFlat, Stats) {
  const TestMesh tm = jittered_grid();
  ExactGeodesicSolver solver(*tm.mesh, *tm.geometry);
  const SurfacePoint s = SurfacePoint::face(150, 0.2, 0.3, 0.5);
  solver.solve(s);
  const ExactGeodesicStats full = solver.stats();
  EXPECT_EQ(full.vertices_reached, tm.mesh->num_vertices());
  EXPECT_GT(full.windows_created, 0u);
  EXPECT_GT(full.windows_propagated, 0u);
  EXPECT_GT(full.peak_queue, 0u);
  // A bounded solve reaches exactly the vertices within its radius, with fewer windows.
  ExactGeodesicSolver::Options opt;
  opt.max_distance = 0.3;
  solver.solve(one(s), {}, opt);
  std::size_t inside = 0;
  for (std::uint32_t v = 0; v < tm.mesh->num_vertices(); ++v) {
    inside += dist(tm.mesh->position(v), s.position(*tm.mesh)) <= 0.3 ? 1 : 0;
  }
  EXPECT_EQ(solver.stats().vertices_reached, inside);
  EXPECT_LT(solver.stats().windows_created, full.windows_created);
  EXPECT_GT(solver.stats().windows_created, 0u);
}

TEST(ExactGeodesicFlat, ZeroLengthPath) {
  const TestMesh tm = jittered_grid();
  ExactGeodesicSolver solver(*tm.mesh, *tm.geometry);
  const SurfacePoint s = SurfacePoint::face(50, 0.2, 0.3, 0.5);
  solver.solve(s);
  EXPECT_EQ(solver.distance(s), 0.0);
  const GeodesicPath path = solver.path_to(s);
  EXPECT_EQ(path.length, 0.0);
  ASSERT_FALSE(path.points.empty());
  EXPECT_LE(dist(path.points.front().position, s.position(*tm.mesh)), 1e-15);
  EXPECT_EQ(path.direction_at_source.face, 50u);
  EXPECT_EQ(path.direction_at_source.x, 1.0);
  EXPECT_EQ(path.direction_at_source.y, 0.0);
  EXPECT_EQ(path.direction_at_target.face, 50u);
  EXPECT_EQ(path.direction_at_target.x, 1.0);
  EXPECT_EQ(path.direction_at_target.y, 0.0);
  solver.solve(SurfacePoint::vertex(40));
  EXPECT_EQ(solver.distance(40u), 0.0);
  EXPECT_EQ(solver.path_to(SurfacePoint::vertex(40)).length, 0.0);
}

// ---------------------------------------------------------------------------------------------
// Cube: shortest unfolding.

double cube_truth(const Cube& cube, const TriangleMesh& mesh, const SurfacePoint& a, const SurfacePoint& b) {
  return cube.polyhedron.distance(a.position(mesh), b.position(mesh));
}

TEST(ExactGeodesicCube, VertexFieldFromFacePoint) {
  const Cube cube = cube_surface(4, 1.5);
  const TestMesh tm = make_test_mesh(cube.data);
  for (const SurfacePoint& s : {SurfacePoint::face(40, 0.1, 0.6, 0.3), SurfacePoint::vertex(0),
                                SurfacePoint::face(150, 0.05, 0.05, 0.9)}) {
    check_single_source(tm, s, [&](const SurfacePoint& q) { return cube_truth(cube, *tm.mesh, s, q); },
                        "cube", {Shape::Curved});
  }
}

TEST(ExactGeodesicCube, AdjacentAndOppositeFaces) {
  const Cube cube = cube_surface(4, 1.5);
  const TestMesh tm = make_test_mesh(cube.data);
  const TriangleMesh& mesh = *tm.mesh;
  const double scale = bbox_diagonal(mesh);
  ExactGeodesicSolver solver(mesh, *tm.geometry);
  Rng rng(31);
  Tally adjacent("cube, adjacent faces", scale), opposite("cube, opposite faces", scale),
      paths("cube paths", scale);
  auto opposite_of = [](int f) { return f ^ 1; };
  for (int k = 0; k < 60; ++k) {
    const SurfacePoint s = random_face_point(mesh, rng, 0.0);
    SurfacePoint t;
    const bool want_opposite = k % 2 == 1;
    do {
      t = random_face_point(mesh, rng, 0.0);
      const int fs = tm.face_tag[s.id], ft = tm.face_tag[t.id];
      if (want_opposite ? ft == opposite_of(fs) : (ft != fs && ft != opposite_of(fs))) break;
    } while (true);
    const double expected = cube_truth(cube, mesh, s, t);
    solver.solve(s);
    const double d_st = solver.distance(t);
    solver.solve(t);
    const double d_ts = solver.distance(s);
    Tally& tally = want_opposite ? opposite : adjacent;
    tally.check(d_st, expected, "d(" + s.to_string() + ", " + t.to_string() + ")");
    tally.check(d_ts, expected, "d(" + t.to_string() + ", " + s.to_string() + ")");
    check_path(mesh, solver.path_to(s), t, s, expected, scale, Shape::Curved, paths, "cube");
  }
  EXPECT_TRUE(adjacent.result());
  EXPECT_TRUE(opposite.result());
  EXPECT_TRUE(paths.result());
}

// ---------------------------------------------------------------------------------------------
// Prism (open polygonal cylinder): unrolled strip.

Truth prism_truth(const Prism& prism, const TestMesh& tm, const SurfacePoint& s) {
  auto unroll = [&prism, &tm](const SurfacePoint& p) {
    const auto [f, b] = p.in_face(*tm.mesh);
    (void)b;
    return prism.unroll(p.position(*tm.mesh), tm.face_tag[f]);
  };
  const P2 us = unroll(s);
  return [&prism, unroll, us](const SurfacePoint& q) { return prism.distance(us, unroll(q)); };
}

TEST(ExactGeodesicPrism, UnrolledDistances) {
  const Prism prism = prism_surface(1.0, 2.0, 12, 6);
  const TestMesh tm = make_test_mesh(prism.data);
  const TriangleMesh& mesh = *tm.mesh;
  // Inside a face; on the bottom rim (boundary vertex); on a boundary edge; on a seam edge.
  std::uint32_t boundary_edge = 0, seam_edge = 0;
  for (std::uint32_t e = 0; e < mesh.num_edges(); ++e) {
    if (mesh.is_boundary_edge(e) && mesh.position(mesh.edge_origin(e)).z > 1) boundary_edge = e;
    const Vec3 a = mesh.position(mesh.edge_origin(e)), b = mesh.position(mesh.edge_target(e));
    if (a.x == b.x && a.y == b.y && a.z > 0.5 && seam_edge == 0) seam_edge = e;
  }
  for (const SurfacePoint& s :
       {SurfacePoint::face(30, 0.2, 0.3, 0.5), SurfacePoint::vertex(5), SurfacePoint::edge(boundary_edge, 0.35),
        SurfacePoint::edge(seam_edge, 0.6)}) {
    check_single_source(tm, s, prism_truth(prism, tm, s), "prism", {Shape::Curved});
  }
}

TEST(ExactGeodesicPrism, PairsBothWaysAround) {
  const Prism prism = prism_surface(0.7, 1.0, 9, 4);
  const TestMesh tm = make_test_mesh(prism.data);
  const TriangleMesh& mesh = *tm.mesh;
  const double scale = bbox_diagonal(mesh);
  ExactGeodesicSolver solver(mesh, *tm.geometry);
  Rng rng(41);
  Tally tally("prism pairs", scale), paths("prism paths", scale);
  for (int k = 0; k < 30; ++k) {
    const SurfacePoint s = random_face_point(mesh, rng), t = random_face_point(mesh, rng);
    const double expected = prism_truth(prism, tm, s)(t);
    solver.solve(s);
    tally.check(solver.distance(t), expected, "d(" + s.to_string() + ", " + t.to_string() + ")");
    check_path(mesh, solver.path_to(t), s, t, expected, scale, Shape::Curved, paths, "prism");
    solver.solve(t);
    tally.check(solver.distance(s), expected, "d(" + t.to_string() + ", " + s.to_string() + ")");
  }
  EXPECT_TRUE(tally.result());
  EXPECT_TRUE(paths.result());
}

// ---------------------------------------------------------------------------------------------
// Fans: faceted cone and a saddle vertex.

Truth fan_truth(const Fan& fan, const TestMesh& tm, const SurfacePoint& s) {
  auto develop = [&fan, &tm](const SurfacePoint& p) {
    const auto [f, b] = p.in_face(*tm.mesh);
    (void)b;
    return fan.develop(p.position(*tm.mesh), tm.face_tag[f]);
  };
  const P2 ds = develop(s);
  return [&fan, develop, ds](const SurfacePoint& q) { return fan.distance(ds, develop(q)); };
}

TEST(ExactGeodesicCone, DevelopedDistances) {
  const Fan cone = cone_surface(1.0, 1.5, 10, 5);
  ASSERT_LT(cone.total_angle, 2 * std::numbers::pi);
  const TestMesh tm = make_test_mesh(cone.data);
  // Apex: distance is the distance to the apex in space (along generators).
  check_single_source(tm, SurfacePoint::vertex(0),
                      [&](const SurfacePoint& q) { return dist(q.position(*tm.mesh), cone.apex); }, "cone",
                      {Shape::Curved});
  for (const SurfacePoint& s : {SurfacePoint::face(12, 0.3, 0.3, 0.4), SurfacePoint::vertex(1 + 2 * 10 + 3),
                                SurfacePoint::vertex(1 + 4 * 10 + 7) /* rim, boundary */}) {
    check_single_source(tm, s, fan_truth(cone, tm, s), "cone", {Shape::Curved});
  }
}

TEST(ExactGeodesicCone, PairsAndSymmetry) {
  const Fan cone = cone_surface(1.0, 0.6, 12, 4);  // flat cone: Theta close to 2 pi
  const TestMesh tm = make_test_mesh(cone.data);
  const TriangleMesh& mesh = *tm.mesh;
  const double scale = bbox_diagonal(mesh);
  ExactGeodesicSolver solver(mesh, *tm.geometry);
  Rng rng(43);
  Tally tally("cone pairs", scale), paths("cone paths", scale);
  for (int k = 0; k < 30; ++k) {
    const SurfacePoint s = random_face_point(mesh, rng), t = random_face_point(mesh, rng);
    const double expected = fan_truth(cone, tm, s)(t);
    solver.solve(s);
    tally.check(solver.distance(t), expected, "d(" + s.to_string() + ", " + t.to_string() + ")");
    check_path(mesh, solver.path_to(t), s, t, expected, scale, Shape::Curved, paths, "cone");
    solver.solve(t);
    tally.check(solver.distance(s), expected, "d(" + t.to_string() + ", " + s.to_string() + ")");
  }
  EXPECT_TRUE(tally.result());
  EXPECT_TRUE(paths.result());
}

TEST(ExactGeodesicSaddle, BendsAroundSaddleVertex) {
  const Fan saddle = saddle_surface(8, 0.5, 6);
  ASSERT_GT(saddle.total_angle, 2.5 * std::numbers::pi);
  const TestMesh tm = make_test_mesh(saddle.data);
  const TriangleMesh& mesh = *tm.mesh;
  const double scale = bbox_diagonal(mesh);
  ASSERT_TRUE(tm.geometry->is_pseudo_source(0)) << "the apex must be a saddle";
  // Whole fields from a face point and from a vertex.
  for (const SurfacePoint& s : {SurfacePoint::face(3, 0.2, 0.5, 0.3), SurfacePoint::vertex(1 + 2 * 8 + 1)}) {
    check_single_source(tm, s, fan_truth(saddle, tm, s), "saddle", {Shape::Curved});
  }
  // Pairs in sectors 0 and k: k = 2 is a straight chord (137 degrees apart), k = 3 and 4 are more
  // than 180 degrees apart both ways, so the path goes through the saddle vertex.
  ExactGeodesicSolver solver(mesh, *tm.geometry);
  Rng rng(47);
  Tally tally("saddle pairs", scale), paths("saddle paths", scale);
  std::vector<std::vector<std::uint32_t>> faces_in_sector(8);
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) faces_in_sector[tm.face_tag[f]].push_back(f);
  int chords = 0, bends = 0;
  for (int k = 0; k < 32; ++k) {
    const int sector_s = k % 8, sector_tt = (sector_s + 1 + k % 4) % 8;
    auto pick = [&](int sector) {
      const auto& fs = faces_in_sector[sector];
      const auto b = rng.barycentrics();
      return SurfacePoint::face(fs[rng.below(static_cast<std::uint32_t>(fs.size()))], b[0], b[1], b[2]);
    };
    const SurfacePoint s = pick(sector_s), t = pick(sector_tt);
    const double expected = fan_truth(saddle, tm, s)(t);
    solver.solve(s);
    tally.check(solver.distance(t), expected, "d(" + s.to_string() + ", " + t.to_string() + ")");
    const GeodesicPath path = solver.path_to(t);
    check_path(mesh, path, s, t, expected, scale, Shape::Curved, paths, "saddle");
    const double separation = saddle.separation(saddle.develop(s.position(mesh), sector_s),
                                                saddle.develop(t.position(mesh), sector_tt));
    const bool through_apex = separation > std::numbers::pi + 1e-6;
    bool has_apex = false;
    for (const PathPoint& p : path.points) has_apex |= dist(p.position, saddle.apex) < 1e-12;
    if (std::abs(separation - std::numbers::pi) > 1e-6) {
      (through_apex ? bends : chords) += 1;
      EXPECT_EQ(has_apex, through_apex)
          << "path " << s.to_string() << " -> " << t.to_string() << " (sectors " << sector_s << ", "
          << sector_tt << ", " << separation * 180 / std::numbers::pi << " degrees apart)";
    }
    if (through_apex) {
      const double rs = dist(s.position(mesh), saddle.apex), rt = dist(t.position(mesh), saddle.apex);
      tally.check(expected, rs + rt, "reference through the apex");
    }
    solver.solve(t);
    tally.check(solver.distance(s), expected, "d(" + t.to_string() + ", " + s.to_string() + ")");
  }
  EXPECT_GE(chords, 5);
  EXPECT_GE(bends, 5);
  EXPECT_TRUE(tally.result());
  EXPECT_TRUE(paths.result());
}

// ---------------------------------------------------------------------------------------------
// Planar domains with a reflex corner (L shape) or a hole.

Truth domain_truth(const PlanarDomain& domain, const TriangleMesh& mesh, const SurfacePoint& s) {
  const Vec3 ps = s.position(mesh);
  return [&domain, &mesh, ps](const SurfacePoint& q) {
    const Vec3 pq = q.position(mesh);
    return domain.distance({ps.x, ps.y}, {pq.x, pq.y});
  };
}

std::uint32_t vertex_at(const TriangleMesh& mesh, double x, double y) {
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    if (std::abs(mesh.position(v).x - x) < 1e-12 && std::abs(mesh.position(v).y - y) < 1e-12) return v;
  }
  throw std::logic_error("no vertex at (" + fmt(x) + ", " + fmt(y) + ")");
}

TEST(ExactGeodesicPlanarDomain, LShapeBendsAtReflexCorner) {
  const HoledGrid g = holed_grid(8, 8, 0.25, {{4, 4, 8, 8}});
  const TestMesh tm = make_test_mesh(g.data);
  const TriangleMesh& mesh = *tm.mesh;
  // Sources in the right arm (x > 1, y < 1): points in the top arm are around the corner (1, 1).
  std::uint32_t right_arm_face = 0;
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
    const Vec3 c = mesh.face_point(f, {1.0 / 3, 1.0 / 3, 1.0 / 3});
    if (c.x > 1.7 && c.y > 0.5 && c.y < 0.75) {
      right_arm_face = f;
      break;
    }
  }
  for (const SurfacePoint& s : {SurfacePoint::face(right_arm_face, 0.3, 0.3, 0.4),
                                SurfacePoint::vertex(vertex_at(mesh, 2.0, 0.5)),
                                SurfacePoint::vertex(vertex_at(mesh, 1.0, 1.0)) /* the reflex corner */}) {
    check_single_source(tm, s, domain_truth(g.domain, mesh, s), "L shape", {Shape::Planar});
  }
  // A point in the top arm is reached through the corner.
  ExactGeodesicSolver solver(mesh, *tm.geometry);
  const SurfacePoint s = SurfacePoint::vertex(vertex_at(mesh, 2.0, 0.25));
  const SurfacePoint t = SurfacePoint::vertex(vertex_at(mesh, 0.25, 2.0));
  solver.solve(s);
  const double expected = std::hypot(1.0, 0.75) * 2;
  EXPECT_NEAR(solver.distance(t), expected, kRel * expected);
  bool via_corner = false;
  for (const PathPoint& p : solver.path_to(t).points) via_corner |= dist(p.position, {1, 1, 0}) < 1e-12;
  EXPECT_TRUE(via_corner);
}

TEST(ExactGeodesicPlanarDomain, AroundAHole) {
  const HoledGrid g = holed_grid(12, 10, 0.25, {{4, 3, 8, 6}});  // hole [1,2] x [0.75,1.5]
  const TestMesh tm = make_test_mesh(g.data);
  const TriangleMesh& mesh = *tm.mesh;
  std::uint32_t hole_edge = 0, outer_edge = 0;
  for (std::uint32_t e = 0; e < mesh.num_edges(); ++e) {
    if (!mesh.is_boundary_edge(e)) continue;
    const Vec3 a = mesh.position(mesh.edge_origin(e));
    if (a.x > 0.9 && a.x < 2.1 && a.y > 0.7 && a.y < 1.6) hole_edge = e;
    if (a.y == 0 && a.x > 1) outer_edge = e;
  }
  for (const SurfacePoint& s :
       {SurfacePoint::vertex(vertex_at(mesh, 0.5, 1.0)), SurfacePoint::face(7, 0.1, 0.1, 0.8),
        SurfacePoint::vertex(vertex_at(mesh, 1.0, 0.75)) /* hole corner */,
        SurfacePoint::vertex(vertex_at(mesh, 1.5, 1.5)) /* hole side */, SurfacePoint::edge(hole_edge, 0.4),
        SurfacePoint::edge(outer_edge, 0.7)}) {
    check_single_source(tm, s, domain_truth(g.domain, mesh, s), "holed grid", {Shape::Planar});
  }
  // Across the hole: from the left side to the right side, both directions.
  ExactGeodesicSolver solver(mesh, *tm.geometry);
  const SurfacePoint a = SurfacePoint::vertex(vertex_at(mesh, 0.5, 1.0));
  const SurfacePoint b = SurfacePoint::vertex(vertex_at(mesh, 2.5, 1.25));
  const double expected = g.domain.distance({0.5, 1.0}, {2.5, 1.25});
  EXPECT_GT(expected, 2.0 + 1e-3);  // strictly longer than the blocked straight line
  solver.solve(a);
  EXPECT_NEAR(solver.distance(b), expected, kRel * expected);
  solver.solve(b);
  EXPECT_NEAR(solver.distance(a), expected, kRel * expected);
}

// ---------------------------------------------------------------------------------------------
// Ugly flat meshes: needles, slivers, caps, zero-area faces. Each is a flat convex rectangle, so
// the truth is the Euclidean distance and every path is a straight segment. Two tests per mesh:
// *Robust checks what the issue demands of ugly meshes whatever the precision (every vertex
// reached, no NaN, no exception, d(s,t) = d(t,s), never shorter than the straight line, valid
// paths); *Exact compares with the Euclidean truth (to 1e-9 of the mesh diagonal, see the top).

TestMesh needle_strip() {
  GridOptions o;
  o.nx = 200;
  o.ny = 1;
  o.hx = 1e-3;  // 1000:1 needles
  o.hy = 1.0;
  return make_test_mesh(flat_grid(o));
}

TestMesh sliver_columns() {
  // Columns alternately 1e-6 and 0.2 wide: triangles with a 1e-6 edge next to 0.3-long ones.
  GridOptions o;
  o.nx = 8;
  o.ny = 3;
  double x = 0;
  for (int i = 0; i <= o.nx; ++i) {
    o.xs.push_back(x);
    x += i % 2 == 0 ? 1e-6 : 0.2;
  }
  o.ys = {0, 0.3, 0.35, 1.0};
  return make_test_mesh(flat_grid(o));
}

// Cap grid: 8 x 8 cells of 0.125, grid vertex (i, j) = 9j + i, cell (i, j) is cell number 8j+i,
// its faces are 4*cell .. 4*cell+3 with the cap (p00, M, p11) at 4*cell + 2 and M = 81 + cell.
// The M of one column all have the same x, so straight paths run exactly through vertices.
TestMesh cap_mesh() { return make_test_mesh(cap_grid(8, 8, 0.125, 1e-7)); }
const std::vector<std::pair<int, int>> kZeroAreaCells{{3, 3}, {4, 4}, {0, 5}};
TestMesh zero_area_mesh() { return make_test_mesh(cap_grid(8, 8, 0.125, 1e-7, kZeroAreaCells)); }

/// Robustness on a flat convex mesh: from each of `points`, a full solve reaches every vertex
/// with a finite, non-negative, not-NaN distance >= the straight line; pairwise distances are
/// symmetric and >= the straight line; paths between the points are valid polylines.
void check_robust(const TestMesh& tm, const std::vector<SurfacePoint>& points, const std::string& ctx,
                  double conditioning = 1) {
  const TriangleMesh& mesh = *tm.mesh;
  const double scale = bbox_diagonal(mesh);
  ExactGeodesicSolver solver(mesh, *tm.geometry);
  Tally tally(ctx + " robustness", scale, 1.0);
  const std::size_t n = points.size();
  std::vector<std::vector<double>> d(n, std::vector<double>(n, kInfinity));
  for (std::size_t i = 0; i < n; ++i) {
    const std::string from = " from " + points[i].to_string();
    try {
      solver.solve(points[i]);
    } catch (const std::exception& e) {
      tally.fail("solve" + from + " threw: " + e.what());
      continue;
    }
    const Vec3 ps = points[i].position(mesh);
    const std::vector<double> all = solver.vertex_distances();
    for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
      const double x = all[v];
      if (!std::isfinite(x) || x < 0 || x < dist(ps, mesh.position(v)) - 1e-9 * scale) {
        tally.fail("vertex " + std::to_string(v) + " at distance " + fmt(x) + from + " (straight line " +
                   fmt(dist(ps, mesh.position(v))) + ")");
      }
    }
    for (std::size_t j = 0; j < n; ++j) {
      try {
        d[i][j] = solver.distance(points[j]);
        const GeodesicPath path = solver.path_to(points[j]);
        // Validity only (length = distance, endpoints, positions, faces, unit directions).
        check_path(mesh, path, points[i], points[j], d[i][j], scale, Shape::Curved, tally, ctx, 0, conditioning);
      } catch (const std::exception& e) {
        tally.fail("distance/path to " + points[j].to_string() + from + " threw: " + e.what());
      }
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < n; ++j) {
      const std::string pair = "d(" + points[i].to_string() + ", " + points[j].to_string() + ")";
      tally.check(d[i][j], d[j][i], pair + " vs reverse");
      const double straight = dist(points[i].position(mesh), points[j].position(mesh));
      if (!(d[i][j] >= straight - 1e-9 * scale)) {
        tally.fail(pair + " = " + fmt(d[i][j]) + " is shorter than the straight line " + fmt(straight));
      }
    }
  }
  EXPECT_TRUE(tally.result());
}

std::vector<SurfacePoint> needle_points() {
  return {SurfacePoint::vertex(0), SurfacePoint::vertex(100), SurfacePoint::vertex(401),
          SurfacePoint::face(133, 0.2, 0.3, 0.5), SurfacePoint::face(398, 0.1, 0.1, 0.8),
          SurfacePoint::edge(300, 0.5), SurfacePoint::edge(3, 0.25)};
}
std::vector<SurfacePoint> sliver_points() {
  return {SurfacePoint::vertex(0),   SurfacePoint::vertex(14),
          SurfacePoint::vertex(20),  SurfacePoint::vertex(35),
          SurfacePoint::face(5, 0.3, 0.3, 0.4), SurfacePoint::face(20, 0.1, 0.1, 0.8),
          SurfacePoint::face(45, 0.5, 0.25, 0.25), SurfacePoint::edge(20, 0.2663255246128744)};
}
std::vector<SurfacePoint> cap_points() {
  return {SurfacePoint::vertex(0),   SurfacePoint::vertex(81 + 27), SurfacePoint::vertex(81 + 3),
          SurfacePoint::vertex(81 + 62), SurfacePoint::face(4 * 20 + 2, 0.3, 0.3, 0.4),
          SurfacePoint::face(4 * 35, 0.25, 0.25, 0.5), SurfacePoint::vertex(40)};
}
std::vector<SurfacePoint> zero_area_points() {
  const std::uint32_t cell = 3 * 8 + 3, boundary_cell = 5 * 8 + 0;
  return {SurfacePoint::vertex(0),
          SurfacePoint::vertex(81 + cell),  // M on the zero-area face's long side
          SurfacePoint::face(4 * cell + 2, 0.2, 0.5, 0.3),  // inside the zero-area face
          SurfacePoint::face(4 * cell + 2, 0.5, 0, 0.5),
          SurfacePoint::face(4 * boundary_cell + 2, 0.3, 0.3, 0.4),
          SurfacePoint::face(4 * (cell + 1), 0.3, 0.3, 0.4),
          SurfacePoint::vertex(80)};
}

TEST(ExactGeodesicRobustness, NeedleStripRobust) { check_robust(needle_strip(), needle_points(), "needle strip"); }

TEST(ExactGeodesicRobustness, NeedleStripExact) {
  const TestMesh tm = needle_strip();
  for (const SurfacePoint& s : {needle_points()[0], needle_points()[1], needle_points()[3], needle_points()[5]}) {
    check_single_source(tm, s, euclidean_from(*tm.mesh, s), "needle strip", {Shape::Straight, 1.0, 5});
  }
}

TEST(ExactGeodesicRobustness, SliverColumnsRobust) {
  check_robust(sliver_columns(), sliver_points(), "sliver columns");
}

TEST(ExactGeodesicRobustness, SliverColumnsExact) {
  const TestMesh tm = sliver_columns();
  for (const SurfacePoint& s : sliver_points()) {
    check_single_source(tm, s, euclidean_from(*tm.mesh, s), "sliver columns", {Shape::Straight, 1.0, 6});
  }
}

TEST(ExactGeodesicRobustness, CapTrianglesRobust) { check_robust(cap_mesh(), cap_points(), "cap grid"); }

TEST(ExactGeodesicRobustness, CapTrianglesExact) {
  const TestMesh tm = cap_mesh();
  for (const SurfacePoint& s : cap_points()) {
    check_single_source(tm, s, euclidean_from(*tm.mesh, s), "cap grid", {Shape::Straight, 1.0});
  }
}

/// The issue's contract for paths holds on ugly meshes too: the polyline's length equals the
/// distance to 1e-9 relative. On these flat convex meshes the geodesic is the straight segment,
/// so the path points must also lie near it: to 1e-7 of the diagonal, not closer, because a
/// detour of d through a vertex next to the line of length L costs only d^2/2L, invisible in
/// double precision below d ~ sqrt(eps) L.
/// The *Robust / *Exact tests above widen the polyline and direction checks by `conditioning` on
/// slivers (1000) and caps (100). For caps that is inherent: a cap's 2e-7 rad angle rebuilt from
/// rounded edge lengths is only good to ~1e-9 rad, so the intrinsic development drifts from the
/// 3D one by ~1e-8 over a dozen caps. For slivers it is not: their layouts are accurate to ~1e-13,
/// yet the path v:14 -> v:20 on the sliver columns was reported through vertex v:21, 2.4e-7 off
/// the straight line (polyline 1.4e-7 relative longer than the exact distance it reports). So
/// this test holds slivers (and needles and zero-area faces) to the contract, caps excluded.
void check_straight_paths(const TestMesh& tm, const std::vector<SurfacePoint>& points, const std::string& ctx) {
  const TriangleMesh& mesh = *tm.mesh;
  const double scale = bbox_diagonal(mesh);
  ExactGeodesicSolver solver(mesh, *tm.geometry);
  Tally tally(ctx + " straight paths", scale, 1e-3);
  for (const SurfacePoint& a : points) {
    solver.solve(a);
    for (const SurfacePoint& b : points) {
      const Vec3 pa = a.position(mesh), pb = b.position(mesh);
      const double straight = dist(pa, pb);
      if (straight == 0) continue;
      const GeodesicPath path = solver.path_to(b);
      const std::string where = ctx + " path " + a.to_string() + " -> " + b.to_string();
      double polyline = 0;
      for (std::size_t i = 0; i + 1 < path.points.size(); ++i) {
        polyline += dist(path.points[i + 1].position, path.points[i].position);
      }
      tally.check(polyline, straight, where + ": polyline length of " + std::to_string(path.points.size()) + " points");
      double worst = 0;
      std::string worst_point;
      for (const PathPoint& p : path.points) {
        const double off = norm(cross(normalized(pb - pa), p.position - pa));
        if (off > worst) {
          worst = off;
          worst_point = p.point.to_string();
        }
      }
      if (!(worst <= 1e-7 * scale)) {
        tally.fail(where + ": point " + worst_point + " is " + fmt(worst) + " off the straight segment");
      }
    }
  }
  EXPECT_TRUE(tally.result());
}

TEST(ExactGeodesicRobustness, SliverPathsAreStraight) {
  check_straight_paths(sliver_columns(), sliver_points(), "sliver columns");
  check_straight_paths(zero_area_mesh(), zero_area_points(), "grid with zero-area faces");
  check_straight_paths(needle_strip(), needle_points(), "needle strip");
}

TEST(ExactGeodesicRobustness, ZeroAreaFacesRobust) {
  const TestMesh tm = zero_area_mesh();
  for (const auto& [i, j] : kZeroAreaCells) {
    const std::uint32_t cell = static_cast<std::uint32_t>(8 * j + i);
    ASSERT_TRUE(tm.geometry->is_degenerate_face(4 * cell + 2)) << "cell " << i << "," << j;
    ASSERT_FALSE(tm.geometry->is_degenerate_face(4 * cell + 1));
  }
  check_robust(tm, zero_area_points(), "grid with zero-area faces");
}

TEST(ExactGeodesicRobustness, ZeroAreaFacesExact) {
  // The zero-area face (p00, M, p11) glues the path p00-M-p11 to the straight side p00-p11; both
  // are the same segment, so the surface is still the flat square and paths cross it freely.
  const TestMesh tm = zero_area_mesh();
  for (const SurfacePoint& s : zero_area_points()) {
    check_single_source(tm, s, euclidean_from(*tm.mesh, s), "grid with zero-area faces", {Shape::Straight, 1.0});
  }
}

TEST(ExactGeodesicRobustness, BoundarySourcesSymmetric) {
  // Sources on boundary vertices and boundary edges of the holed grid and of a cone: d(s,t) =
  // d(t,s) and no NaN anywhere.
  const HoledGrid g = holed_grid(10, 8, 0.2, {{3, 2, 6, 5}});
  const TestMesh holed = make_test_mesh(g.data);
  const Fan cone = cone_surface(1.0, 0.8, 9, 3);
  const TestMesh cone_mesh = make_test_mesh(cone.data);
  for (const TestMesh* tm : {&holed, &cone_mesh}) {
    const TriangleMesh& mesh = *tm->mesh;
    std::vector<std::uint32_t> boundary;
    for (std::uint32_t e = 0; e < mesh.num_edges(); ++e) {
      if (mesh.is_boundary_edge(e)) boundary.push_back(e);
    }
    std::vector<SurfacePoint> points;
    for (std::size_t k = 0; k < 6; ++k) {
      const std::uint32_t e = boundary[k * boundary.size() / 6];
      points.push_back(SurfacePoint::edge(e, 0.37));
      points.push_back(SurfacePoint::vertex(mesh.edge_origin(boundary[(k * boundary.size() + 3) / 6])));
    }
    ExactGeodesicSolver solver(mesh, *tm->geometry);
    const double scale = bbox_diagonal(mesh);
    Tally tally(tm == &holed ? "holed grid boundary sources" : "cone boundary sources", scale);
    std::vector<std::vector<double>> d(points.size(), std::vector<double>(points.size()));
    for (std::size_t i = 0; i < points.size(); ++i) {
      solver.solve(points[i]);
      for (double x : solver.vertex_distances()) {
        if (!std::isfinite(x) || x < 0) tally.fail("bad vertex distance " + fmt(x) + " from " + points[i].to_string());
      }
      for (std::size_t j = 0; j < points.size(); ++j) d[i][j] = solver.distance(points[j]);
    }
    for (std::size_t i = 0; i < points.size(); ++i) {
      for (std::size_t j = 0; j < points.size(); ++j) {
        const std::string pair = "d(" + points[i].to_string() + ", " + points[j].to_string() + ")";
        tally.check(d[i][j], d[j][i], pair + " vs reverse");
        if (tm == &holed) {
          const Vec3 a = points[i].position(mesh), b = points[j].position(mesh);
          tally.check(d[i][j], g.domain.distance({a.x, a.y}, {b.x, b.y}), pair + " vs planar domain");
        } else {
          tally.check(d[i][j], fan_truth(cone, *tm, points[i])(points[j]), pair + " vs developed cone");
        }
      }
    }
    EXPECT_TRUE(tally.result());
  }
}

// ---------------------------------------------------------------------------------------------
// Random ugly meshes (test_meshes.h: ugly_rectangle, ugly_bumps): needles, slivers, caps,
// zero-area faces and coincident vertices mixed at random. A fixed set of seeds runs here;
// GEOPROX_STRESS_SEEDS=N runs seeds 1 to N instead, GEOPROX_STRESS_SEEDS=A-B seeds A to B (a soak
// run: bugs found that way get their seed added to the fixed set).

std::vector<std::uint64_t> stress_seeds(std::vector<std::uint64_t> fixed) {
  if (const char* n = std::getenv("GEOPROX_STRESS_SEEDS")) {
    // "N": seeds 1 to N; "A-B": seeds A to B.
    char* end = nullptr;
    std::uint64_t first = 1, last = std::strtoull(n, &end, 10);
    if (*end == '-') {
      first = last;
      last = std::strtoull(end + 1, nullptr, 10);
    }
    fixed.clear();
    for (std::uint64_t s = first; s <= last; ++s) fixed.push_back(s);
  }
  return fixed;
}

/// A few points of every kind on the mesh: vertices, edge points, points inside faces (any face,
/// degenerate ones included) and on a face's side (a zero barycentric).
std::vector<SurfacePoint> stress_points(const TriangleMesh& mesh, std::uint64_t seed) {
  Rng rng(seed ^ 0x5EEDull);
  const auto nv = static_cast<std::uint32_t>(mesh.num_vertices());
  const auto ne = static_cast<std::uint32_t>(mesh.num_edges());
  const auto nf = static_cast<std::uint32_t>(mesh.num_faces());
  std::vector<SurfacePoint> points{SurfacePoint::vertex(rng.below(nv)), SurfacePoint::vertex(rng.below(nv)),
                                   SurfacePoint::edge(rng.below(ne), rng.uniform()),
                                   SurfacePoint::edge(rng.below(ne), rng.uniform()),
                                   random_face_point(mesh, rng, 0), random_face_point(mesh, rng, 0)};
  const double b = rng.uniform();
  points.push_back(SurfacePoint::face(rng.below(nf), b, 1 - b, 0));
  return points;
}

/// Tolerances of check_stress.
struct StressTolerance {
  double flat = -1;        ///< |distance - straight line|, of the diagonal (negative: not flat)
  double straight = 1e-9;  ///< how far below the straight line a distance may come, of the diagonal
  double polyline = 1e-9;  ///< |3D polyline - distance|, of the diagonal
  /// One distance from two solves: d(s,t) vs d(t,s), and bounded or K-target vs full; relative.
  double agreement = 1e-9;
};

/// Hairline features (test_meshes.h: ugly_rectangle with thinnest 9 or 15): distances,
/// symmetry and the straight line hold to 1e-8 (one of 4,000 such meshes was asymmetric by
/// 1.5e-9, beside a needle of 1e-9); the 3D polylines to 1e-6 (in 2,000 meshes, one beyond
/// 1e-7): a path crossing the long side of a sliver at a grazing angle is placed along it only
/// to the layout's error divided by that angle, and such misplaced points zigzag. The paths'
/// intrinsic lengths still equal the distances.
StressTolerance hairline(bool flat) { return {flat ? 1e-8 : -1.0, 1e-8, 1e-6, 1e-8}; }

/// From each point: every vertex reached with a finite distance, at least the straight line
/// (within tolerance.straight), and on a flat mesh equal to it within tolerance.flat; between the
/// points, d(s,t) = d(t,s), and a path whose length is the distance, whose polyline is that long
/// and whose end directions are finite unit vectors. (The 3D directions are not compared: in
/// caps and zero-area faces the 3D frame itself is ill-conditioned or undefined.)
void check_stress(const TestMesh& tm, const std::vector<SurfacePoint>& points, const std::string& ctx,
                  const StressTolerance& tolerance) {
  const TriangleMesh& mesh = *tm.mesh;
  const double scale = bbox_diagonal(mesh);
  const double flat_tolerance = tolerance.flat;
  const double straight_tolerance = std::max(tolerance.straight, flat_tolerance) * scale;
  const double polyline_tolerance = std::max(tolerance.polyline, flat_tolerance) * scale;
  ExactGeodesicSolver solver(mesh, *tm.geometry);
  Tally tally(ctx, scale, 1.0, tolerance.agreement);
  const std::size_t n = points.size();
  std::vector<std::vector<double>> d(n, std::vector<double>(n, kInfinity));
  for (std::size_t i = 0; i < n; ++i) {
    const std::string from = " from " + points[i].to_string();
    solver.solve(points[i]);
    const Vec3 ps = points[i].position(mesh);
    for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
      const double x = solver.distance(v), straight = dist(ps, mesh.position(v));
      if (!std::isfinite(x) || x < straight - straight_tolerance ||
          (flat_tolerance >= 0 && !(std::abs(x - straight) <= flat_tolerance * scale))) {
        tally.fail("vertex " + std::to_string(v) + " at distance " + fmt(x) + from + " (straight line " +
                   fmt(straight) + ")");
      }
    }
    for (std::size_t j = 0; j < n; ++j) {
      const std::string where = ctx + " " + points[i].to_string() + " -> " + points[j].to_string();
      d[i][j] = solver.distance(points[j]);
      const double straight = dist(ps, points[j].position(mesh));
      if (flat_tolerance >= 0 && !(std::abs(d[i][j] - straight) <= flat_tolerance * scale)) {
        tally.fail(where + ": distance " + fmt(d[i][j]) + ", straight line " + fmt(straight));
      }
      const GeodesicPath path = solver.path_to(points[j]);
      tally.check(path.length, d[i][j], where + ": path length");
      double polyline = 0;
      for (std::size_t k = 0; k + 1 < path.points.size(); ++k) {
        polyline += dist(path.points[k + 1].position, path.points[k].position);
      }
      if (!(std::abs(polyline - d[i][j]) <= polyline_tolerance)) {
        tally.fail(where + ": polyline of " + std::to_string(path.points.size()) + " points is " + fmt(polyline) +
                   " long, distance " + fmt(d[i][j]));
      }
      for (const FaceDirection& e : {path.direction_at_source, path.direction_at_target}) {
        if (!(e.face < mesh.num_faces()) || !(std::abs(std::hypot(e.x, e.y) - 1) <= 1e-12)) {
          tally.fail(where + ": end direction (face " + std::to_string(e.face) + ", " + fmt(e.x) + ", " + fmt(e.y) +
                     ") is not a unit vector of a face");
        }
      }
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      tally.check(d[i][j], d[j][i], "d(" + points[i].to_string() + ", " + points[j].to_string() + ") vs reverse");
    }
  }
  EXPECT_TRUE(tally.result());
}

/// check_stress on ugly_rectangle(seed, thinnest), then from every vertex to every vertex (where
/// unreachable vertices and infinite loops were found), within `tolerance.flat` of the diagonal.
void check_flat_rectangle(std::uint64_t seed, double thinnest, const StressTolerance& tolerance) {
  const TestMesh tm = make_test_mesh(ugly_rectangle(seed, thinnest));
  const std::string ctx = "ugly rectangle " + std::to_string(seed) + " (thinnest 1e-" + fmt(thinnest) + ")";
  check_stress(tm, stress_points(*tm.mesh, seed), ctx, tolerance);
  const TriangleMesh& mesh = *tm.mesh;
  const double scale = bbox_diagonal(mesh);
  ExactGeodesicSolver solver(mesh, *tm.geometry);
  Tally tally(ctx + " vertex to vertex", scale, 1.0);
  for (std::uint32_t s = 0; s < mesh.num_vertices(); ++s) {
    solver.solve(SurfacePoint::vertex(s));
    for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
      const double straight = dist(mesh.position(s), mesh.position(v));
      if (!(std::abs(solver.distance(v) - straight) <= tolerance.flat * scale)) {
        tally.fail("v:" + std::to_string(s) + " -> v:" + std::to_string(v) + ": " + fmt(solver.distance(v)) +
                   ", straight line " + fmt(straight));
      }
    }
  }
  if (tally.count() == 0) tally.check(0, 0, "nothing failed");
  EXPECT_TRUE(tally.result());
}

TEST(ExactGeodesicRobustness, RandomUglyRectanglesAreFlat) {
  // The surface is the flat rectangle: every distance is the straight line. Within 1e-8 of the
  // diagonal rather than the 1e-9 of the fixed ugly meshes above: needles of 1e-6 next to caps
  // of 1e-7 compound their layouts' errors (up to 1.8e-9 seen). Before the fixes these seeds
  // found (windows going on along the line of a zero-area face, corners not reached yet reached by a
  // hair outside a window, directions along a zero-length side, the direction at a source on a
  // line of zero-area faces), vertex-to-vertex distances were off by more than 1e-6 on 120 of
  // 300 seeds, up to 80 times too long (seeds 57 and 220; paths through a zero-area fin or
  // across a column of coincident vertices bent at a vertex of the line), some end directions
  // were NaN or not unit vectors, and with needles down to 1e-9 some vertices were unreachable.
  // Seeds 13964 and 15533: paths along a line of zero-area faces went a hair past a vertex and
  // back (polylines 1.6e-7 and 2.2e-7 too long; the spur is now dropped). Seed 36888: distances
  // across a row of zero-area faces 2.4e-8 too long, their heights laid out 1.8e-9 from the
  // rounded lengths (now from the positions). Seeds 1374, 14721 and 34104: crossings of edges
  // lying along a path placed forward and back by up to 1e-7 (polylines up to 1.9e-7 too long;
  // path_to now straightens them).
  for (const std::uint64_t seed : stress_seeds({1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 19, 20, 57, 220, 1374,
                                                13964, 14721, 15533, 34104, 36888})) {
    check_flat_rectangle(seed, 6, {1e-8, 1e-8, 1e-8});
  }
}

TEST(ExactGeodesicRobustness, RandomHairlineRectanglesAreFlat) {
  // Needles and caps far thinner: down to 1e-9 and 1e-10 (a height of 1e-9 next to sides of 0.1
  // is laid out to ~1e-10), and down to 1e-15 and 1e-16, an ulp or two of the coordinates.
  // Before thin faces' corners became pseudo-sources (IntrinsicGeometryOptions::thin_face_ratio),
  // 34 of 1000 seeds at 1e-9 had vertex distances off by more than 1e-6 or unreachable (seed 8:
  // 21% too long, a path grazing along a band of slivers lost its window and went round; 43:
  // 5.7e-4), and at 1e-15 most seeds failed (4: twice too long, 14: unreachable, 16 and 17:
  // over 400 times too long); seed 331 at 1e-15 never finished: windows whose source sat at an
  // end of their own edge (a cluster of coincident vertices) went round it at an unchanging
  // key. Seed 2598 at 1e-9 (3% too long) and 2352 at 1e-15 (a polyline 17% longer than its
  // distance): a source 2.3e-14 off a sliver's long side was taken as on its line (see
  // kOnLineTolerance). Seeds 4595, 4653, 5245 and 7246 at 1e-15 (from points on edges and in
  // faces, 8-46% too long): a source on an edge's line, its interval trimmed down to it, saw
  // nothing of the face ahead (propagate). Seed 1935 at 1e-15 (a vertex 5% too long): trimming
  // cut such a window 7e-7 short of its source where another window merely tied with it
  // (keep_source_point). Seeds 15524 and 36888 at 1e-9: distances up to 4.6e-9 (1.6e-8 of the
  // diagonal) too long, through faces laid out from rounded lengths (now from the positions).
  // (Tolerances: hairline.)
  for (const std::uint64_t seed : stress_seeds({8, 32, 43, 93, 97, 295, 2598, 15524, 36888})) {
    check_flat_rectangle(seed, 9, hairline(true));
  }
  for (const std::uint64_t seed : stress_seeds({4, 14, 16, 17, 126, 331, 581, 1935, 2352, 4595, 4653, 5245, 7246})) {
    check_flat_rectangle(seed, 15, hairline(true));
  }
}

/// No analytic truth: symmetry, never below the straight line, valid paths; a solve bounded by a
/// radius agrees with the full solve inside it; the K-target stop settles the K nearest.
void check_bumps(std::uint64_t seed, double thinnest, const StressTolerance& tolerance) {
  const TestMesh tm = make_test_mesh(ugly_bumps(seed, thinnest));
  const TriangleMesh& mesh = *tm.mesh;
  const std::string ctx = "ugly bumps " + std::to_string(seed) + " (thinnest 1e-" + fmt(thinnest) + ")";
  const std::vector<SurfacePoint> points = stress_points(mesh, seed);
  check_stress(tm, points, ctx, tolerance);

  ExactGeodesicSolver full(mesh, *tm.geometry), bounded(mesh, *tm.geometry);
  const double scale = bbox_diagonal(mesh);
  // On hairline features to 1e-8 (seed 2843 at 1e-9 settled two targets 1.3e-9 of the diagonal
  // apart in the other order: what the queue pops is only as monotone as the layouts are
  // accurate).
  Tally tally(ctx + " bounded and K-target solves", scale, 1.0, tolerance.agreement);
  std::vector<SurfacePoint> vertices;
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) vertices.push_back(SurfacePoint::vertex(v));
  for (const SurfacePoint& s : points) {
    full.solve(s);
    std::vector<double> d = full.vertex_distances();
    std::vector<double> sorted = d;
    std::sort(sorted.begin(), sorted.end());
    const double radius = sorted[sorted.size() / 2];
    ExactGeodesicOptions within;
    within.max_distance = radius;
    bounded.solve(s, within);
    for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
      const std::string where = "vertex " + std::to_string(v) + " from " + s.to_string();
      // Near the radius either answer is right: within 1e-9 of the diagonal, or within the
      // two solves' agreement (on hairline features 1e-8: ugly_bumps(23013, 15) put a vertex
      // 5.6e-9 inside the radius in the full solve, and the bounded solve found it outside,
      // by less than 1e-8).
      if (std::abs(d[v] - radius) <= std::max(1e-9 * scale, tolerance.agreement * radius)) continue;
      tally.check(bounded.distance(v), d[v] <= radius ? d[v] : kInfinity, where + " within " + fmt(radius));
    }
    const std::size_t k = 1 + sorted.size() / 5;
    ExactGeodesicOptions nearest;
    nearest.stop_after_targets = k;
    bounded.solve(one(s), vertices, nearest);
    const std::vector<double>& settled = bounded.settled_target_distances();
    if (settled.size() != k) {
      tally.fail(std::to_string(settled.size()) + " targets settled from " + s.to_string() + ", asked " +
                 std::to_string(k));
      continue;
    }
    for (std::size_t i = 0; i < k; ++i) {
      const std::uint32_t v = bounded.settled_targets()[i];
      tally.check(settled[i], d[v], "settled vertex " + std::to_string(v) + " from " + s.to_string());
      tally.check(settled[i], sorted[i], "the " + std::to_string(i) + "th nearest from " + s.to_string());
    }
  }
  EXPECT_TRUE(tally.result());
}

TEST(ExactGeodesicRobustness, RandomUglyBumpsKeepTheInvariants) {
  // 3D polylines to 1e-8 of the diagonal, as on the flat rectangles: a path through faces 2e-8
  // thin is placed in 3D only to their layouts' conditioning (seed 3577: the polyline 2.3e-9
  // shorter than the path's intrinsic length, which equals the distance).
  const StressTolerance ugly{-1, 1e-9, 1e-8, 1e-9};
  for (const std::uint64_t seed : stress_seeds({1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 3577})) {
    check_bumps(seed, 6, ugly);
  }
}

TEST(ExactGeodesicRobustness, RandomHairlineBumpsKeepTheInvariants) {
  // At 1e-15 (an ulp or two of the coordinates), before short sides got their layouts from the
  // face's longest side and let no window through, distances came out up to 3.5e-5 below the
  // straight line (bumps 5, unfolded through a side of 1.5e-15 laid out 0.0023 off) and, from
  // points on edges and in faces beside such sides, polylines 1.4% longer than the distance
  // (bumps 18).
  // Seed 3883: a source on a cluster of coincident vertices settled them all at distance 0,
  // more targets than asked for; 2843 (see check_bumps).
  for (const std::uint64_t seed : stress_seeds({1, 2, 3, 4, 5, 6, 295, 2843, 3883})) {
    check_bumps(seed, 9, hairline(false));
  }
  for (const std::uint64_t seed : stress_seeds({1, 2, 3, 4, 5, 15, 18, 20, 3883})) {
    check_bumps(seed, 15, hairline(false));
  }
}

// ---------------------------------------------------------------------------------------------
// Several components and unreachable points.

TEST(ExactGeodesicComponents, UnreachableIsInfinityNeverZero) {
  GridOptions a;
  a.nx = 6;
  a.ny = 5;
  a.hx = a.hy = 0.2;
  GridOptions b;
  b.nx = 4;
  b.ny = 4;
  b.hx = b.hy = 0.3;
  b.x0 = 5;
  b.z0 = 1;
  MeshData data = concatenate(flat_grid(a), flat_grid(b));
  data.positions.push_back({9, 9, 9});  // an isolated vertex
  const std::uint32_t na = 7 * 6, nb = 5 * 5, isolated = na + nb;
  const std::uint32_t fa = 2 * 6 * 5;
  const TestMesh tm = make_test_mesh(std::move(data));
  const TriangleMesh& mesh = *tm.mesh;
  ASSERT_EQ(mesh.num_vertices(), na + nb + 1);
  const double scale = bbox_diagonal(mesh);
  ExactGeodesicSolver solver(mesh, *tm.geometry);

  const SurfacePoint sa = SurfacePoint::face(11, 0.2, 0.3, 0.5);
  const SurfacePoint sb = SurfacePoint::face(fa + 7, 0.6, 0.2, 0.2);
  const SurfacePoint in_b = SurfacePoint::face(fa + 20, 0.3, 0.3, 0.4);
  const SurfacePoint in_a = SurfacePoint::face(40, 0.3, 0.3, 0.4);

  solver.solve(sa);
  Tally tally("two components", scale);
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    const double expected = v < na ? dist(mesh.position(v), sa.position(mesh)) : kInfinity;
    tally.check(solver.distance(v), expected, "from component A, vertex " + std::to_string(v));
    tally.check(solver.vertex_distances()[v], expected, "vertex_distances()[" + std::to_string(v) + "]");
    if (v >= na && solver.nearest_source(v) != -1) tally.fail("nearest_source(" + std::to_string(v) + ") != -1");
  }
  EXPECT_EQ(solver.distance(in_b), kInfinity);
  EXPECT_EQ(solver.distance(SurfacePoint::vertex(isolated)), kInfinity);
  EXPECT_THROW((void)solver.path_to(in_b), Unreachable);
  EXPECT_THROW((void)solver.path_to(SurfacePoint::vertex(isolated)), Unreachable);

  // Both components at once: each gets its own field.
  const std::vector<GeodesicSource> both{{sa, 0}, {sb, 0.5}};
  solver.solve(both);
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    const double expected = v < na   ? dist(mesh.position(v), sa.position(mesh))
                            : v < na + nb ? 0.5 + dist(mesh.position(v), sb.position(mesh))
                                          : kInfinity;
    tally.check(solver.distance(v), expected, "both components, vertex " + std::to_string(v));
  }
  EXPECT_EQ(solver.nearest_source(3), 0);
  EXPECT_EQ(solver.nearest_source(na + 3), 1);
  EXPECT_EQ(solver.nearest_source(isolated), -1);
  const GeodesicPath pb = solver.path_to(in_b);
  EXPECT_EQ(pb.source_index, 1u);
  EXPECT_NEAR(pb.length, 0.5 + dist(in_b.position(mesh), sb.position(mesh)), 1e-12);
  const GeodesicPath pa = solver.path_to(in_a);
  EXPECT_EQ(pa.source_index, 0u);

  // From B, component A is unreachable; targets in A are never settled.
  const std::vector<SurfacePoint> targets{in_a, in_b, SurfacePoint::vertex(0)};
  ExactGeodesicSolver::Options opt;
  solver.solve(one(sb), targets, opt);
  ASSERT_EQ(solver.settled_targets().size(), 1u);
  EXPECT_EQ(solver.settled_targets()[0], 1u);
  EXPECT_EQ(solver.distance(in_a), kInfinity);
  EXPECT_EQ(solver.distance(0u), kInfinity);
  for (std::uint32_t v = 0; v < na; ++v) {
    tally.check(solver.distance(v), kInfinity, "from B with targets, vertex " + std::to_string(v));
  }
  EXPECT_TRUE(tally.result());
}

std::string reason_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.reason();
  }
  return "(nothing thrown)";
}

TEST(ExactGeodesicInput, InvalidSourcesThrow) {
  const TestMesh tm = jittered_grid();
  ExactGeodesicSolver solver(*tm.mesh, *tm.geometry);
  EXPECT_THROW(solver.solve(SurfacePoint::vertex(100000)), InvalidInput);
  EXPECT_THROW(solver.solve(SurfacePoint::face(0, 0.5, 0.6, 0.1)), InvalidInput);
  EXPECT_THROW(solver.solve(SurfacePoint::edge(0, 1.5)), InvalidInput);
  EXPECT_THROW(solver.solve(one(SurfacePoint::vertex(0), -1.0)), InvalidInput);
  EXPECT_THROW(solver.solve(one(SurfacePoint::vertex(0), std::nan(""))), InvalidInput);
  const std::vector<SurfacePoint> bad_targets{SurfacePoint::face(1u << 30, 1, 0, 0)};
  EXPECT_THROW(solver.solve(one(SurfacePoint::vertex(0)), bad_targets), InvalidInput);
  // A goal needs one target and a finite position.
  ExactGeodesicSolver::Options directed;
  directed.goal = tm.mesh->position(5);
  const std::vector<SurfacePoint> two{SurfacePoint::vertex(5), SurfacePoint::vertex(6)};
  const auto from_0 = one(SurfacePoint::vertex(0));
  EXPECT_EQ(reason_of([&] { solver.solve(from_0, {}, directed); }), "BadGoal");
  EXPECT_EQ(reason_of([&] { solver.solve(from_0, two, directed); }), "BadGoal");
  directed.goal = Vec3{std::nan(""), 0, 0};
  EXPECT_EQ(reason_of([&] { solver.solve(from_0, std::span(two).first(1), directed); }), "BadGoal");
  directed.goal = tm.mesh->position(5);
  for (const double limit : {-1.0, std::nan("")}) {
    directed.goal_limit = limit;
    EXPECT_EQ(reason_of([&] { solver.solve(from_0, std::span(two).first(1), directed); }),
              "BadRadius");
  }
  // The solver still works after the failures.
  solver.solve(SurfacePoint::vertex(0));
  EXPECT_NEAR(solver.distance(1u), dist(tm.mesh->position(0), tm.mesh->position(1)), 1e-15);
  EXPECT_THROW((void)solver.distance(SurfacePoint::face(99999, 1, 0, 0)), InvalidInput);
}

TEST(ExactGeodesicInput, GoalDirectedSolveOnAGridEnds) {
  // Found by the spline property test (geodesic_spline_test.cpp): on a flat grid, a
  // goal-directed solve to one target with no radius, from a face point a rounding error away
  // from a corner, kept propagating and never ended.
  const TestMesh tm = make_test_mesh(flat_grid({.nx = 13, .ny = 7, .hx = 0.013, .hy = 0.013}));
  const SurfacePoint from = SurfacePoint::face(62, 7.4014868308343812e-16, 0.99999999999999889,
                                               3.7007434154171842e-16);
  const SurfacePoint to = SurfacePoint::edge(28, 0.33333333333333326);
  ExactGeodesicSolver solver(*tm.mesh, *tm.geometry);
  ExactGeodesicSolver::Options directed;
  directed.stop_after_targets = 1;
  directed.goal = to.position(*tm.mesh);
  QueryInterrupt deadline;  // a hang guard, not a timing
  deadline.deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  directed.interrupt = &deadline;
  solver.solve(one(from), std::vector<SurfacePoint>{to}, directed);
  ASSERT_EQ(solver.settled_targets().size(), 1u);
  const double straight = dist(from.position(*tm.mesh), to.position(*tm.mesh));
  EXPECT_NEAR(solver.settled_target_distances()[0], straight, 1e-12);
  EXPECT_NEAR(solver.path_to(to).length, straight, 1e-12);
}

TEST(ExactGeodesicInput, PreparedTargets) {
  const TestMesh tm = jittered_grid(), other = jittered_grid();
  const std::vector<SurfacePoint> bad_vertex{SurfacePoint::vertex(0), SurfacePoint::vertex(100000)};
  EXPECT_EQ(reason_of([&] { GeodesicTargets t(*tm.geometry, bad_vertex); }), "VertexOutOfRange");
  const std::vector<SurfacePoint> bad_face{SurfacePoint::face(1u << 30, 1, 0, 0)};
  EXPECT_EQ(reason_of([&] { GeodesicTargets t(*tm.geometry, bad_face); }), "FaceOutOfRange");

  const std::vector<SurfacePoint> points{SurfacePoint::vertex(7), SurfacePoint::face(3, 0.2, 0.3, 0.5)};
  const GeodesicTargets prepared(*tm.geometry, points), elsewhere(*other.geometry, points);
  EXPECT_EQ(prepared.size(), 2u);
  ExactGeodesicSolver solver(*tm.mesh, *tm.geometry);
  EXPECT_EQ(reason_of([&] { solver.solve(one(SurfacePoint::vertex(0)), elsewhere); }), "TargetsForAnotherGeometry");
  // The same mesh under another metric (every edge twice as long): face targets sit in other
  // frames, so a set prepared with the embedding is refused there, and one prepared with the
  // metric settles where the targets given per solve do.
  std::vector<double> doubled = tm.geometry->edge_lengths();
  for (double& l : doubled) l *= 2;
  const IntrinsicGeometry metric(*tm.mesh, doubled);
  ExactGeodesicSolver metric_solver(*tm.mesh, metric);
  EXPECT_EQ(reason_of([&] { metric_solver.solve(one(SurfacePoint::vertex(0)), prepared); }), "TargetsForAnotherGeometry");
  metric_solver.solve(one(SurfacePoint::vertex(0)), points);
  const std::vector<double> per_solve = metric_solver.settled_target_distances();
  metric_solver.solve(one(SurfacePoint::vertex(0)), GeodesicTargets(metric, points));
  EXPECT_EQ(metric_solver.settled_target_distances(), per_solve);
  ASSERT_EQ(per_solve.size(), 2u);
  EXPECT_NEAR(per_solve[1], 2 * dist(tm.mesh->position(0), points[metric_solver.settled_targets()[1]].position(*tm.mesh)), 1e-12);
  // A span with a bad point leaves the solver's own set as it was: the next solve is right.
  const std::vector<SurfacePoint> half_bad{SurfacePoint::vertex(3), SurfacePoint::face(3, 0.5, 0.6, 0.1)};
  EXPECT_EQ(reason_of([&] { solver.solve(one(SurfacePoint::vertex(0)), half_bad); }), "BadBarycentric");
  // An empty set is a solve without targets: the whole surface.
  const GeodesicTargets none(*tm.geometry, std::vector<SurfacePoint>{});
  EXPECT_TRUE(none.empty());
  solver.solve(one(SurfacePoint::vertex(0)), none);
  const std::vector<double> with_empty_set = solver.vertex_distances();
  EXPECT_TRUE(solver.settled_targets().empty());
  solver.solve(one(SurfacePoint::vertex(0)), {}, {});
  EXPECT_EQ(with_empty_set, solver.vertex_distances());
  for (double d : with_empty_set) EXPECT_LT(d, kInfinity);
  // Both targets are settled, at their exact (Euclidean, on this flat grid) distances.
  solver.solve(one(SurfacePoint::vertex(0)), points);
  EXPECT_EQ(solver.settled_targets().size(), 2u);
  solver.solve(one(SurfacePoint::vertex(0)), prepared);
  ASSERT_EQ(solver.settled_targets().size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const SurfacePoint& p = points[solver.settled_targets()[k]];
    EXPECT_NEAR(solver.settled_target_distances()[k], dist(tm.mesh->position(0), p.position(*tm.mesh)), 1e-12);
  }
}

// ---------------------------------------------------------------------------------------------
// Real meshes: invariants.

std::optional<std::string> find_mesh(const std::string& name, bool repo_only = false) {
  const std::string repo = std::string(GEOPROX_SOURCE_DIR) + "/data/meshes/" + name;
  if (std::filesystem::exists(repo)) return repo;
  if (repo_only) return std::nullopt;
  return test_support::corpus_mesh_file(name);
}

struct LoadedMesh {
  std::unique_ptr<TriangleMesh> mesh;
  std::unique_ptr<IntrinsicGeometry> geometry;
  double scale = 1;
};

const LoadedMesh* load_cached(const std::string& name) {
  static std::map<std::string, std::unique_ptr<LoadedMesh>> cache;
  auto it = cache.find(name);
  if (it != cache.end()) return it->second.get();
  std::unique_ptr<LoadedMesh> out;
  if (auto path = find_mesh(name)) {
    out = std::make_unique<LoadedMesh>();
    out->mesh = std::make_unique<TriangleMesh>(load_mesh(*path));
    out->geometry = std::make_unique<IntrinsicGeometry>(*out->mesh);
    out->scale = bbox_diagonal(*out->mesh);
  }
  return cache.emplace(name, std::move(out)).first->second.get();
}

struct RealMeshCase {
  const char* name;
  int pairs;  ///< symmetry pairs; other counts scale with it (keeps the suite under a minute)
};

class ExactGeodesicRealMesh : public ::testing::TestWithParam<RealMeshCase> {
 protected:
  void SetUp() override {
    lm_ = load_cached(GetParam().name);
    ASSERT_TRUE(lm_) << GetParam().name << " is neither in data/meshes nor in "
                     << test_support::corpus_dir();
  }
  const TriangleMesh& mesh() const { return *lm_->mesh; }
  const IntrinsicGeometry& geometry() const { return *lm_->geometry; }
  double scale() const { return lm_->scale; }
  /// Number of repetitions: `full` on the main mesh (50 pairs), fewer on the others.
  int count(int full, int minimum) const { return std::max(minimum, full * GetParam().pairs / 50); }
  std::uint32_t random_vertex(Rng& rng) const {
    return rng.below(static_cast<std::uint32_t>(mesh().num_vertices()));
  }
  const LoadedMesh* lm_ = nullptr;
};

/// The same point written every way: as an edge point, and as a face point in each face of the
/// edge; a vertex as a vertex, as a corner of each of its faces and as an end of its edges. One
/// solve must give every spelling the same distance.
TEST_P(ExactGeodesicRealMesh, PointSpellingsAgree) {
  ExactGeodesicSolver solver(mesh(), geometry());
  Rng rng(97);
  Tally tally(std::string(GetParam().name) + " spellings of one point", scale());
  for (int k = 0; k < count(8, 3); ++k) {
    const SurfacePoint s = random_face_point(mesh(), rng);
    solver.solve(s);
    const std::string from = " from " + s.to_string();
    for (int j = 0; j < 150; ++j) {
      const std::uint32_t e = rng.below(static_cast<std::uint32_t>(mesh().num_edges()));
      const double t = rng.uniform();
      const SurfacePoint edge_point = SurfacePoint::edge(e, t);
      const double d = solver.distance(edge_point);
      const std::uint32_t h = mesh().edge_halfedge(e);
      for (std::int32_t hh : {static_cast<std::int32_t>(h), mesh().twin(h)}) {
        if (hh < 0) continue;
        const auto uh = static_cast<std::uint32_t>(hh);
        std::array<double, 3> b{0, 0, 0};
        const bool same_direction = mesh().origin(uh) == mesh().edge_origin(e);
        b[uh % 3] = same_direction ? 1 - t : t;
        b[(uh % 3 + 1) % 3] = same_direction ? t : 1 - t;
        const SurfacePoint fp = SurfacePoint::face(uh / 3, b[0], b[1], b[2]);
        tally.check(solver.distance(fp), d, fp.to_string() + " vs " + edge_point.to_string() + from);
      }
    }
    for (int j = 0; j < 15; ++j) {
      const std::uint32_t v = random_vertex(rng);
      const double d = solver.distance(v);
      tally.check(solver.distance(SurfacePoint::vertex(v)), d, "SurfacePoint::vertex(" + std::to_string(v) + ")" + from);
      for (std::uint32_t h : mesh().outgoing_halfedges(v)) {
        std::array<double, 3> b{0, 0, 0};
        b[h % 3] = 1;
        const SurfacePoint fp = SurfacePoint::face(h / 3, b[0], b[1], b[2]);
        tally.check(solver.distance(fp), d, fp.to_string() + " vs vertex " + std::to_string(v) + from);
        const std::uint32_t e = mesh().edge_of(h);
        const SurfacePoint ep = SurfacePoint::edge(e, mesh().edge_origin(e) == v ? 0.0 : 1.0);
        tally.check(solver.distance(ep), d, ep.to_string() + " vs vertex " + std::to_string(v) + from);
      }
    }
  }
  EXPECT_TRUE(tally.result());
}

/// d(s,t) = d(t,s) where s and t are edge points and vertices (full solves both ways).
TEST_P(ExactGeodesicRealMesh, SymmetryOfEdgePointsAndVertices) {
  ExactGeodesicSolver solver(mesh(), geometry());
  Rng rng(99);
  Tally tally(std::string(GetParam().name) + " symmetry of edge points and vertices", scale());
  for (int k = 0; k < count(16, 4); ++k) {
    const SurfacePoint s = SurfacePoint::edge(rng.below(static_cast<std::uint32_t>(mesh().num_edges())), rng.uniform());
    const SurfacePoint t = k % 2 ? SurfacePoint::vertex(random_vertex(rng))
                                 : SurfacePoint::edge(rng.below(static_cast<std::uint32_t>(mesh().num_edges())), rng.uniform());
    solver.solve(s);
    const double st = solver.distance(t);
    solver.solve(t);
    const double ts = solver.distance(s);
    tally.check(ts, st, "d(" + t.to_string() + ", " + s.to_string() + ") vs d(s,t)");
  }
  EXPECT_TRUE(tally.result());
}

TEST_P(ExactGeodesicRealMesh, Symmetry) {
  ExactGeodesicSolver solver(mesh(), geometry());
  Rng rng(101);
  Tally tally(std::string(GetParam().name) + " symmetry", scale());
  for (int k = 0; k < GetParam().pairs; ++k) {
    const SurfacePoint s = random_face_point(mesh(), rng, 0.0), t = random_face_point(mesh(), rng, 0.0);
    solver.solve(s);
    const double st = solver.distance(t);
    solver.solve(t);
    const double ts = solver.distance(s);
    if (!std::isfinite(st) || !std::isfinite(ts)) {
      tally.fail("d(" + s.to_string() + ", " + t.to_string() + ") = " + fmt(st) + ", reverse " + fmt(ts));
      continue;
    }
    tally.check(ts, st, "d(" + t.to_string() + ", " + s.to_string() + ") vs d(s,t)");
    if (!(st >= dist(s.position(mesh()), t.position(mesh())) * (1 - 1e-12))) {
      tally.fail("d(" + s.to_string() + ", " + t.to_string() + ") = " + fmt(st) + " is shorter than the straight line");
    }
  }
  EXPECT_TRUE(tally.result());
}

TEST_P(ExactGeodesicRealMesh, TriangleInequality) {
  ExactGeodesicSolver solver(mesh(), geometry());
  Rng rng(103);
  Tally tally(std::string(GetParam().name) + " triangle inequality", scale());
  for (int k = 0; k < count(16, 4); ++k) {
    const SurfacePoint a = random_face_point(mesh(), rng), b = random_face_point(mesh(), rng),
                       c = k % 2 ? random_face_point(mesh(), rng)
                                 : SurfacePoint::vertex(rng.below(static_cast<std::uint32_t>(mesh().num_vertices())));
    solver.solve(a);
    const double ab = solver.distance(b), ac = solver.distance(c);
    solver.solve(b);
    const double bc = solver.distance(c);
    const double slack = kRel * (ab + bc + 1e-4 * scale());
    if (!(ac <= ab + bc + slack) || !(ab <= ac + bc + slack) || !(bc <= ab + ac + slack)) {
      tally.fail("a=" + a.to_string() + " b=" + b.to_string() + " c=" + c.to_string() + ": d(a,b)=" + fmt(ab) +
                 " d(b,c)=" + fmt(bc) + " d(a,c)=" + fmt(ac));
    } else {
      tally.check(0, 0, "ok");
    }
  }
  EXPECT_TRUE(tally.result());
}

TEST_P(ExactGeodesicRealMesh, Paths) {
  ExactGeodesicSolver solver(mesh(), geometry());
  Rng rng(107);
  Tally tally(std::string(GetParam().name) + " paths", scale());
  const int sources = count(5, 2);
  for (int k = 0; k < sources; ++k) {
    const SurfacePoint s = k % 3 == 0   ? SurfacePoint::vertex(rng.below(static_cast<std::uint32_t>(mesh().num_vertices())))
                           : k % 3 == 1 ? SurfacePoint::edge(rng.below(static_cast<std::uint32_t>(mesh().num_edges())), rng.uniform())
                                        : random_face_point(mesh(), rng);
    solver.solve(s);
    for (int j = 0; j < 12; ++j) {
      const SurfacePoint t = j % 4 == 3 ? SurfacePoint::vertex(rng.below(static_cast<std::uint32_t>(mesh().num_vertices())))
                                        : random_face_point(mesh(), rng);
      const double d = solver.distance(t);
      if (!std::isfinite(d)) {
        tally.fail("d(" + s.to_string() + ", " + t.to_string() + ") is not finite on a connected mesh");
        continue;
      }
      check_path(mesh(), solver.path_to(t), s, t, d, scale(), Shape::Curved, tally, GetParam().name);
    }
  }
  EXPECT_TRUE(tally.result());
}

TEST_P(ExactGeodesicRealMesh, BoundedSolveAgreesWithFullSolve) {
  ExactGeodesicSolver full(mesh(), geometry());
  detail::WindowPropagation bounded(mesh(), geometry());  // both queue strategies
  Rng rng(109);
  Tally tally(std::string(GetParam().name) + " bounded solve", scale());
  std::size_t beyond_stop = 0;
  for (int k = 0; k < count(3, 2); ++k) {
    const SurfacePoint s = k == 0 ? SurfacePoint::vertex(rng.below(static_cast<std::uint32_t>(mesh().num_vertices())))
                                  : random_face_point(mesh(), rng);
    full.solve(s);
    const std::vector<double> d = full.vertex_distances();
    std::vector<double> sorted;
    for (double x : d) {
      if (std::isfinite(x)) sorted.push_back(x);
    }
    std::sort(sorted.begin(), sorted.end());
    // Radii halfway between two consecutive vertex distances (no vertex sits on the bound):
    // about 20 vertices, 1% of them, and 30%.
    // Each radius with one queue entry per window, then with halfedges queued.
    const std::array<std::size_t, 3> ranks{20, sorted.size() / 100, sorted.size() * 3 / 10};
    std::size_t per_window_pops = 0;
    for (std::size_t run = 0; run < 2 * ranks.size(); ++run) {
      std::size_t rank = ranks[run / 2];
      rank = std::clamp<std::size_t>(rank, 1, sorted.size() - 1);
      const double r = 0.5 * (sorted[rank - 1] + sorted[rank]);
      ExactGeodesicSolver::Options opt;
      opt.max_distance = r;
      const bool queue_halfedges = run % 2 == 1;
      bounded.force_queue_strategy(queue_halfedges);
      bounded.solve(one(s), {}, opt);
      beyond_stop += bounded.stats().windows_beyond_stop;
      const std::string ctx = "from " + s.to_string() + ", R = " + fmt(r) +
                              (queue_halfedges ? ", halfedges queued" : "");
      if (!queue_halfedges) {
        per_window_pops = bounded.stats().queue_pops;
      } else if (run + 1 == 2 * ranks.size() &&
                 !(bounded.stats().queue_pops < per_window_pops)) {
        // The widest disk: a halfedge's waiting windows go together, in fewer pops.
        tally.fail(ctx + ": " + std::to_string(bounded.stats().queue_pops) + " pops, against " +
                   std::to_string(per_window_pops) + " with one entry per window");
      }
      if (!(bounded.radius_reached() >= r * (1 - 1e-12))) {
        tally.fail(ctx + ": radius_reached() = " + fmt(bounded.radius_reached()) + " < R");
      }
      std::size_t inside = 0;
      for (std::uint32_t v = 0; v < mesh().num_vertices(); ++v) {
        const double got = bounded.distance(v);
        if (d[v] <= r) {
          ++inside;
          tally.check(got, d[v], ctx + ": vertex " + std::to_string(v) + " inside R");
        } else if (got != kInfinity) {
          tally.fail(ctx + ": vertex " + std::to_string(v) + " at distance " + fmt(d[v]) + " > R reported as " + fmt(got));
        }
      }
      EXPECT_EQ(inside, rank) << ctx;
      // touched_vertices() lists the disk: every vertex with a distance, each once.
      std::vector<std::uint8_t> seen(mesh().num_vertices(), 0);
      for (std::uint32_t v : bounded.touched_vertices()) {
        if (v >= mesh().num_vertices() || seen[v]) {
          tally.fail(ctx + ": touched_vertices() has " + std::to_string(v) + " out of range or twice");
          break;
        }
        seen[v] = 1;
      }
      for (std::uint32_t v = 0; v < mesh().num_vertices(); ++v) {
        if (bounded.distance(v) < kInfinity && !seen[v]) {
          tally.fail(ctx + ": vertex " + std::to_string(v) + " has a distance but is not in touched_vertices()");
          break;
        }
      }
      for (int j = 0; j < 30; ++j) {
        const SurfacePoint q = random_face_point(mesh(), rng);
        const double want = full.distance(q);
        if (std::abs(want - r) < 1e-9 * r) continue;
        tally.check(bounded.distance(q), want <= r ? want : kInfinity, ctx + ": " + q.to_string());
      }
    }
  }
  EXPECT_GT(beyond_stop, 0u);  // windows past R are not stored (and the checks above hold)
  EXPECT_TRUE(tally.result());
}

TEST_P(ExactGeodesicRealMesh, HalfedgeQueueMatchesWindowQueue) {
  // A full solve queues halfedges (all windows waiting on one go together); the other solve,
  // with a radius, is made to queue single windows. With a radius beyond the farthest point both
  // cover the whole mesh in different orders and must agree everywhere: every vertex and random
  // surface points.
  ExactGeodesicSolver full(mesh(), geometry());
  detail::WindowPropagation windowed(mesh(), geometry());
  windowed.force_queue_strategy(false);
  Rng rng(223);
  Tally tally(std::string(GetParam().name) + " halfedge vs window queue", scale());
  for (int k = 0; k < count(3, 2); ++k) {
    const SurfacePoint s = random_face_point(mesh(), rng);
    full.solve(s);
    ExactGeodesicSolver::Options opt;
    opt.max_distance = 1e3 * scale();
    windowed.solve(s, opt);
    const std::string ctx = "from " + s.to_string();
    // The same windows up to the order of creation: within a percent of each other.
    const double created = static_cast<double>(full.stats().windows_created);
    if (std::abs(created - static_cast<double>(windowed.stats().windows_created)) > 0.01 * created) {
      tally.fail(ctx + ": " + std::to_string(full.stats().windows_created) + " windows against " +
                 std::to_string(windowed.stats().windows_created));
    }
    if (!(full.stats().queue_pops < windowed.stats().queue_pops)) {
      tally.fail(ctx + ": the halfedge queue popped no fewer entries");
    }
    for (std::uint32_t v = 0; v < mesh().num_vertices(); ++v) {
      tally.check(full.distance(v), windowed.distance(v), ctx + ", vertex " + std::to_string(v));
    }
    for (int j = 0; j < 50; ++j) {
      const SurfacePoint t = random_face_point(mesh(), rng);
      tally.check(full.distance(t), windowed.distance(t), ctx + ", to " + t.to_string());
    }
  }
  EXPECT_TRUE(tally.result());
}

TEST_P(ExactGeodesicRealMesh, WorkBudgetStopsPastMinDistanceWithFinalDistances) {
  // max_windows_propagated: the solve stops once the budget is spent and min_distance is
  // reached; every vertex within radius_reached() has its full-solve distance, none beyond has
  // one. With one queue entry per window the budget is met exactly; with halfedges queued the
  // last entry may take it further, by less than one halfedge's waiting windows.
  ExactGeodesicSolver full(mesh(), geometry());
  detail::WindowPropagation budgeted(mesh(), geometry());  // both queue strategies
  Rng rng(211);
  Tally tally(std::string(GetParam().name) + " work budget", scale());
  for (int k = 0; k < count(3, 2); ++k) {
    const SurfacePoint s = random_face_point(mesh(), rng);
    full.solve(s);
    const std::vector<double> d = full.vertex_distances();
    const std::size_t all_windows = full.stats().windows_propagated;
    double farthest = 0;
    for (double x : d) {
      if (std::isfinite(x)) farthest = std::max(farthest, x);
    }
    for (int run = 0; run < 4; ++run) {
      const bool queue_halfedges = run >= 2;
      const double min_fraction = run % 2 == 0 ? 0.0 : 0.2;
      ExactGeodesicSolver::Options opt;
      opt.max_windows_propagated = all_windows / 10;
      opt.min_distance = min_fraction * farthest;
      budgeted.force_queue_strategy(queue_halfedges);
      budgeted.solve(one(s), {}, opt);
      const double r = budgeted.radius_reached();
      const std::size_t spent = budgeted.stats().windows_propagated;
      const std::string ctx = "from " + s.to_string() + ", budget " +
                              std::to_string(opt.max_windows_propagated) + ", min " +
                              fmt(opt.min_distance) + ", reached " + fmt(r) +
                              (queue_halfedges ? ", halfedges queued" : "");
      if (!(r >= opt.min_distance) || !(r < farthest)) tally.fail(ctx + ": radius out of range");
      if (min_fraction == 0 && !queue_halfedges && spent != opt.max_windows_propagated) {
        tally.fail(ctx + ": " + std::to_string(spent) + " windows propagated");
      }
      if (min_fraction == 0 && queue_halfedges &&
          !(spent >= opt.max_windows_propagated && spent < opt.max_windows_propagated + 100)) {
        tally.fail(ctx + ": " + std::to_string(spent) + " windows propagated");
      }
      std::size_t inside = 0;
      for (std::uint32_t v = 0; v < mesh().num_vertices(); ++v) {
        const double got = budgeted.distance(v);
        if (d[v] < r) {
          ++inside;
          tally.check(got, d[v], ctx + ": vertex " + std::to_string(v) + " inside");
        } else if (d[v] > r && got != kInfinity) {
          tally.fail(ctx + ": vertex " + std::to_string(v) + " beyond reported as " + fmt(got));
        }
      }
      EXPECT_GT(inside, 0u) << ctx;
    }
  }
  EXPECT_TRUE(tally.result());
}

TEST_P(ExactGeodesicRealMesh, VertexStopSettlesTheNearestVertices) {
  // stop_after_vertices: the solve stops once that many vertices are final and min_distance is
  // reached. The nearest that many vertices of the full solve are then final with their
  // full-solve distances, so is every vertex within radius_reached(), none beyond has one, and
  // (checked every 16 queue pops) the solve settles few more vertices than asked for.
  ExactGeodesicSolver full(mesh(), geometry()), stopped(mesh(), geometry());
  Rng rng(227);
  Tally tally(std::string(GetParam().name) + " vertex stop", scale());
  for (int k = 0; k < count(4, 2); ++k) {
    const SurfacePoint s = random_face_point(mesh(), rng);
    full.solve(s);
    std::vector<double> d = full.vertex_distances();
    std::vector<double> sorted;
    for (double x : d) {
      if (std::isfinite(x)) sorted.push_back(x);
    }
    std::sort(sorted.begin(), sorted.end());
    for (const std::size_t n : {std::size_t{1}, std::size_t{30}, std::size_t{100}}) {
      if (n > sorted.size()) continue;
      for (const double min_distance : {0.0, sorted[std::min(sorted.size() - 1, 2 * n)]}) {
        ExactGeodesicSolver::Options opt;
        opt.stop_after_vertices = n;
        opt.min_distance = min_distance;
        stopped.solve(s, opt);
        const double r = stopped.radius_reached();
        const std::string ctx = "from " + s.to_string() + ", " + std::to_string(n) +
                                " vertices, min " + fmt(min_distance) + ", reached " + fmt(r);
        if (!(r >= sorted[n - 1] * (1 - 1e-12)) || !(r >= min_distance)) {
          tally.fail(ctx + ": stopped before the " + std::to_string(n) + "th vertex at " +
                     fmt(sorted[n - 1]));
        }
        std::size_t final_vertices = 0;
        for (std::uint32_t v = 0; v < mesh().num_vertices(); ++v) {
          const double got = stopped.distance(v);
          if (d[v] < r) {
            ++final_vertices;
            tally.check(got, d[v], ctx + ": vertex " + std::to_string(v));
          } else if (d[v] > r && got != kInfinity) {
            tally.fail(ctx + ": vertex " + std::to_string(v) + " beyond reported as " + fmt(got));
          }
        }
        if (min_distance == 0 && stopped.stats().vertices_reached > n + 64) {
          tally.fail(ctx + ": " + std::to_string(stopped.stats().vertices_reached) +
                     " vertices final, far more than asked for");
        }
        if (final_vertices + 1 < n) tally.fail(ctx + ": only " + std::to_string(final_vertices));
      }
    }
  }
  EXPECT_TRUE(tally.result());
}

TEST_P(ExactGeodesicRealMesh, KTargetStopSettlesTheKNearest) {
  ExactGeodesicSolver full(mesh(), geometry());
  detail::WindowPropagation local(mesh(), geometry());  // both queue strategies
  Rng rng(113);
  Tally tally(std::string(GetParam().name) + " K-target stop", scale());
  std::size_t beyond_stop = 0;  // windows not stored as the solve would stop before popping them
  // Targets: random face points, edge points and vertices spread over the surface.
  std::vector<SurfacePoint> targets;
  for (int k = 0; k < 400; ++k) {
    if (k % 4 == 0) {
      targets.push_back(SurfacePoint::vertex(rng.below(static_cast<std::uint32_t>(mesh().num_vertices()))));
    } else if (k % 4 == 1) {
      targets.push_back(SurfacePoint::edge(rng.below(static_cast<std::uint32_t>(mesh().num_edges())), rng.uniform()));
    } else {
      targets.push_back(random_face_point(mesh(), rng));
    }
  }
  for (int trial = 0; trial < count(4, 2); ++trial) {
    const SurfacePoint s = trial == 0 ? targets[5] : random_face_point(mesh(), rng);
    full.solve(s);
    std::vector<std::pair<double, std::uint32_t>> truth;
    for (std::uint32_t i = 0; i < targets.size(); ++i) truth.push_back({full.distance(targets[i]), i});
    std::sort(truth.begin(), truth.end());
    const std::array<std::size_t, 4> ks{1, 36, 100, targets.size()};
    for (std::size_t run = 0; run < 2 * ks.size(); ++run) {
      // Each K with one queue entry per window, then with halfedges queued.
      const std::size_t k = ks[run / 2];
      ExactGeodesicSolver::Options opt;
      opt.stop_after_targets = k;
      const bool queue_halfedges = run % 2 == 1;
      local.force_queue_strategy(queue_halfedges);
      local.solve(one(s), targets, opt);
      if (k == 36) beyond_stop += local.stats().windows_beyond_stop;
      const std::string ctx = "from " + s.to_string() + ", K = " + std::to_string(k) +
                              (queue_halfedges ? ", halfedges queued" : "");
      const auto& settled = local.settled_targets();
      const auto& sd = local.settled_target_distances();
      if (settled.size() != k || sd.size() != k) {
        tally.fail(ctx + ": " + std::to_string(settled.size()) + " targets settled (" + std::to_string(sd.size()) +
                   " distances)");
        continue;
      }
      // Exactly the K nearest, nearest first, with exact distances (ties at the K-th distance
      // could legitimately settle either; skip a tie within 1e-9).
      const bool tie = k < truth.size() && truth[k].first - truth[k - 1].first <= 1e-9 * truth[k].first;
      std::vector<std::uint32_t> want, got(settled.begin(), settled.end());
      for (std::size_t i = 0; i < k; ++i) want.push_back(truth[i].second);
      std::sort(want.begin(), want.end());
      std::sort(got.begin(), got.end());
      if (!tie && want != got) {
        tally.fail(ctx + ": settled set differs from the K nearest (K-th distance " + fmt(truth[k - 1].first) +
                   ", next " + (k < truth.size() ? fmt(truth[k].first) : std::string("-")) + ")");
      }
      for (std::size_t i = 0; i < k; ++i) {
        tally.check(sd[i], full.distance(targets[settled[i]]), ctx + ": settled target " + std::to_string(settled[i]));
        if (i > 0 && !(sd[i] >= sd[i - 1])) tally.fail(ctx + ": settled distances not ascending at " + std::to_string(i));
        tally.check(local.distance(targets[settled[i]]), sd[i], ctx + ": distance(settled target)");
      }
      const double rr = local.radius_reached();
      if (!(rr >= truth[k - 1].first * (1 - 1e-12))) {
        tally.fail(ctx + ": radius_reached() = " + fmt(rr) + " below the K-th distance " + fmt(truth[k - 1].first));
      }
      // Everything within the radius reached is final; beyond it, unreachable.
      for (std::uint32_t v = 0; v < mesh().num_vertices(); ++v) {
        const double want_d = full.distance(v);
        if (std::abs(want_d - rr) <= 1e-9 * rr) continue;
        tally.check(local.distance(v), want_d <= rr ? want_d : kInfinity, ctx + ": vertex " + std::to_string(v));
      }
    }
  }
  // The skipping is exercised (the checks above hold with it).
  EXPECT_GT(beyond_stop, 0u);
  EXPECT_TRUE(tally.result());
}

TEST_P(ExactGeodesicRealMesh, GoalDirectedSolveIsExactAtItsTargetWithLessWork) {
  // With the target's position as goal, windows that cannot reach it before the stop are
  // dropped: the target's distance and path stay exact, and the solve does less work. Pairs
  // from close to a third of the way across the surface; with a radius, a target beyond it
  // stays unreached.
  ExactGeodesicSolver full(mesh(), geometry());
  // Both queue strategies.
  detail::WindowPropagation plain(mesh(), geometry()), goal(mesh(), geometry());
  Rng rng(307);
  Tally tally(std::string(GetParam().name) + " goal-directed", scale());
  std::size_t plain_windows = 0, goal_windows = 0;
  for (int trial = 0; trial < count(4, 2); ++trial) {
    const SurfacePoint s = random_face_point(mesh(), rng);
    full.solve(s);
    const double farthest = farthest_vertex_distance(full, mesh());
    std::vector<std::uint32_t> near;  // vertices within a third of the farthest distance
    for (std::uint32_t v = 0; v < mesh().num_vertices(); ++v) {
      if (full.distance(v) <= farthest / 3) near.push_back(v);
    }
    for (int k = 0; k < 6; ++k) {
      // A vertex, or a point of a face around one.
      const std::uint32_t v = near[rng.below(static_cast<std::uint32_t>(near.size()))];
      const std::uint32_t f = mesh().outgoing_halfedges(v)[0] / 3;
      const double b0 = rng.uniform(), b1 = (1 - b0) * rng.uniform();
      const SurfacePoint t =
          k % 3 == 0 ? SurfacePoint::vertex(v) : SurfacePoint::face(f, b0, b1, 1 - b0 - b1);
      const double want = full.distance(t);
      if (!std::isfinite(want)) continue;
      const Vec3 at = t.position(mesh());
      const std::vector<SurfacePoint> target{t};
      for (const double radius : {kInfinity, 1.2 * want, 0.8 * want}) {
        ExactGeodesicSolver::Options opt;
        opt.max_distance = radius;
        plain.force_queue_strategy(k % 2 == 1);
        goal.force_queue_strategy(k % 2 == 1);
        plain.solve(one(s), target, opt);
        opt.goal = at;
        goal.solve(one(s), target, opt);
        const std::string ctx = "from " + s.to_string() + " to " + t.to_string() + ", radius " +
                                fmt(radius) + ", exact " + fmt(want);
        if (radius < want) {
          if (goal.distance(t) != kInfinity || !goal.settled_targets().empty()) {
            tally.fail(ctx + ": reached beyond the radius, " + fmt(goal.distance(t)));
          }
          continue;
        }
        tally.check(goal.distance(t), want, ctx + ": distance");
        if (goal.settled_targets().size() != 1) {
          tally.fail(ctx + ": target not settled");
        } else {
          tally.check(goal.settled_target_distances()[0], want, ctx + ": settled distance");
        }
        const GeodesicPath path = goal.path_to(t);
        double length = 0;
        for (std::size_t i = 1; i < path.points.size(); ++i) {
          length += norm(path.points[i].position - path.points[i - 1].position);
        }
        tally.check(length, want, ctx + ": path length");
        plain_windows += plain.stats().windows_created;
        goal_windows += goal.stats().windows_created;
      }
    }
  }
  EXPECT_GT(plain_windows, 0u);
  EXPECT_LT(goal_windows, plain_windows);
  EXPECT_TRUE(tally.result());
}

TEST_P(ExactGeodesicRealMesh, GoalLimitKeepsThePartOfTheDiskThatShorterPathsCross) {
  // A disk out to a radius, directed at a goal with a bound on distance plus straight line
  // (goal_limit, as a query's near disks take it; the goal's point a target or not): every
  // point x of the disk with d(s, x) + |x goal| under that bound keeps its exact distance (the
  // region holds the whole geodesic to such a point), the others are unreached or upper
  // bounds, and the solve creates fewer windows than the whole disk does.
  ExactGeodesicSolver full(mesh(), geometry()), disk(mesh(), geometry()),
      directed(mesh(), geometry());
  Rng rng(419);
  Tally tally(std::string(GetParam().name) + " goal limit", scale());
  std::size_t disk_windows = 0, directed_windows = 0, kept = 0, upper = 0;
  for (int trial = 0; trial < count(6, 3); ++trial) {
    const SurfacePoint s = random_face_point(mesh(), rng);
    full.solve(s);
    const double farthest = farthest_vertex_distance(full, mesh());
    std::vector<std::uint32_t> candidates;  // goals between a sixth and a third of the way
    for (std::uint32_t v = 0; v < mesh().num_vertices(); ++v) {
      if (full.distance(v) >= farthest / 6 && full.distance(v) <= farthest / 3) {
        candidates.push_back(v);
      }
    }
    ASSERT_FALSE(candidates.empty());
    const SurfacePoint goal =
        SurfacePoint::vertex(candidates[rng.below(static_cast<std::uint32_t>(candidates.size()))]);
    const Vec3 at = goal.position(mesh());
    const double d = full.distance(goal);
    ExactGeodesicSolver::Options bounded;
    bounded.max_distance = 0.6 * d;
    disk.solve(s, bounded);
    bounded.goal = at;
    bounded.goal_limit = 1.02 * d;
    if (trial % 2 == 0) {
      directed.solve(one(s), std::vector<SurfacePoint>{goal}, bounded);
    } else {
      directed.solve(s, bounded);  // with a goal_limit, no target is needed
    }
    disk_windows += disk.stats().windows_created;
    directed_windows += directed.stats().windows_created;
    const std::string ctx = "from " + s.to_string() + " towards " + goal.to_string();
    for (std::uint32_t v = 0; v < mesh().num_vertices(); ++v) {
      const double exact = full.distance(v), got = directed.distance(v);
      const bool inside = exact <= bounded.max_distance * (1 - 1e-6) &&
                          exact + norm(mesh().position(v) - at) <= bounded.goal_limit * (1 - 1e-6);
      if (inside) {
        ++kept;
        tally.check(got, exact, ctx + ", vertex " + std::to_string(v));
      } else if (std::isfinite(got)) {
        ++upper;
        if (!(got >= exact * (1 - 1e-9))) {
          tally.fail(ctx + ", vertex " + std::to_string(v) + " below its distance: " + fmt(got) +
                     " < " + fmt(exact));
        }
      }
    }
    EXPECT_TRUE(directed.settled_targets().empty()) << ctx << ": the goal lies beyond the radius";
  }
  EXPECT_GT(kept, 0u);
  EXPECT_LT(directed_windows, disk_windows);
  RecordProperty("vertices_kept", std::to_string(kept));
  RecordProperty("upper_bounds", std::to_string(upper));
  EXPECT_TRUE(tally.result());
}

TEST_P(ExactGeodesicRealMesh, SeveralSourcesAreTheMinimum) {
  ExactGeodesicSolver solver(mesh(), geometry());
  Rng rng(127);
  Tally tally(std::string(GetParam().name) + " several sources", scale());
  const std::vector<GeodesicSource> sources{
      {SurfacePoint::vertex(rng.below(static_cast<std::uint32_t>(mesh().num_vertices()))), 0},
      {SurfacePoint::edge(rng.below(static_cast<std::uint32_t>(mesh().num_edges())), 0.3), 0.05 * scale()},
      {random_face_point(mesh(), rng), 0.0},
      {random_face_point(mesh(), rng), 0.1 * scale()},
  };
  std::vector<std::vector<double>> single;
  std::vector<SurfacePoint> probes;
  for (int k = 0; k < 40; ++k) probes.push_back(random_face_point(mesh(), rng));
  std::vector<std::vector<double>> single_probe;
  for (const GeodesicSource& src : sources) {
    solver.solve(std::vector<GeodesicSource>{src});
    single.push_back(solver.vertex_distances());
    single_probe.emplace_back();
    for (const SurfacePoint& p : probes) single_probe.back().push_back(solver.distance(p));
  }
  solver.solve(sources);
  for (std::uint32_t v = 0; v < mesh().num_vertices(); ++v) {
    double best = kInfinity, second = kInfinity;
    std::int32_t which = -1;
    for (std::size_t i = 0; i < sources.size(); ++i) {
      if (single[i][v] < best) {
        second = best;
        best = single[i][v];
        which = static_cast<std::int32_t>(i);
      } else {
        second = std::min(second, single[i][v]);
      }
    }
    tally.check(solver.distance(v), best, "vertex " + std::to_string(v));
    if (second - best > 1e-9 * best && solver.nearest_source(v) != which) {
      tally.fail("nearest_source(" + std::to_string(v) + ") = " + std::to_string(solver.nearest_source(v)) +
                 ", expected " + std::to_string(which));
    }
  }
  for (std::size_t k = 0; k < probes.size(); ++k) {
    double best = kInfinity;
    for (std::size_t i = 0; i < sources.size(); ++i) best = std::min(best, single_probe[i][k]);
    tally.check(solver.distance(probes[k]), best, "probe " + probes[k].to_string());
  }
  EXPECT_TRUE(tally.result());
}

TEST_P(ExactGeodesicRealMesh, ReusedSolverMatchesFreshSolvers) {
  detail::WindowPropagation reused(mesh(), geometry());  // both queue strategies
  Rng rng(131);
  std::vector<SurfacePoint> targets;
  for (int k = 0; k < 200; ++k) targets.push_back(random_face_point(mesh(), rng));
  const std::uint32_t nv = static_cast<std::uint32_t>(mesh().num_vertices());
  int mismatches = 0;
  std::string first;
  for (int k = 0; k < count(12, 6); ++k) {
    // Alternate full, bounded, K-target and multi-source solves.
    std::vector<GeodesicSource> sources = one(k % 2 ? random_face_point(mesh(), rng) : SurfacePoint::vertex(rng.below(nv)));
    if (k % 4 == 3) sources.push_back({random_face_point(mesh(), rng), 0.01 * scale()});
    ExactGeodesicSolver::Options opt;
    std::vector<SurfacePoint> tg;
    if (k % 3 == 1) opt.max_distance = 0.1 * scale();
    if (k % 3 == 2) {
      tg = targets;
      opt.stop_after_targets = 36;
    }
    // Bounded solves with and without halfedges queued (a stopped solve leaves some queued).
    const bool queue_halfedges = k % 4 >= 2;
    reused.force_queue_strategy(queue_halfedges);
    reused.solve(sources, tg, opt);
    detail::WindowPropagation fresh(mesh(), geometry());
    fresh.force_queue_strategy(queue_halfedges);
    fresh.solve(sources, tg, opt);
    const auto a = reused.vertex_distances(), b = fresh.vertex_distances();
    bool same = a.size() == b.size() && reused.radius_reached() == fresh.radius_reached() &&
                reused.settled_targets() == fresh.settled_targets() &&
                reused.settled_target_distances() == fresh.settled_target_distances();
    for (std::size_t v = 0; same && v < a.size(); ++v) same = a[v] == b[v] || (std::isnan(a[v]) && std::isnan(b[v]));
    for (std::size_t t = 0; same && t < 20; ++t) same = reused.distance(targets[t]) == fresh.distance(targets[t]);
    if (!same) {
      ++mismatches;
      if (first.empty()) first = "solve " + std::to_string(k) + " from " + sources[0].point.to_string();
    }
  }
  EXPECT_EQ(mismatches, 0) << "reused solver differs from a fresh one, first at " << first;
}

// Targets prepared once give what the same targets given to every solve give, whatever came
// before on the same solver (another prepared set, targets given per solve, no targets), and one
// set serves solvers on two threads at once.
TEST_P(ExactGeodesicRealMesh, PreparedTargetsMatchTargetsGivenPerSolve) {
  Rng rng(139);
  const std::uint32_t nv = static_cast<std::uint32_t>(mesh().num_vertices());
  std::vector<SurfacePoint> mixed, samples;
  for (int k = 0; k < 300; ++k) {
    if (k % 3 == 0) mixed.push_back(SurfacePoint::vertex(rng.below(nv)));
    if (k % 3 == 1) mixed.push_back(SurfacePoint::edge(rng.below(static_cast<std::uint32_t>(mesh().num_edges())), rng.uniform()));
    if (k % 3 == 2) mixed.push_back(random_face_point(mesh(), rng));
  }
  mixed.push_back(mixed[0]);  // the same vertex twice
  mixed.push_back(mixed[2]);  // the same face point twice
  for (int k = 0; k < 200; ++k) samples.push_back(SurfacePoint::vertex(rng.below(nv)));
  const GeodesicTargets prepared_mixed(geometry(), mixed), prepared_samples(geometry(), samples);

  struct Result {
    std::vector<std::uint32_t> settled;
    std::vector<double> distances, field;
    double radius = 0;
    bool operator==(const Result&) const = default;
  };
  auto result_of = [](const ExactGeodesicSolver& s) {
    return Result{s.settled_targets(), s.settled_target_distances(), s.vertex_distances(), s.radius_reached()};
  };
  ExactGeodesicSolver reused(mesh(), geometry());
  std::vector<std::vector<GeodesicSource>> sources;
  std::vector<ExactGeodesicSolver::Options> options;
  std::vector<Result> expected;
  int mismatches = 0;
  std::string first;
  for (int k = 0; k < count(24, 12); ++k) {
    const bool use_mixed = k % 2 == 0;
    const std::vector<SurfacePoint>& points = use_mixed ? mixed : samples;
    const GeodesicTargets& prepared = use_mixed ? prepared_mixed : prepared_samples;
    sources.push_back(one(k % 3 ? random_face_point(mesh(), rng) : SurfacePoint::vertex(rng.below(nv))));
    ExactGeodesicSolver::Options opt;
    opt.stop_after_targets = std::array<std::size_t, 4>{1, 36, 7, 0}[static_cast<std::size_t>(k) % 4];
    if (k % 5 == 4) opt.min_distance = 0.05 * scale();
    options.push_back(opt);
    ExactGeodesicSolver fresh(mesh(), geometry());
    fresh.solve(sources.back(), points, opt);
    expected.push_back(result_of(fresh));
    if (expected.back().settled.empty()) ADD_FAILURE() << "solve " << k << " settled no target";
    // Before it, the reused solver ran a solve of another kind.
    if (k % 3 == 0) reused.solve(one(SurfacePoint::vertex(rng.below(nv))), use_mixed ? samples : mixed, opt);
    if (k % 3 == 1) reused.solve(one(SurfacePoint::vertex(rng.below(nv))), use_mixed ? prepared_samples : prepared_mixed, opt);
    if (k % 3 == 2) reused.solve(SurfacePoint::vertex(rng.below(nv)));
    reused.solve(sources.back(), prepared, opt);
    if (!(result_of(reused) == expected.back())) {
      ++mismatches;
      if (first.empty()) first = "solve " + std::to_string(k) + " from " + sources.back()[0].point.to_string();
    }
    for (const SurfacePoint& p : points) {
      if (reused.distance(p) != fresh.distance(p)) {
        ++mismatches;
        if (first.empty()) first = "distance(" + p.to_string() + ") after solve " + std::to_string(k);
        break;
      }
    }
  }
  EXPECT_EQ(mismatches, 0) << "prepared targets differ from targets given per solve, first at " << first;

  // Two threads, both using both sets, in opposite orders.
  std::vector<int> wrong(2, 0);
  auto worker = [&](int id) {
    ExactGeodesicSolver solver(mesh(), geometry());
    for (std::size_t i = 0; i < sources.size(); ++i) {
      const std::size_t k = id == 0 ? i : sources.size() - 1 - i;
      solver.solve(sources[k], k % 2 == 0 ? prepared_mixed : prepared_samples, options[k]);
      if (!(result_of(solver) == expected[k])) ++wrong[static_cast<std::size_t>(id)];
    }
  };
  std::thread a(worker, 0), b(worker, 1);
  a.join();
  b.join();
  EXPECT_EQ(wrong[0] + wrong[1], 0) << "solves sharing one prepared set across threads differ";
}

TEST_P(ExactGeodesicRealMesh, OneShotFunctionsMatchSolver) {
  Rng rng(137);
  const SurfacePoint s = random_face_point(mesh(), rng), t = random_face_point(mesh(), rng);
  ExactGeodesicSolver solver(mesh(), geometry());
  solver.solve(s);
  const std::vector<double> d = exact_geodesic_distances(mesh(), geometry(), one(s));
  EXPECT_EQ(d, solver.vertex_distances());
  const GeodesicPath p = exact_geodesic_path(mesh(), geometry(), s, t);
  EXPECT_NEAR(p.length, solver.distance(t), kRel * solver.distance(t));
  Tally tally("one-shot path", scale());
  check_path(mesh(), p, s, t, solver.distance(t), scale(), Shape::Curved, tally, GetParam().name);
  EXPECT_TRUE(tally.result());
}

// A case found by the K-target test: the geodesic to an edge point arrives through the edge's
// second face (3880), but the distance was read in its first face (953) only.
TEST(ExactGeodesicSpot, EdgePointReachedThroughItsSecondFace) {
  const LoadedMesh* lm = load_cached("spot.obj");
  ASSERT_TRUE(lm) << "spot.obj not found";
  const TriangleMesh& mesh = *lm->mesh;
  const SurfacePoint s = SurfacePoint::face(2986, 0.50814537462324716, 0.1178169717528663, 0.37403765362388652);
  const SurfacePoint t = SurfacePoint::edge(1945, 0.55442875658629454);
  ASSERT_LT(t.id, mesh.num_edges());
  ExactGeodesicSolver solver(mesh, *lm->geometry);
  solver.solve(t);
  const double reverse = solver.distance(s);
  solver.solve(s);
  EXPECT_NEAR(solver.distance(t), reverse, kRel * reverse) << "d(s,t) from a full solve vs d(t,s)";
  EXPECT_NEAR(solver.path_to(t).length, reverse, kRel * reverse);
  // With t as the only target: settled at the right distance, and distance(t) agrees.
  const std::vector<SurfacePoint> targets{t};
  solver.solve(one(s), targets);
  ASSERT_EQ(solver.settled_targets().size(), 1u);
  EXPECT_NEAR(solver.settled_target_distances()[0], reverse, kRel * reverse);
  EXPECT_NEAR(solver.distance(t), reverse, kRel * reverse) << "distance() of the settled target";
}

INSTANTIATE_TEST_SUITE_P(Meshes, ExactGeodesicRealMesh,
                         ::testing::Values(RealMeshCase{"spot.obj", 20}, RealMeshCase{"plane_holes.obj", 6},
                                           RealMeshCase{"ChineseDragon-10kv.off", 6}),
                         [](const ::testing::TestParamInfo<RealMeshCase>& case_info) {
                           std::string n = case_info.param.name;
                           for (char& c : n) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           }
                           return n;
                         });

}  // namespace
}  // namespace geoprox
