// Tests of core/geodesic/geodesic_tracing.h against analytic straight lines: on flat grids (a trace is a
// segment of the plane), on a prism (the unrolled strip), on a cube (the unfolded belt and single
// edge crossings) and on a faceted cone (the developed sector), with starts in faces, on edges
// and at vertices; plus the stops (vertex, boundary, zero-area face), zero length, the outward
// tolerance of start directions, reuse of the output, and bad inputs. A last test traces the
// exact solver's end directions on a real mesh and lands on its paths.
//
// Every mesh here is isometric to its positions, so 3D distances are intrinsic ones: positions
// are compared to 1e-12 of the scale (~1), and the 3D length of the polyline to the trace's
// length to 1e-12 relative (of at least 1e-3: positions carry absolute rounding). The grid of
// caps is the exception (see CapsAreCrossedStraight): rounded edge lengths give it angle defects
// of ~1e-9, so there positions are compared to 1e-8.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/geodesic/geodesic_tracing.h"
#include "core/mesh/mesh_io.h"
#include "tests/core/test_meshes.h"

namespace geoprox {
namespace {

using namespace test_meshes;

constexpr double kPos = 1e-12;  // positions, meshes of size ~1
constexpr double kLen = 1e-12;  // polyline length vs requested length, relative
constexpr double kPi = std::numbers::pi;

std::string fmt(double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}
std::string fmt(const Vec3& p) { return "(" + fmt(p.x) + ", " + fmt(p.y) + ", " + fmt(p.z) + ")"; }

/// Largest error seen and where, reported once per test instead of one failure per sample.
struct Worst {
  double error = 0;
  std::string where;
  int count = 0;
  void add(double err, const std::string& what) {
    ++count;
    if (!(err <= error)) {  // NaN counts as worst
      error = std::isnan(err) ? std::numeric_limits<double>::infinity() : err;
      where = what;
    }
  }
};

/// A 3D direction lying in face f as a FaceDirection (inverse of face_direction_3d).
FaceDirection to_frame(const TriangleMesh& mesh, std::uint32_t f, const Vec3& d) {
  const Triangle& t = mesh.face(f);
  const Vec3 p0 = mesh.position(t[0]), p1 = mesh.position(t[1]), p2 = mesh.position(t[2]);
  const Vec3 ex = normalized(p1 - p0);
  const Vec3 w = p2 - p0;
  const Vec3 ey = normalized(w - dot(w, ex) * ex);
  return {f, dot(d, ex), dot(d, ey)};
}

Vec3 dir3(const TriangleMesh& mesh, const FaceDirection& d) {
  return face_direction_3d(mesh, d.face, d.x, d.y);
}

Vec3 unit3(const Vec3& v) { return normalized(v); }

/// The face containing p (most interior one), with its barycentrics; nullopt if none.
std::optional<SurfacePoint> locate(const TriangleMesh& mesh, const Vec3& p) {
  std::optional<SurfacePoint> best;
  double best_min = -1e-12;
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
    const Triangle& t = mesh.face(f);
    const Vec3 a = mesh.position(t[0]), b = mesh.position(t[1]), c = mesh.position(t[2]);
    const Vec3 n = cross(b - a, c - a);
    const double nn = dot(n, n);
    if (!(nn > 0) || std::abs(dot(p - a, n)) > 1e-12 * std::sqrt(nn)) continue;
    const double b0 = dot(cross(c - b, p - b), n) / nn;
    const double b1 = dot(cross(a - c, p - c), n) / nn;
    const double b2 = 1 - b0 - b1;
    const double m = std::min({b0, b1, b2});
    if (m > best_min) {
      best_min = m;
      best = SurfacePoint::face(f, std::max(b0, 0.0), std::max(b1, 0.0), std::max(b2, 0.0));
      const double s = best->bary[0] + best->bary[1] + best->bary[2];
      for (double& x : best->bary) x /= s;
    }
  }
  return best;
}

/// The vertex at position p.
std::uint32_t vertex_at(const TriangleMesh& mesh, const Vec3& p) {
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    if (dist(mesh.position(v), p) < 1e-12) return v;
  }
  throw std::logic_error("no vertex at " + fmt(p));
}

/// A face of v whose corner wedge strictly contains the 3D direction d (in the face's plane).
std::uint32_t wedge_face(const TriangleMesh& mesh, std::uint32_t v, const Vec3& d) {
  for (std::uint32_t h : mesh.outgoing_halfedges(v)) {
    const Vec3 p = mesh.position(v);
    const Vec3 e1 = mesh.position(mesh.target(h)) - p;
    const Vec3 e2 = mesh.position(mesh.opposite_vertex(h)) - p;
    const Vec3 n = cross(e1, e2);
    if (std::abs(dot(d, n)) > 1e-12 * norm(n)) continue;
    if (dot(cross(e1, d), n) > 0 && dot(cross(d, e2), n) > 0) return TriangleMesh::face_of(h);
  }
  throw std::logic_error("no face of vertex " + std::to_string(v) + " holds the direction");
}

/// Invariants of every trace: starts at `start`, crossings are edge points, consecutive points
/// share a face, end == last point, and the 3D polyline is as long as trace.length (relative
/// to max(length, length_floor)).
void check_invariants(const TriangleMesh& mesh, const GeodesicTrace& trace,
                      const SurfacePoint& start, const std::string& where,
                      double length_tolerance = kLen, double length_floor = 1e-3) {
  ASSERT_FALSE(trace.points.empty()) << where;
  EXPECT_EQ(trace.points.front().point.to_string(), start.to_string()) << where;
  double sum = 0;
  for (std::size_t k = 0; k < trace.points.size(); ++k) {
    const PathPoint& p = trace.points[k];
    EXPECT_NO_THROW(p.point.validate(mesh)) << where << " point " << k;
    const Vec3 q = p.point.position(mesh);
    EXPECT_EQ(dist(q, p.position), 0.0) << where << " point " << k;
    if (k > 0 && k + 1 < trace.points.size()) {
      EXPECT_EQ(p.point.kind, SurfacePoint::Kind::Edge) << where << " point " << k;
    }
    if (k > 0) {
      sum += dist(trace.points[k - 1].position, p.position);
      const auto fa = incident_faces(mesh, trace.points[k - 1].point, 1e-9);
      const auto fb = incident_faces(mesh, p.point, 1e-9);
      bool shared = false;
      for (std::uint32_t f : fa) shared = shared || std::find(fb.begin(), fb.end(), f) != fb.end();
      EXPECT_TRUE(shared) << where << ": points " << k - 1 << " and " << k << " share no face";
    }
  }
  // Relative to the length, with a floor for very short traces: 3D positions of size ~1 carry
  // absolute rounding of ~1e-16 each.
  EXPECT_LE(std::abs(sum - trace.length), length_tolerance * std::max(trace.length, length_floor))
      << where << ": polyline " << fmt(sum) << ", trace length " << fmt(trace.length);
  EXPECT_EQ(trace.end.to_string(), trace.points.back().point.to_string()) << where;
  EXPECT_NEAR(std::hypot(trace.end_direction.x, trace.end_direction.y), 1.0, 1e-14) << where;
  EXPECT_LT(trace.end_direction.face, mesh.num_faces()) << where;
  if (trace.stop == TraceStop::HitVertex) {
    ASSERT_EQ(trace.end.kind, SurfacePoint::Kind::Vertex) << where;
    EXPECT_EQ(static_cast<std::uint32_t>(trace.stop_vertex), trace.end.id) << where;
  } else {
    EXPECT_EQ(trace.stop_vertex, -1) << where;
  }
}

// ---------------------------------------------------------------------------------------------
// Flat grid: a trace is a straight segment of the plane.

struct FlatCase {
  TestMesh tm;
  double x1, y1;  ///< the grid is [0, x1] x [0, y1]
};

FlatCase jittered_grid() {
  GridOptions o;
  o.nx = 12;
  o.ny = 10;
  o.hx = o.hy = 0.1;
  o.jitter = 0.2;
  o.seed = 7;
  return {make_test_mesh(flat_grid(o)), 1.2, 1.0};
}

/// Distance from p along unit d to the boundary of [0, x1] x [0, y1] (p inside).
double box_exit(const Vec3& p, const Vec3& d, double x1, double y1) {
  double s = std::numeric_limits<double>::infinity();
  if (d.x > 0) s = std::min(s, (x1 - p.x) / d.x);
  if (d.x < 0) s = std::min(s, -p.x / d.x);
  if (d.y > 0) s = std::min(s, (y1 - p.y) / d.y);
  if (d.y < 0) s = std::min(s, -p.y / d.y);
  return s;
}

/// Traces from start (at 3D point p) along the 3D unit direction d given in face f, and checks
/// the whole trace against the segment p + [0, length] d.
void check_flat_line(const TriangleMesh& mesh, const IntrinsicGeometry& g,
                     const SurfacePoint& start, std::uint32_t f, const Vec3& d, double length,
                     Worst& worst, const std::string& where) {
  const Vec3 p = start.position(mesh);
  const GeodesicTrace trace = trace_geodesic(mesh, g, start, to_frame(mesh, f, d), length);
  check_invariants(mesh, trace, start, where);
  EXPECT_EQ(trace.stop, TraceStop::Completed) << where;
  EXPECT_EQ(trace.length, length) << where;
  const Vec3 expected = p + length * d;
  worst.add(dist(trace.points.back().position, expected) / kPos,
            where + ": end " + fmt(trace.points.back().position) + ", expected " + fmt(expected));
  double along = -1;
  for (const PathPoint& q : trace.points) {
    const Vec3 r = q.position - p;
    worst.add(norm(cross(d, r)) / kPos, where + ": point off the line");
    EXPECT_GE(dot(r, d), along - 1e-15) << where << ": points out of order";
    along = dot(r, d);
  }
  worst.add(norm(dir3(mesh, trace.end_direction) - d) / kPos, where + ": end direction");
}

TEST(GeodesicTracingFlat, FaceStartsAreStraightSegments) {
  const FlatCase fc = jittered_grid();
  const TriangleMesh& mesh = *fc.tm.mesh;
  Rng rng(11);
  Worst worst;
  int crossings = 0;
  for (int k = 0; k < 400; ++k) {
    const SurfacePoint start = random_face_point(mesh, rng);
    const double a = rng.uniform(0, 2 * kPi);
    const Vec3 d{std::cos(a), std::sin(a), 0};
    const double length = rng.uniform(0, 0.97) * box_exit(start.position(mesh), d, fc.x1, fc.y1);
    const std::string where = "case " + std::to_string(k) + " from " + start.to_string();
    check_flat_line(mesh, *fc.tm.geometry, start, start.id, d, length, worst, where);
    crossings += static_cast<int>(
        trace_geodesic(mesh, *fc.tm.geometry, start, to_frame(mesh, start.id, d), length)
            .points.size()) - 2;
  }
  EXPECT_LE(worst.error, 1.0) << worst.where << " (error / 1e-12)";
  EXPECT_GT(crossings, 400 * 3);  // the lines do cross many faces
}

TEST(GeodesicTracingFlat, VertexStartsAreStraightSegments) {
  const FlatCase fc = jittered_grid();
  const TriangleMesh& mesh = *fc.tm.mesh;
  Rng rng(12);
  Worst worst;
  for (int k = 0; k < 300; ++k) {
    std::uint32_t v;
    do {
      v = rng.below(static_cast<std::uint32_t>(mesh.num_vertices()));
    } while (mesh.is_boundary_vertex(v));
    const auto out = mesh.outgoing_halfedges(v);
    const std::uint32_t h = out[rng.below(static_cast<std::uint32_t>(out.size()))];
    const Vec3 p = mesh.position(v);
    const Vec3 e1 = unit3(mesh.position(mesh.target(h)) - p);
    const Vec3 e2 = unit3(mesh.position(mesh.opposite_vertex(h)) - p);
    const double alpha = std::atan2(norm(cross(e1, e2)), dot(e1, e2));
    const Vec3 n = unit3(e2 - dot(e2, e1) * e1);
    const double theta = rng.uniform(0.001, 0.999) * alpha;
    const Vec3 d = std::cos(theta) * e1 + std::sin(theta) * n;
    const double length = rng.uniform(0, 0.97) * box_exit(p, d, fc.x1, fc.y1);
    check_flat_line(mesh, *fc.tm.geometry, SurfacePoint::vertex(v), TriangleMesh::face_of(h), d,
                    length, worst, "case " + std::to_string(k) + " from v:" + std::to_string(v));
  }
  EXPECT_LE(worst.error, 1.0) << worst.where << " (error / 1e-12)";
}

TEST(GeodesicTracingFlat, EdgeStartsAreStraightSegments) {
  const FlatCase fc = jittered_grid();
  const TriangleMesh& mesh = *fc.tm.mesh;
  Rng rng(13);
  Worst worst;
  for (int k = 0; k < 300; ++k) {
    std::uint32_t e;
    do {
      e = rng.below(static_cast<std::uint32_t>(mesh.num_edges()));
    } while (mesh.is_boundary_edge(e));
    const double t = rng.uniform(0.02, 0.98);
    const SurfacePoint start = SurfacePoint::edge(e, t);
    // Either face of the edge, the direction at angle phi in (0, pi) from the halfedge.
    std::uint32_t h = mesh.edge_halfedge(e);
    if (rng.uniform() < 0.5) h = static_cast<std::uint32_t>(mesh.twin(h));
    const Vec3 a = mesh.position(mesh.origin(h)), b = mesh.position(mesh.target(h));
    const Vec3 u = unit3(b - a);
    const Vec3 w = mesh.position(mesh.opposite_vertex(h)) - a;
    const Vec3 n = unit3(w - dot(w, u) * u);
    const double phi = rng.uniform(0.001, kPi - 0.001);
    const Vec3 d = std::cos(phi) * u + std::sin(phi) * n;
    const double length = rng.uniform(0, 0.97) * box_exit(start.position(mesh), d, fc.x1, fc.y1);
    check_flat_line(mesh, *fc.tm.geometry, start, TriangleMesh::face_of(h), d, length, worst,
                    "case " + std::to_string(k) + " from " + start.to_string());
  }
  EXPECT_LE(worst.error, 1.0) << worst.where << " (error / 1e-12)";
}

TEST(GeodesicTracingFlat, LeavingTheGridStopsAtTheBoundary) {
  const FlatCase fc = jittered_grid();
  const TriangleMesh& mesh = *fc.tm.mesh;
  Rng rng(14);
  Worst worst;
  for (int k = 0; k < 200; ++k) {
    const SurfacePoint start = random_face_point(mesh, rng);
    const Vec3 p = start.position(mesh);
    const double a = rng.uniform(0, 2 * kPi);
    const Vec3 d{std::cos(a), std::sin(a), 0};
    const double exit = box_exit(p, d, fc.x1, fc.y1);
    const std::string where = "case " + std::to_string(k) + " from " + start.to_string();
    const GeodesicTrace trace = trace_geodesic(mesh, *fc.tm.geometry, start,
                                               to_frame(mesh, start.id, d),
                                               exit * rng.uniform(1.01, 3.0) + 0.1);
    check_invariants(mesh, trace, start, where);
    ASSERT_EQ(trace.stop, TraceStop::HitBoundary) << where;
    ASSERT_EQ(trace.end.kind, SurfacePoint::Kind::Edge) << where;
    EXPECT_TRUE(mesh.is_boundary_edge(trace.end.id)) << where;
    worst.add(std::abs(trace.length - exit) / kPos, where + ": length " + fmt(trace.length) +
                                                        ", expected " + fmt(exit));
    worst.add(dist(trace.end.position(mesh), p + exit * d) / kPos, where + ": end");
    worst.add(norm(dir3(mesh, trace.end_direction) - d) / kPos, where + ": end direction");
  }
  EXPECT_LE(worst.error, 1.0) << worst.where << " (error / 1e-12)";
}

TEST(GeodesicTracingFlat, AimedAtAVertexStopsThere) {
  GridOptions o;
  o.nx = o.ny = 10;
  o.hx = o.hy = 0.1;
  const TestMesh tm = make_test_mesh(flat_grid(o));
  const TriangleMesh& mesh = *tm.mesh;
  const Vec3 p{0.1234, 0.2719, 0};
  const std::uint32_t target = grid_vertex(o, 7, 6);
  const Vec3 q = mesh.position(target);
  const double distance = dist(p, q);
  const Vec3 d = (1.0 / distance) * (q - p);
  // Precondition: the segment passes no other vertex.
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    if (v == target) continue;
    const Vec3 r = mesh.position(v) - p;
    const double s = std::clamp(dot(r, d), 0.0, distance);
    ASSERT_GT(dist(mesh.position(v), p + s * d), 1e-3) << "vertex " << v;
  }
  const SurfacePoint start = *locate(mesh, p);
  const FaceDirection fd = to_frame(mesh, start.id, d);

  // Longer than the distance: stops at the vertex.
  const GeodesicTrace hit = trace_geodesic(mesh, *tm.geometry, start, fd, 1.5 * distance);
  check_invariants(mesh, hit, start, "longer");
  EXPECT_EQ(hit.stop, TraceStop::HitVertex);
  EXPECT_EQ(hit.stop_vertex, static_cast<std::int32_t>(target));
  EXPECT_NEAR(hit.length, distance, 1e-15);
  EXPECT_GT(hit.points.size(), 5u);
  EXPECT_NEAR(norm(dir3(mesh, hit.end_direction) - d), 0, 1e-14);

  // Exactly the distance: completed, ending at the vertex.
  const GeodesicTrace exact = trace_geodesic(mesh, *tm.geometry, start, fd, distance);
  check_invariants(mesh, exact, start, "exact");
  EXPECT_EQ(exact.stop, TraceStop::Completed);
  EXPECT_EQ(exact.end.to_string(), SurfacePoint::vertex(target).to_string());
  EXPECT_EQ(exact.length, distance);

  // A little shorter: completed in a face next to the vertex.
  const GeodesicTrace shorter = trace_geodesic(mesh, *tm.geometry, start, fd, distance - 1e-6);
  check_invariants(mesh, shorter, start, "shorter");
  EXPECT_EQ(shorter.stop, TraceStop::Completed);
  EXPECT_EQ(shorter.end.kind, SurfacePoint::Kind::Face);
  EXPECT_NEAR(dist(shorter.end.position(mesh), q), 1e-6, 1e-15);

  // From a vertex to a vertex: (2, 3) -> (5, 7) passes no lattice point in between.
  const std::uint32_t from = grid_vertex(o, 2, 3), to = grid_vertex(o, 5, 7);
  const Vec3 dv{0.6, 0.8, 0};
  const GeodesicTrace vv = trace_geodesic(mesh, *tm.geometry, SurfacePoint::vertex(from),
                                          to_frame(mesh, wedge_face(mesh, from, dv), dv), 2.0);
  check_invariants(mesh, vv, SurfacePoint::vertex(from), "vertex to vertex");
  EXPECT_EQ(vv.stop, TraceStop::HitVertex);
  EXPECT_EQ(vv.stop_vertex, static_cast<std::int32_t>(to));
  EXPECT_NEAR(vv.length, 0.5, 1e-15);
}

TEST(GeodesicTracingFlat, AlongAnEdge) {
  GridOptions o;
  o.nx = o.ny = 10;
  o.hx = o.hy = 0.1;
  const TestMesh tm = make_test_mesh(flat_grid(o));
  const TriangleMesh& mesh = *tm.mesh;
  const std::uint32_t v = grid_vertex(o, 4, 4);
  // Every outgoing halfedge of v, from both of its faces' wedges (either side of the edge).
  for (std::uint32_t h : mesh.outgoing_halfedges(v)) {
    const std::uint32_t w = mesh.target(h);
    const Vec3 d = unit3(mesh.position(w) - mesh.position(v));
    const double edge = dist(mesh.position(w), mesh.position(v));
    std::vector<std::uint32_t> faces{TriangleMesh::face_of(h)};
    faces.push_back(TriangleMesh::face_of(static_cast<std::uint32_t>(mesh.twin(h))));
    for (std::uint32_t f : faces) {
      const std::string where = SurfacePoint::vertex(v).to_string() + " -> " +
                                SurfacePoint::vertex(w).to_string() + " in face " +
                                std::to_string(f);
      const GeodesicTrace hit =
          trace_geodesic(mesh, *tm.geometry, SurfacePoint::vertex(v), to_frame(mesh, f, d), 1.0);
      check_invariants(mesh, hit, SurfacePoint::vertex(v), where);
      EXPECT_EQ(hit.stop, TraceStop::HitVertex) << where;
      EXPECT_EQ(hit.stop_vertex, static_cast<std::int32_t>(w)) << where;
      EXPECT_NEAR(hit.length, edge, 1e-15) << where;
      EXPECT_EQ(hit.points.size(), 2u) << where;
      const GeodesicTrace part = trace_geodesic(mesh, *tm.geometry, SurfacePoint::vertex(v),
                                                to_frame(mesh, f, d), 0.3 * edge);
      check_invariants(mesh, part, SurfacePoint::vertex(v), where + " (part)");
      EXPECT_EQ(part.stop, TraceStop::Completed) << where;
      EXPECT_NEAR(dist(part.end.position(mesh), mesh.position(v) + 0.3 * edge * d), 0, 1e-15)
          << where;
    }
  }
  // From an edge point along its edge.
  const std::uint32_t h = mesh.outgoing_halfedges(v)[0];
  const std::uint32_t e = mesh.edge_of(h);
  const Vec3 a = mesh.position(mesh.edge_origin(e)), b = mesh.position(mesh.edge_target(e));
  const GeodesicTrace along = trace_geodesic(
      mesh, *tm.geometry, SurfacePoint::edge(e, 0.25),
      to_frame(mesh, TriangleMesh::face_of(mesh.edge_halfedge(e)), unit3(b - a)), 10.0);
  EXPECT_EQ(along.stop, TraceStop::HitVertex);
  EXPECT_EQ(along.stop_vertex, static_cast<std::int32_t>(mesh.edge_target(e)));
  EXPECT_NEAR(along.length, 0.75 * dist(a, b), 1e-15);
}

TEST(GeodesicTracingFlat, ZeroLengthReturnsTheStart) {
  const FlatCase fc = jittered_grid();
  const TriangleMesh& mesh = *fc.tm.mesh;
  const std::uint32_t v = 30;  // interior
  const std::uint32_t f = TriangleMesh::face_of(mesh.outgoing_halfedges(v)[0]);
  const std::uint32_t e = mesh.edge_of(3 * f + 1);
  const SurfacePoint starts[] = {SurfacePoint::face(f, 0.2, 0.3, 0.5), SurfacePoint::vertex(v),
                                 SurfacePoint::edge(e, 0.4)};
  for (const SurfacePoint& start : starts) {
    // A direction into the face from any of these starts (towards the centroid), not unit.
    const Vec3 c = mesh.face_point(f, {1.0 / 3, 1.0 / 3, 1.0 / 3});
    const Vec3 d = 3.0 * unit3(c - start.position(mesh));
    const GeodesicTrace trace =
        trace_geodesic(mesh, *fc.tm.geometry, start, to_frame(mesh, f, d), 0.0);
    ASSERT_EQ(trace.points.size(), 1u) << start.to_string();
    EXPECT_EQ(trace.points[0].point.to_string(), start.to_string());
    EXPECT_EQ(trace.end.to_string(), start.to_string());
    EXPECT_EQ(trace.stop, TraceStop::Completed);
    EXPECT_EQ(trace.length, 0.0);
    EXPECT_EQ(trace.end_direction.face, f);
    EXPECT_NEAR(norm(dir3(mesh, trace.end_direction) - (1.0 / 3) * d), 0, 1e-15);
  }
}

TEST(GeodesicTracingFlat, SlightlyOutwardStartDirections) {
  const FlatCase fc = jittered_grid();
  const TriangleMesh& mesh = *fc.tm.mesh;
  const IntrinsicGeometry& g = *fc.tm.geometry;
  Worst worst;
  const double out_angle = 1e-8;  // float-stored directions are off by about this much
  // Vertex start: a direction just past either edge of the wedge of face f continues in the
  // neighbouring face and is still the straight line.
  const std::uint32_t v = 5 * 13 + 6;  // interior vertex (i=6, j=5)
  ASSERT_FALSE(mesh.is_boundary_vertex(v));
  for (std::uint32_t h : mesh.outgoing_halfedges(v)) {
    const std::uint32_t f = TriangleMesh::face_of(h);
    const Vec3 p = mesh.position(v);
    const Vec3 e1 = unit3(mesh.position(mesh.target(h)) - p);
    const Vec3 e2 = unit3(mesh.position(mesh.opposite_vertex(h)) - p);
    const double alpha = std::atan2(norm(cross(e1, e2)), dot(e1, e2));
    const Vec3 n = unit3(e2 - dot(e2, e1) * e1);
    for (double theta : {-out_angle, alpha + out_angle}) {
      const Vec3 d = std::cos(theta) * e1 + std::sin(theta) * n;
      const std::string where = "face " + std::to_string(f) + " theta " + fmt(theta);
      check_flat_line(mesh, g, SurfacePoint::vertex(v), f, d, 0.3, worst, where);
    }
    // Far outside: refused.
    const Vec3 back = -1.0 * unit3(e1 + e2);
    try {
      (void)trace_geodesic(mesh, g, SurfacePoint::vertex(v), to_frame(mesh, f, back), 0.3);
      ADD_FAILURE() << "no throw for a direction out of the wedge of face " << f;
    } catch (const InvalidInput& err) {
      EXPECT_EQ(err.reason(), "BadDirection");
    }
  }
  // Edge start: a direction just out of face f (either end) crosses into the other face.
  const std::uint32_t h = mesh.outgoing_halfedges(v)[0];
  const std::uint32_t e = mesh.edge_of(h);
  const std::uint32_t f = TriangleMesh::face_of(h);
  const SurfacePoint start = SurfacePoint::edge(e, 0.3);
  const Vec3 u = unit3(mesh.position(mesh.target(h)) - mesh.position(mesh.origin(h)));
  const Vec3 w = mesh.position(mesh.opposite_vertex(h)) - mesh.position(mesh.origin(h));
  const Vec3 n = unit3(w - dot(w, u) * u);
  for (double phi : {-out_angle, kPi + out_angle}) {
    const Vec3 d = std::cos(phi) * u + std::sin(phi) * n;
    check_flat_line(mesh, g, start, f, d, 0.3, worst, "edge start, phi " + fmt(phi));
  }
  try {
    (void)trace_geodesic(mesh, g, start, to_frame(mesh, f, -1.0 * n), 0.3);
    ADD_FAILURE() << "no throw for a direction out of face " << f;
  } catch (const InvalidInput& err) {
    EXPECT_EQ(err.reason(), "BadDirection");
  }
  EXPECT_LE(worst.error, 1.0) << worst.where << " (error / 1e-12)";

  // Boundary vertex: a direction just outside the surface is clamped onto the boundary edge.
  const std::uint32_t corner = 3;  // on the bottom side y = 0
  ASSERT_TRUE(mesh.is_boundary_vertex(corner));
  const Vec3 dx{1, 0, 0};
  const Vec3 tilted{std::cos(out_angle), -std::sin(out_angle), 0};
  const std::uint32_t fb = wedge_face(mesh, corner, unit3(Vec3{1, 0.1, 0}));
  const GeodesicTrace clamped =
      trace_geodesic(mesh, g, SurfacePoint::vertex(corner), to_frame(mesh, fb, tilted), 0.05);
  EXPECT_EQ(clamped.stop, TraceStop::Completed);
  EXPECT_NEAR(dist(clamped.end.position(mesh), mesh.position(corner) + 0.05 * dx), 0, 1e-15);
}

TEST(GeodesicTracingFlat, FacePointOnAnEdgeWithTheOtherFacesDirection) {
  const FlatCase fc = jittered_grid();
  const TriangleMesh& mesh = *fc.tm.mesh;
  const IntrinsicGeometry& g = *fc.tm.geometry;
  Worst worst;
  // f's point with a zero barycentric lies on the edge opposite that corner; the direction is
  // given in the face across that edge.
  const std::uint32_t f = 50;
  const std::uint32_t h = 3 * f + 1;  // opposite corner 0
  ASSERT_GE(mesh.twin(h), 0);
  const std::uint32_t other = TriangleMesh::face_of(static_cast<std::uint32_t>(mesh.twin(h)));
  const SurfacePoint start = SurfacePoint::face(f, 0, 0.3, 0.7);
  const Vec3 p = start.position(mesh);
  const Vec3 c = mesh.face_point(other, {1.0 / 3, 1.0 / 3, 1.0 / 3});
  const Vec3 d = unit3(c - p);
  check_flat_line(mesh, g, start, other, d, 0.2, worst, "edge point as face point");
  // Two zero barycentrics: the vertex, with a direction in any of its faces.
  const SurfacePoint at_vertex = SurfacePoint::face(f, 0, 1, 0);
  const std::uint32_t vtx = mesh.face(f)[1];
  for (std::uint32_t hv : mesh.outgoing_halfedges(vtx)) {
    const std::uint32_t fv = TriangleMesh::face_of(hv);
    const Vec3 dv = unit3(mesh.face_point(fv, {1.0 / 3, 1.0 / 3, 1.0 / 3}) - mesh.position(vtx));
    check_flat_line(mesh, g, at_vertex, fv, dv, 0.15, worst,
                    "vertex as face point, face " + std::to_string(fv));
  }
  EXPECT_LE(worst.error, 1.0) << worst.where << " (error / 1e-12)";
}

TEST(GeodesicTracingFlat, ReusesTheOutput) {
  const FlatCase fc = jittered_grid();
  const TriangleMesh& mesh = *fc.tm.mesh;
  const IntrinsicGeometry& g = *fc.tm.geometry;
  const SurfacePoint start = SurfacePoint::face(40, 0.3, 0.3, 0.4);
  const FaceDirection d = to_frame(mesh, 40, {std::cos(2.0), std::sin(2.0), 0});
  GeodesicTrace out;
  trace_geodesic(mesh, g, start, d, 0.8, {}, out);
  ASSERT_EQ(out.stop, TraceStop::Completed);
  const std::size_t long_size = out.points.size();
  const PathPoint* data = out.points.data();
  trace_geodesic(mesh, g, start, d, 0.3, {}, out);
  EXPECT_LT(out.points.size(), long_size);
  EXPECT_EQ(out.points.data(), data);  // capacity reused, no reallocation
  const GeodesicTrace fresh = trace_geodesic(mesh, g, start, d, 0.3);
  ASSERT_EQ(out.points.size(), fresh.points.size());
  for (std::size_t k = 0; k < out.points.size(); ++k) {
    EXPECT_EQ(out.points[k].point.to_string(), fresh.points[k].point.to_string());
  }
  EXPECT_EQ(out.length, fresh.length);
  EXPECT_EQ(out.stop, fresh.stop);
  // A failed call leaves the output as it was.
  EXPECT_THROW(trace_geodesic(mesh, g, start, d, -1.0, {}, out), InvalidInput);
  EXPECT_EQ(out.points.size(), fresh.points.size());
  // Stop fields are reset between calls.
  trace_geodesic(mesh, g, start, d, 100.0, {}, out);
  EXPECT_EQ(out.stop, TraceStop::HitBoundary);
  trace_geodesic(mesh, g, start, d, 0.1, {}, out);
  EXPECT_EQ(out.stop, TraceStop::Completed);
  EXPECT_EQ(out.stop_vertex, -1);
}

// ---------------------------------------------------------------------------------------------
// Prism: the lateral surface unrolls onto a strip of width = perimeter, glued at its sides.

struct Unrolled {
  Vec3 position, direction;
};

/// 3D point and direction of unrolled (u, z) with unrolled direction (du, dz).
Unrolled prism_point(const Prism& pr, double u, double z, double du, double dz) {
  const double per = pr.perimeter();
  u = std::fmod(u, per);
  if (u < 0) u += per;
  const int j = std::min(static_cast<int>(u / pr.side), pr.segments - 1);
  const Vec3 a = pr.rim(j), b = pr.rim(j + 1);
  const Vec3 along = normalized(b - a);
  const Vec3 up{0, 0, 1};
  return {a + (u - j * pr.side) * along + z * up, du * along + dz * up};
}

TEST(GeodesicTracingPrism, AroundTheSideFollowsTheUnrolledLine) {
  const Prism pr = prism_surface(1.0, 2.0, 12, 8);
  const TestMesh tm = make_test_mesh(pr.data);
  const TriangleMesh& mesh = *tm.mesh;
  Rng rng(21);
  Worst worst;
  std::size_t max_points = 0;
  for (int k = 0; k < 200; ++k) {
    const SurfacePoint start = random_face_point(mesh, rng);
    const Vec3 p = start.position(mesh);
    const P2 uz = pr.unroll(p, tm.face_tag[start.id]);
    const double beta = rng.uniform(-0.3, 0.3) + (rng.uniform() < 0.5 ? kPi : 0.0);
    const double du = std::cos(beta), dz = std::sin(beta);
    double length = rng.uniform(0.1, 2.5) * pr.perimeter();
    if (dz > 0) length = std::min(length, 0.97 * (pr.height - uz.y) / dz);
    if (dz < 0) length = std::min(length, 0.97 * uz.y / -dz);
    const Unrolled s = prism_point(pr, uz.x, uz.y, du, dz);
    const std::string where = "case " + std::to_string(k) + " from " + start.to_string();
    const GeodesicTrace trace =
        trace_geodesic(mesh, *tm.geometry, start, to_frame(mesh, start.id, s.direction), length);
    check_invariants(mesh, trace, start, where);
    EXPECT_EQ(trace.stop, TraceStop::Completed) << where;
    const Unrolled e = prism_point(pr, uz.x + length * du, uz.y + length * dz, du, dz);
    worst.add(dist(trace.points.back().position, e.position) / kPos,
              where + ": end " + fmt(trace.points.back().position) + ", expected " +
                  fmt(e.position));
    worst.add(norm(dir3(mesh, trace.end_direction) - e.direction) / kPos,
              where + ": end direction");
    max_points = std::max(max_points, trace.points.size());
  }
  EXPECT_LE(worst.error, 1.0) << worst.where << " (error / 1e-12)";
  EXPECT_GT(max_points, 50u);  // some traces go around more than once
}

TEST(GeodesicTracingPrism, ReachesTheRims) {
  const Prism pr = prism_surface(1.0, 2.0, 12, 8);
  const TestMesh tm = make_test_mesh(pr.data);
  const TriangleMesh& mesh = *tm.mesh;
  Rng rng(22);
  Worst worst;
  for (int k = 0; k < 100; ++k) {
    const SurfacePoint start = random_face_point(mesh, rng);
    const P2 uz = pr.unroll(start.position(mesh), tm.face_tag[start.id]);
    const double beta = rng.uniform(0.2, kPi - 0.2) * (rng.uniform() < 0.5 ? 1 : -1);
    const double du = std::cos(beta), dz = std::sin(beta);
    const double exit = dz > 0 ? (pr.height - uz.y) / dz : uz.y / -dz;
    const Unrolled s = prism_point(pr, uz.x, uz.y, du, dz);
    const std::string where = "case " + std::to_string(k) + " from " + start.to_string();
    const GeodesicTrace trace = trace_geodesic(
        mesh, *tm.geometry, start, to_frame(mesh, start.id, s.direction), exit + 1.0);
    check_invariants(mesh, trace, start, where);
    ASSERT_EQ(trace.stop, TraceStop::HitBoundary) << where;
    EXPECT_TRUE(mesh.is_boundary_edge(trace.end.id)) << where;
    worst.add(std::abs(trace.length - exit) / kPos, where + ": length");
    const Unrolled e = prism_point(pr, uz.x + exit * du, uz.y + exit * dz, du, dz);
    worst.add(dist(trace.end.position(mesh), e.position) / kPos, where + ": end");
  }
  EXPECT_LE(worst.error, 1.0) << worst.where << " (error / 1e-12)";
}

// ---------------------------------------------------------------------------------------------
// Cube [0, 2]^3: unfolding across the edges.

TEST(GeodesicTracingCube, AcrossOneEdgeTurnsDown) {
  const Cube cube = cube_surface(4, 2.0);
  const TestMesh tm = make_test_mesh(cube.data);
  const TriangleMesh& mesh = *tm.mesh;
  Rng rng(31);
  Worst worst;
  for (int k = 0; k < 200; ++k) {
    // From the top face z = 2 towards the edge x = 2; on the face x = 2 the x component of the
    // direction becomes -z.
    const Vec3 p{rng.uniform(0.1, 1.9), rng.uniform(0.5, 1.5), 2};
    const double a = rng.uniform(-0.9, 0.9);
    const double dx = std::cos(a), dy = std::sin(a);
    const double to_edge = (2 - p.x) / dx;
    const Vec3 crossing{2, p.y + to_edge * dy, 2};
    if (crossing.y < 0.05 || crossing.y > 1.95) continue;
    // Beyond the edge: stay on the face x = 2 (0 < y < 2, 0 < z < 2).
    double room = 1.9 / dx;
    if (dy > 0) room = std::min(room, (1.95 - crossing.y) / dy);
    if (dy < 0) room = std::min(room, (crossing.y - 0.05) / -dy);
    const double length = to_edge + rng.uniform(0.01, 1.0) * room;
    const Vec3 expected = crossing + (length - to_edge) * Vec3{0, dy, -dx};
    const SurfacePoint start = *locate(mesh, p);
    const std::string where = "case " + std::to_string(k) + " from " + fmt(p);
    const GeodesicTrace trace =
        trace_geodesic(mesh, *tm.geometry, start, to_frame(mesh, start.id, {dx, dy, 0}), length);
    check_invariants(mesh, trace, start, where);
    EXPECT_EQ(trace.stop, TraceStop::Completed) << where;
    worst.add(dist(trace.points.back().position, expected) / kPos,
              where + ": end " + fmt(trace.points.back().position) + ", expected " +
                  fmt(expected));
    worst.add(norm(dir3(mesh, trace.end_direction) - Vec3{0, dy, -dx}) / kPos,
              where + ": end direction");
    // The crossing of the cube edge is one of the points.
    double nearest = 1;
    for (const PathPoint& q : trace.points) nearest = std::min(nearest, dist(q.position, crossing));
    worst.add(nearest / kPos, where + ": cube edge crossing");
  }
  EXPECT_GT(worst.count, 300);
  EXPECT_LE(worst.error, 1.0) << worst.where << " (error / 1e-12)";
}

TEST(GeodesicTracingCube, AroundTheBeltFollowsTheUnfoldedLine) {
  const Cube cube = cube_surface(4, 2.0);
  const TestMesh tm = make_test_mesh(cube.data);
  const TriangleMesh& mesh = *tm.mesh;
  // Belt around the y axis, arc s in [0, 8): top (z = 2, +x), x = 2 (-z), bottom (z = 0, -x),
  // x = 0 (+z).
  auto belt = [](double s, double y) -> Unrolled {
    s = std::fmod(s, 8.0);
    if (s < 0) s += 8;
    const int side = std::min(static_cast<int>(s / 2), 3);
    const double r = s - 2 * side;
    switch (side) {
      case 0: return {{r, y, 2}, {1, 0, 0}};
      case 1: return {{2, y, 2 - r}, {0, 0, -1}};
      case 2: return {{2 - r, y, 0}, {-1, 0, 0}};
      default: return {{0, y, r}, {0, 0, 1}};
    }
  };
  Rng rng(32);
  Worst worst;
  for (int k = 0; k < 100; ++k) {
    const double s0 = rng.uniform(0.05, 1.95), y0 = rng.uniform(0.6, 1.4);
    const double g = rng.uniform(-0.1, 0.1) + (rng.uniform() < 0.5 ? kPi : 0.0);
    const double ds = std::cos(g), dy = std::sin(g);
    const double length = std::min(rng.uniform(0.1, 20.0), 0.5 / std::max(std::abs(dy), 1e-3));
    const Unrolled p = belt(s0, y0);
    const SurfacePoint start = *locate(mesh, p.position);
    const Vec3 d = ds * p.direction + Vec3{0, dy, 0};
    const std::string where = "case " + std::to_string(k) + " from " + fmt(p.position);
    const GeodesicTrace trace =
        trace_geodesic(mesh, *tm.geometry, start, to_frame(mesh, start.id, d), length);
    check_invariants(mesh, trace, start, where);
    EXPECT_EQ(trace.stop, TraceStop::Completed) << where;
    const Unrolled e = belt(s0 + length * ds, y0 + length * dy);
    worst.add(dist(trace.points.back().position, e.position) / kPos,
              where + ": end " + fmt(trace.points.back().position) + ", expected " +
                  fmt(e.position));
    worst.add(norm(dir3(mesh, trace.end_direction) - (ds * e.direction + Vec3{0, dy, 0})) / kPos,
              where + ": end direction");
  }
  EXPECT_LE(worst.error, 1.0) << worst.where << " (error / 1e-12)";
}

TEST(GeodesicTracingCube, AimedAtACubeCornerStopsThere) {
  const Cube cube = cube_surface(4, 2.0);
  const TestMesh tm = make_test_mesh(cube.data);
  const TriangleMesh& mesh = *tm.mesh;
  const Vec3 p{0.83, 1.21, 2};
  const Vec3 corner{2, 2, 2};
  const double distance = dist(p, corner);
  const SurfacePoint start = *locate(mesh, p);
  const GeodesicTrace trace = trace_geodesic(
      mesh, *tm.geometry, start, to_frame(mesh, start.id, (1.0 / distance) * (corner - p)), 5.0);
  check_invariants(mesh, trace, start, "to the corner");
  EXPECT_EQ(trace.stop, TraceStop::HitVertex);
  EXPECT_EQ(trace.stop_vertex, static_cast<std::int32_t>(vertex_at(mesh, corner)));
  EXPECT_NEAR(trace.length, distance, 1e-14);
}

TEST(GeodesicTracingCube, UnfoldDirectionAcrossACubeEdge) {
  const Cube cube = cube_surface(2, 2.0);
  const TestMesh tm = make_test_mesh(cube.data);
  const TriangleMesh& mesh = *tm.mesh;
  int checked = 0;
  for (std::uint32_t h = 0; h < mesh.num_halfedges(); ++h) {
    const std::uint32_t f = TriangleMesh::face_of(h);
    const auto twin = static_cast<std::uint32_t>(mesh.twin(h));
    const std::uint32_t g = TriangleMesh::face_of(twin);
    // 3D: keep the component along the edge, turn the across component from f's plane into
    // g's (pointing away from the edge into g).
    const Vec3 a = mesh.position(mesh.origin(h)), b = mesh.position(mesh.target(h));
    const Vec3 u = unit3(b - a);
    auto inward = [&](std::uint32_t face_h) {
      const Vec3 w = mesh.position(mesh.opposite_vertex(face_h)) - a;
      return unit3(w - dot(w, u) * u);
    };
    const Vec3 nf = inward(h), ng = inward(twin);
    const double along = 0.6, across = -0.8;  // leaving f through the edge
    const Vec3 d = along * u + across * nf;
    const FaceDirection unfolded = unfold_direction(mesh, *tm.geometry, h, to_frame(mesh, f, d));
    EXPECT_EQ(unfolded.face, g);
    EXPECT_NEAR(norm(dir3(mesh, unfolded) - (along * u - across * ng)), 0, 1e-15) << "h " << h;
    ++checked;
  }
  EXPECT_EQ(checked, static_cast<int>(mesh.num_halfedges()));
  EXPECT_THROW((void)unfold_direction(mesh, *tm.geometry, 0, {1, 1, 0}), InvalidInput);
  EXPECT_THROW((void)unfold_direction(mesh, *tm.geometry,
                                      static_cast<std::uint32_t>(mesh.num_halfedges()), {0, 1, 0}),
               InvalidInput);
}

// ---------------------------------------------------------------------------------------------
// Faceted cone: the surface develops onto a sector of angle Theta around the apex.

struct Developed {
  Vec3 position, radial, angular;  ///< 3D point, unit radial and angular directions there
};

/// 3D point of developed polar coordinates (r, phi) (phi taken modulo Theta).
Developed cone_point(const Fan& fan, double r, double phi) {
  phi = std::fmod(phi, fan.total_angle);
  if (phi < 0) phi += fan.total_angle;
  int j = 0;
  while (j + 1 < static_cast<int>(fan.sector_start.size()) && fan.sector_start[j + 1] <= phi) ++j;
  const int n = static_cast<int>(fan.rim.size());
  const Vec3 a = normalized(fan.rim[j] - fan.apex);
  const Vec3 b = normalized(fan.rim[(j + 1) % n] - fan.apex);
  const Vec3 w = normalized(b - dot(b, a) * a);
  const double delta = phi - fan.sector_start[j];
  const Vec3 radial = std::cos(delta) * a + std::sin(delta) * w;
  const Vec3 angular = -std::sin(delta) * a + std::cos(delta) * w;
  return {fan.apex + r * radial, radial, angular};
}

TEST(GeodesicTracingCone, FollowsTheDevelopedLine) {
  const Fan fan = cone_surface(1.0, 1.0, 16, 4);
  const TestMesh tm = make_test_mesh(fan.data);
  const TriangleMesh& mesh = *tm.mesh;
  ASSERT_GT(fan.total_angle, kPi);
  const double slant = dist(fan.apex, fan.rim[0]);
  const double inner = slant * std::cos(fan.total_angle / 32);  // inside every rim chord
  Rng rng(41);
  Worst worst;
  int around = 0;
  for (int k = 0; k < 300; ++k) {
    const SurfacePoint start = random_face_point(mesh, rng);
    const P2 polar = fan.develop(start.position(mesh), tm.face_tag[start.id]);
    const P2 p{polar.x * std::cos(polar.y), polar.x * std::sin(polar.y)};
    const double psi = rng.uniform(0, 2 * kPi);
    const P2 d{std::cos(psi), std::sin(psi)};
    // Stay inside the disk of radius `inner` and away from the apex.
    const double pd = dot2(p, d);
    const double exit = -pd + std::sqrt(pd * pd - dot2(p, p) + inner * inner);
    if (!(exit > 0.05)) continue;
    const double length = rng.uniform(0.05, 0.97) * exit;
    const double closest = std::clamp(-pd, 0.0, length);
    if (norm2(p + closest * d) < 0.05) continue;
    const Developed s = cone_point(fan, polar.x, polar.y);
    const P2 er{std::cos(polar.y), std::sin(polar.y)}, ephi{-std::sin(polar.y), std::cos(polar.y)};
    const Vec3 d3 = dot2(d, er) * s.radial + dot2(d, ephi) * s.angular;
    const std::string where = "case " + std::to_string(k) + " from " + start.to_string();
    const GeodesicTrace trace =
        trace_geodesic(mesh, *tm.geometry, start, to_frame(mesh, start.id, d3), length);
    check_invariants(mesh, trace, start, where);
    EXPECT_EQ(trace.stop, TraceStop::Completed) << where;
    const P2 q = p + length * d;
    const double turn = std::atan2(cross2(p, q), dot2(p, q));
    if (std::abs(turn) > 1.0) ++around;
    const double phi_end = polar.y + turn;
    const Developed e = cone_point(fan, norm2(q), phi_end);
    const P2 er2{std::cos(phi_end), std::sin(phi_end)};
    const P2 ephi2{-std::sin(phi_end), std::cos(phi_end)};
    worst.add(dist(trace.points.back().position, e.position) / kPos,
              where + ": end " + fmt(trace.points.back().position) + ", expected " +
                  fmt(e.position));
    worst.add(norm(dir3(mesh, trace.end_direction) -
                   (dot2(d, er2) * e.radial + dot2(d, ephi2) * e.angular)) /
                  kPos,
              where + ": end direction");
  }
  EXPECT_GT(worst.count, 400);
  EXPECT_GT(around, 10);  // lines that turn far around the apex (through the cut at phi = 0)
  EXPECT_LE(worst.error, 1.0) << worst.where << " (error / 1e-12)";
}

TEST(GeodesicTracingCone, AimedAtTheApexStopsThere) {
  const Fan fan = cone_surface(1.0, 1.0, 16, 4);
  const TestMesh tm = make_test_mesh(fan.data);
  const TriangleMesh& mesh = *tm.mesh;
  Rng rng(42);
  for (int k = 0; k < 20; ++k) {
    const SurfacePoint start = random_face_point(mesh, rng);
    const Vec3 p = start.position(mesh);
    const double r = dist(p, fan.apex);
    const GeodesicTrace trace = trace_geodesic(
        mesh, *tm.geometry, start, to_frame(mesh, start.id, (1.0 / r) * (fan.apex - p)), 2 * r);
    check_invariants(mesh, trace, start, start.to_string());
    EXPECT_EQ(trace.stop, TraceStop::HitVertex) << start.to_string();
    EXPECT_EQ(trace.stop_vertex, 0) << start.to_string();
    EXPECT_NEAR(trace.length, r, 1e-14) << start.to_string();
  }
}

// ---------------------------------------------------------------------------------------------
// Degenerate faces.

TEST(GeodesicTracingDegenerate, CapsAreCrossedStraight) {
  // Caps with an angle of nearly 180 degrees in every cell; the surface is the flat square.
  // Edge lengths rounded to doubles do not describe it exactly: a cap's height (~1.8e-8) from
  // lengths that are off by ~1e-17 is off by ~1e-10, so the intrinsic surface has angle defects
  // of ~1e-9 rad at the caps' apexes and its straightest lines bend by that much; a segment
  // across a cap is as long in 3D as in the cap's layout only to ~1e-10. Positions are compared
  // to 1e-8, the polyline's length to 1e-9 (of the unit square's size).
  const TestMesh tm = make_test_mesh(cap_grid(8, 8, 0.125, 1e-7));
  const TriangleMesh& mesh = *tm.mesh;
  Rng rng(51);
  Worst worst;
  for (int k = 0; k < 200; ++k) {
    const SurfacePoint start = random_face_point(mesh, rng);
    const Vec3 p = start.position(mesh);
    const double a = rng.uniform(0, 2 * kPi);
    const Vec3 d{std::cos(a), std::sin(a), 0};
    const double length = rng.uniform(0, 0.97) * box_exit(p, d, 1.0, 1.0);
    const std::string where = "case " + std::to_string(k) + " from " + start.to_string();
    const GeodesicTrace trace =
        trace_geodesic(mesh, *tm.geometry, start, to_frame(mesh, start.id, d), length);
    check_invariants(mesh, trace, start, where, 1e-9, 1.0);
    if (trace.stop == TraceStop::HitVertex) {
      // Passing within vertex_tolerance of a cap's 180-degree corner is a vertex hit: check
      // that it was on the line.
      const Vec3 v = mesh.position(static_cast<std::uint32_t>(trace.stop_vertex));
      worst.add(norm(cross(d, v - p)) / 1e-8, where + ": vertex hit off the line");
      continue;
    }
    EXPECT_EQ(trace.stop, TraceStop::Completed) << where;
    worst.add(dist(trace.points.back().position, p + length * d) / 1e-8,
              where + ": end " + fmt(trace.points.back().position));
  }
  EXPECT_LE(worst.error, 1.0) << worst.where << " (error / 1e-8)";
}

TEST(GeodesicTracingDegenerate, ZeroAreaFaceStopsAtItsNearestCorner) {
  // Cell (1, 1) of size 0.25: its point M is exactly the midpoint of the diagonal, so face
  // (p00, M, p11) has zero area.
  const double h = 0.25;
  const TestMesh tm = make_test_mesh(cap_grid(4, 4, h, 1e-3, {{1, 1}}));
  const TriangleMesh& mesh = *tm.mesh;
  const IntrinsicGeometry& g = *tm.geometry;
  const std::uint32_t p00 = vertex_at(mesh, {h, h, 0}), p11 = vertex_at(mesh, {2 * h, 2 * h, 0});
  const std::uint32_t m = vertex_at(mesh, {1.5 * h, 1.5 * h, 0});
  int degenerate = 0;
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) degenerate += g.is_degenerate_face(f);
  ASSERT_EQ(degenerate, 1);
  // From the upper triangle (p00, p11, p01) of the cell straight down (-y): crosses the diagonal
  // at x, enters the zero-area face there.
  struct Case {
    double x;
    std::uint32_t corner;
  };
  for (const Case c : {Case{1.2 * h, p00}, Case{1.45 * h, m}, Case{1.6 * h, m}, Case{1.9 * h, p11}}) {
    const Vec3 p{c.x, c.x + 0.05 * h, 0};  // just above the diagonal y = x
    const SurfacePoint start = *locate(mesh, p);
    const std::string where = "x = " + fmt(c.x);
    const GeodesicTrace trace =
        trace_geodesic(mesh, g, start, to_frame(mesh, start.id, {0, -1, 0}), 1.0);
    check_invariants(mesh, trace, start, where);
    EXPECT_EQ(trace.stop, TraceStop::HitVertex) << where;
    EXPECT_EQ(trace.stop_vertex, static_cast<std::int32_t>(c.corner)) << where;
    ASSERT_EQ(trace.points.size(), 3u) << where;  // start, diagonal crossing, corner
    const Vec3 crossing{c.x, c.x, 0};
    EXPECT_NEAR(dist(trace.points[1].position, crossing), 0, 1e-15) << where;
    EXPECT_NEAR(trace.length, 0.05 * h + dist(crossing, mesh.position(c.corner)), 1e-15) << where;
  }
}

// ---------------------------------------------------------------------------------------------
// Bad input.

TEST(GeodesicTracingInput, BadInputsThrowWithReasons) {
  const FlatCase fc = jittered_grid();
  const TriangleMesh& mesh = *fc.tm.mesh;
  const IntrinsicGeometry& g = *fc.tm.geometry;
  const SurfacePoint start = SurfacePoint::face(10, 0.2, 0.3, 0.5);
  const FaceDirection ok{10, 0.6, 0.8};
  auto reason = [&](const SurfacePoint& s, const FaceDirection& d, double length,
                    const GeodesicTraceOptions& options = {}) -> std::string {
    try {
      (void)trace_geodesic(mesh, g, s, d, length, options);
    } catch (const InvalidInput& e) {
      return e.reason();
    }
    return "no throw";
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(reason(start, ok, 0.1), "no throw");
  EXPECT_EQ(reason(start, {10, 0, 0}, 0.1), "BadDirection");
  EXPECT_EQ(reason(start, {10, nan, 1}, 0.1), "BadDirection");
  EXPECT_EQ(reason(start, {10, inf, 0}, 0.1), "BadDirection");
  EXPECT_EQ(reason(start, {10, 0, 0}, 0.0), "BadDirection");  // checked even for length 0
  EXPECT_EQ(reason(start, {11, 0.6, 0.8}, 0.1), "BadDirection");  // face does not hold start
  EXPECT_EQ(reason(start, {1u << 30, 0.6, 0.8}, 0.1), "FaceOutOfRange");
  EXPECT_EQ(reason(start, ok, -1e-300), "BadLength");
  EXPECT_EQ(reason(start, ok, nan), "BadLength");
  EXPECT_EQ(reason(start, ok, inf), "BadLength");
  EXPECT_EQ(reason(SurfacePoint::face(1u << 30, 1, 0, 0), ok, 0.1), "FaceOutOfRange");
  EXPECT_EQ(reason(SurfacePoint::face(10, 0.5, 0.5, 0.5), ok, 0.1), "BadBarycentric");
  EXPECT_EQ(reason(SurfacePoint::vertex(1u << 30), ok, 0.1), "VertexOutOfRange");
  EXPECT_EQ(reason(SurfacePoint::edge(1u << 30, 0.5), ok, 0.1), "EdgeOutOfRange");
  EXPECT_EQ(reason(SurfacePoint::edge(0, 1.5), ok, 0.1), "BadEdgeParameter");
  // Vertex and edge starts in a face that does not contain them.
  const std::uint32_t far_vertex = mesh.face(200)[0];
  EXPECT_EQ(reason(SurfacePoint::vertex(far_vertex), ok, 0.1), "BadDirection");
  EXPECT_EQ(reason(SurfacePoint::edge(mesh.edge_of(600), 0.5), ok, 0.1), "BadDirection");
  // Pointing out of the face from its vertex / edge.
  const std::uint32_t v = mesh.face(10)[0];
  const FaceDirection out_of_corner{10, -1, -0.1};  // corner 0 is at the frame's origin
  EXPECT_EQ(reason(SurfacePoint::vertex(v), out_of_corner, 0.1), "BadDirection");
  const std::uint32_t e = mesh.edge_of(30);  // halfedge 3 * 10 + 0: the frame's x axis
  EXPECT_EQ(reason(SurfacePoint::edge(e, 0.5), {10, 0.3, -1}, 0.1), "BadDirection");
  EXPECT_EQ(reason(SurfacePoint::edge(e, 0.5), {10, 0.3, 1}, 0.1), "no throw");
  // The same as face points with zero barycentrics: the vertex (corner 0), the edge (opposite
  // corner 2).
  EXPECT_EQ(reason(SurfacePoint::face(10, 1, 0, 0), out_of_corner, 0.1), "BadDirection");
  EXPECT_EQ(reason(SurfacePoint::face(10, 0.5, 0.5, 0), {10, 0.3, -1}, 0.1), "BadDirection");
  EXPECT_EQ(reason(SurfacePoint::face(10, 0.5, 0.5, 0), {10, 0.3, 1}, 0.1), "no throw");
  GeodesicTraceOptions bad;
  bad.vertex_tolerance = -1;
  EXPECT_EQ(reason(start, ok, 0.1, bad), "BadTolerance");
  bad = {};
  bad.angle_tolerance = nan;
  EXPECT_EQ(reason(start, ok, 0.1, bad), "BadTolerance");
}

// ---------------------------------------------------------------------------------------------
// The exact solver's end directions, traced, land on its paths (what queries on the proximity
// graph rely on).

TEST(GeodesicTracingExact, TracesExactPathsFromBothEnds) {
  const std::string path = std::string(GEOPROX_SOURCE_DIR) + "/data/meshes/spot.obj";
  const TriangleMesh mesh = load_mesh(path);
  const IntrinsicGeometry g(mesh);
  const double scale = bbox_diagonal(mesh);
  Rng rng(61);
  int traced = 0;
  Worst worst;
  for (int k = 0; k < 150 && traced < 25; ++k) {
    const SurfacePoint s = random_face_point(mesh, rng);
    const SurfacePoint t = random_face_point(mesh, rng);
    const GeodesicPath exact = exact_geodesic_path(mesh, g, s, t);
    bool straight = true;  // no pseudo-source vertex on the way
    for (std::size_t i = 1; i + 1 < exact.points.size(); ++i) {
      straight = straight && exact.points[i].point.kind == SurfacePoint::Kind::Edge;
    }
    if (!straight || exact.points.size() < 3) continue;
    ++traced;
    const std::string where = "case " + std::to_string(k) + " " + s.to_string() + " -> " +
                              t.to_string();
    const GeodesicTrace forward = trace_geodesic(mesh, g, s, exact.direction_at_source, exact.length);
    check_invariants(mesh, forward, s, where);
    EXPECT_EQ(forward.stop, TraceStop::Completed) << where;
    worst.add(dist(forward.points.back().position, t.position(mesh)) / (1e-9 * scale),
              where + ": forward end");
    // Same edges crossed, at the same places.
    if (forward.points.size() == exact.points.size()) {
      for (std::size_t i = 1; i + 1 < exact.points.size(); ++i) {
        EXPECT_EQ(forward.points[i].point.id, exact.points[i].point.id) << where << " point " << i;
        worst.add(dist(forward.points[i].position, exact.points[i].position) / (1e-9 * scale),
                  where + ": crossing " + std::to_string(i));
      }
    } else {
      ADD_FAILURE() << where << ": " << forward.points.size() << " points, exact path has "
                    << exact.points.size();
    }
    const GeodesicTrace backward =
        trace_geodesic(mesh, g, t, exact.direction_at_target, exact.length);
    EXPECT_EQ(backward.stop, TraceStop::Completed) << where;
    worst.add(dist(backward.points.back().position, s.position(mesh)) / (1e-9 * scale),
              where + ": backward end");
  }
  EXPECT_GE(traced, 20);
  EXPECT_LE(worst.error, 1.0) << worst.where << " (error / 1e-9 of the diagonal)";
}

}  // namespace
}  // namespace geoprox
