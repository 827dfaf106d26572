// Tests of core/riemannian_metric: a metric changes only edge lengths, and the solvers then give
// the metric's distances (exact solver to its precision, graph queries within Theorem 4.2).
#include "core/mesh/riemannian_metric.h"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/query/geodesic_query.h"
#include "core/graph/graph_file.h"
#include "core/graph/proximity_graph.h"
#include "tests/core/application_test_support.h"
#include "tests/core/test_meshes.h"
#include "tests/core/test_support.h"

namespace geoprox {
namespace {

using namespace test_meshes;
using test_support::fmt;
namespace fs = std::filesystem;

bool close_rel(double a, double b, double rel) {
  return std::abs(a - b) <= rel * std::max(std::abs(a), std::abs(b));
}

/// A constant metric on the plane z = 0: M = [[mxx, mxy], [mxy, myy]] in world x, y.
struct PlaneMetric {
  double mxx = 4, mxy = 1, myy = 2;
  double distance(const Vec3& a, const Vec3& b) const {
    const double dx = b.x - a.x, dy = b.y - a.y;
    return std::sqrt(mxx * dx * dx + 2 * mxy * dx * dy + myy * dy * dy);
  }
  /// As a 3D tensor (z gets 1: flat faces never see it).
  RiemannianMetric as_3d(const TriangleMesh& mesh) const {
    RiemannianMetric m{MetricKind::FaceTensor3D, {}};
    for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
      m.values.insert(m.values.end(), {mxx, mxy, 0, myy, 0, 1});
    }
    return m;
  }
  /// As 2D tensors in each face's frame: M_f = B^T M B, B = [x_hat y_hat] of the face.
  RiemannianMetric as_2d(const TriangleMesh& mesh) const {
    RiemannianMetric m{MetricKind::FaceTensor2D, {}};
    for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
      const Vec3 p0 = mesh.position(mesh.face(f)[0]), p1 = mesh.position(mesh.face(f)[1]),
                 p2 = mesh.position(mesh.face(f)[2]);
      const Vec3 x = normalized(p1 - p0);
      const Vec3 n = cross(p1 - p0, p2 - p0);
      const Vec3 y = normalized(cross(n, x));
      auto form = [&](const Vec3& a, const Vec3& b) {
        return mxx * a.x * b.x + mxy * (a.x * b.y + a.y * b.x) + myy * a.y * b.y;
      };
      m.values.insert(m.values.end(), {form(x, x), form(x, y), form(y, y)});
    }
    return m;
  }
};

const TestMesh& grid() { return jittered_unit_grid(); }

RiemannianMetric scaling_2d(const TriangleMesh& mesh, double s) {
  RiemannianMetric m{MetricKind::FaceTensor2D, {}};
  for (std::size_t f = 0; f < mesh.num_faces(); ++f)
    m.values.insert(m.values.end(), {s * s, 0, s * s});
  return m;
}

RiemannianMetric scaling_3d(const TriangleMesh& mesh, double s) {
  RiemannianMetric m{MetricKind::FaceTensor3D, {}};
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    m.values.insert(m.values.end(), {s * s, 0, 0, s * s, 0, s * s});
  }
  return m;
}

std::string message_of(const std::function<void()>& f, std::string& reason) {
  try {
    f();
  } catch (const Error& e) {
    reason = e.reason();
    return e.what();
  }
  reason = "(nothing thrown)";
  return "";
}

// ---------------------------------------------------------------------------------------------
// Side-file format

TEST(RiemannianMetric, FormatAndParseRoundTripBitForBit) {
  const TriangleMesh& mesh = *grid().mesh;
  for (const RiemannianMetric& m :
       {PlaneMetric{}.as_2d(mesh), PlaneMetric{}.as_3d(mesh),
        RiemannianMetric{MetricKind::EdgeLengths, IntrinsicGeometry(mesh).edge_lengths()}}) {
    std::istringstream in(format_metric(m));
    const RiemannianMetric back = parse_metric(in, "memory");
    EXPECT_EQ(back.kind, m.kind);
    EXPECT_TRUE(test_support::same_bits(back.values, m.values)) << metric_kind_name(m.kind);
  }
  std::istringstream commented(
      "# a comment\n\ngeoprox-metric 1 edge-lengths  # trailing comment\n1.5\n\n2 # two\n");
  const RiemannianMetric m = parse_metric(commented, "c.metric");
  EXPECT_EQ(m.kind, MetricKind::EdgeLengths);
  EXPECT_EQ(m.values, (std::vector<double>{1.5, 2}));
}

TEST(RiemannianMetric, ParseErrorsNameTheLine) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "m.txt: empty"},
      {"geoprox-graph 1 edge-lengths\n", "m.txt:1: expected the header"},
      {"geoprox-metric 2 edge-lengths\n", "m.txt:1: the header must be"},
      {"geoprox-metric 1 face-tensor-4d\n", "m.txt:1: unknown metric kind 'face-tensor-4d'"},
      {"geoprox-metric 1 face-tensor-2d\n1 0 1\n1 0\n",
       "m.txt:3: expected 3 numbers for face 1, got 2"},
      {"geoprox-metric 1 face-tensor-3d\n1 0 0 1 0 x\n", "m.txt:2: 'x' is not a number"},
      {"geoprox-metric 1 edge-lengths\n1 2\n", "m.txt:2: expected 1 number for edge 0, got 2"},
  };
  for (const auto& [text, expected] : cases) {
    std::istringstream in(text);
    std::string reason;
    const std::string message = message_of([&] { parse_metric(in, "m.txt"); }, reason);
    EXPECT_EQ(reason, "ParseError") << text;
    EXPECT_NE(message.find(expected), std::string::npos) << message;
  }
  std::string reason;
  message_of([] { read_metric_file("/nonexistent/geoprox.metric"); }, reason);
  EXPECT_EQ(reason, "FileNotFound");
}

// ---------------------------------------------------------------------------------------------
// Distances under a metric

TEST(RiemannianMetric, UniformScalingScalesEveryExactDistance) {
  const TestMesh& spot = test_support::spot();
  const TriangleMesh& mesh = *spot.mesh;
  const double s = 2.5;
  std::vector<double> scaled_lengths = spot.geometry->edge_lengths();
  for (double& l : scaled_lengths) l *= s;
  const std::vector<std::pair<std::string, RiemannianMetric>> metrics = {
      {"face-tensor-2d", scaling_2d(mesh, s)},
      {"face-tensor-3d", scaling_3d(mesh, s)},
      {"edge-lengths", RiemannianMetric{MetricKind::EdgeLengths, scaled_lengths}},
  };
  const SurfacePoint sources[] = {SurfacePoint::vertex(0), SurfacePoint::vertex(1234),
                                  SurfacePoint::face(4000, 0.2, 0.3, 0.5)};
  ExactGeodesicSolver plain(mesh, *spot.geometry);
  for (const auto& [name, metric] : metrics) {
    const IntrinsicGeometry geometry = make_metric_geometry(mesh, metric);
    for (std::uint32_t e = 0; e < mesh.num_edges(); ++e) {
      ASSERT_TRUE(close_rel(geometry.edge_length(e), s * spot.geometry->edge_length(e), 1e-12))
          << name << " edge " << e;
    }
    ExactGeodesicSolver solver(mesh, geometry);
    for (const SurfacePoint& source : sources) {
      plain.solve(source);
      solver.solve(source);
      int checked = 0;
      for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
        const double d = plain.distance(v), ds = solver.distance(v);
        ASSERT_TRUE(std::isfinite(d)) << v;
        if (d == 0) {
          EXPECT_EQ(ds, 0);
          continue;
        }
        EXPECT_TRUE(close_rel(ds, s * d, 1e-9))
            << name << " " << source.to_string() << " -> v" << v << ": " << fmt(ds) << " vs "
            << fmt(s * d);
        ++checked;
      }
      EXPECT_GT(checked, 2900);
    }
  }
}

TEST(RiemannianMetric, AnisotropicMetricOnFlatGridGivesAnalyticDistance) {
  const TriangleMesh& mesh = *grid().mesh;
  const PlaneMetric plane;
  for (const RiemannianMetric& metric : {plane.as_2d(mesh), plane.as_3d(mesh)}) {
    const IntrinsicGeometry geometry = make_metric_geometry(mesh, metric);
    for (std::uint32_t e = 0; e < mesh.num_edges(); ++e) {
      ASSERT_TRUE(close_rel(geometry.edge_length(e),
                            plane.distance(mesh.position(mesh.edge_origin(e)),
                                           mesh.position(mesh.edge_target(e))),
                            1e-12))
          << metric_kind_name(metric.kind) << " edge " << e;
    }
    ExactGeodesicSolver solver(mesh, geometry);
    const SurfacePoint sources[] = {SurfacePoint::vertex(0), SurfacePoint::vertex(312),
                                    SurfacePoint::face(500, 0.3, 0.3, 0.4),
                                    SurfacePoint::edge(77, 0.25)};
    for (const SurfacePoint& source : sources) {
      solver.solve(source);
      const Vec3 ps = source.position(mesh);
      double worst = 0;
      for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
        const double analytic = plane.distance(ps, mesh.position(v));
        const double d = solver.distance(v);
        if (analytic < 1e-12) continue;
        worst = std::max(worst, std::abs(d - analytic) / analytic);
      }
      EXPECT_LT(worst, 1e-9) << metric_kind_name(metric.kind) << " from " << source.to_string();
      // Not the Euclidean distance: the metric really changed the answers.
      EXPECT_GT(std::abs(solver.distance(mesh.num_vertices() - 1) -
                         norm(mesh.position(mesh.num_vertices() - 1) - ps)),
                0.1);
    }
  }
}

TEST(RiemannianMetric, GraphQueriesStayWithinTheBoundUnderTheMetric) {
  const TriangleMesh& mesh = *grid().mesh;
  const PlaneMetric plane;
  const IntrinsicGeometry geometry = make_metric_geometry(mesh, plane.as_3d(mesh));
  ProximityGraphOptions options;
  options.num_samples = 100;
  options.neighbors = 8;
  const ProximityGraph graph = build_proximity_graph(mesh, geometry, options);
  const double bound = graph.view().error_bound();
  ASSERT_TRUE(std::isfinite(bound));
  const GeodesicQuery query(mesh, geometry, graph.view());
  QueryScratch scratch = query.make_scratch();
  Rng rng(7);
  double worst = 0, total = 0;
  int graph_answers = 0;
  const int pairs = 300;
  for (int k = 0; k < pairs; ++k) {
    const SurfacePoint s = random_face_point(mesh, rng), t = random_face_point(mesh, rng);
    const double analytic = plane.distance(s.position(mesh), t.position(mesh));
    const DistanceResult r = query.distance(s, t, scratch);
    const std::string what = s.to_string() + " -> " + t.to_string() + ": query " +
                             fmt(r.distance) + ", analytic " + fmt(analytic);
    EXPECT_GE(r.distance, analytic * (1 - 1e-9)) << what;
    EXPECT_LE(r.distance, analytic * (1 + bound)) << what << ", bound " << fmt(bound);
    if (r.exact) {
      EXPECT_TRUE(close_rel(r.distance, analytic, 1e-9)) << what;
    } else {
      ++graph_answers;
    }
    const double rel = (r.distance - analytic) / analytic;
    worst = std::max(worst, rel);
    total += rel;
  }
  EXPECT_GT(graph_answers, pairs / 2);
  EXPECT_LT(total / pairs, 0.02) << "mean relative error";
  RecordProperty("worst_relative_error", fmt(worst));
  RecordProperty("error_bound", fmt(bound));

  // The distance field under the metric, against the analytic one.
  const SurfacePoint source = SurfacePoint::vertex(300);
  const DistanceField field = query.field(std::span<const SurfacePoint>(&source, 1), scratch);
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    const double analytic = plane.distance(mesh.position(300), mesh.position(v));
    EXPECT_GE(field.distances[v], analytic * (1 - 1e-9) - 1e-12) << "v" << v;
    EXPECT_LE(field.distances[v], analytic * (1 + bound) + 1e-12) << "v" << v;
  }
}

TEST(RiemannianMetric, GraphFileBuiltWithMetricIsRefusedWithoutIt) {
  const TriangleMesh& mesh = *grid().mesh;
  const IntrinsicGeometry metric_geometry = make_metric_geometry(mesh, PlaneMetric{}.as_3d(mesh));
  const IntrinsicGeometry plain(mesh);
  ProximityGraphOptions options;
  options.num_samples = 60;
  options.neighbors = 6;
  const ProximityGraph graph = build_proximity_graph(mesh, metric_geometry, options);
  std::string dir = (fs::temp_directory_path() / "geoprox-metric-XXXXXX").string();
  ASSERT_NE(::mkdtemp(dir.data()), nullptr);
  const std::string path = dir + "/grid.geoprox";
  write_graph_file(path, mesh, metric_geometry, graph);
  {
    const MappedGraphFile file = MappedGraphFile::open(path);
    EXPECT_NO_THROW(file.verify_mesh(mesh, metric_geometry));
    std::string reason;
    const std::string message = message_of([&] { file.verify_mesh(mesh, plain); }, reason);
    EXPECT_EQ(reason, "MeshMismatch");
    EXPECT_NE(message.find("edge"), std::string::npos) << message;
    // And the other way round: a plain graph is refused for the mesh under the metric.
    EXPECT_NE(mesh_fingerprint(mesh, plain), mesh_fingerprint(mesh, metric_geometry));
    // The bundle's geometry is the metric's.
    const TriangleMesh bundled = file.make_mesh();
    EXPECT_EQ(file.make_geometry(bundled).edge_lengths(), metric_geometry.edge_lengths());
  }
  fs::remove_all(dir);
}

// ---------------------------------------------------------------------------------------------
// Refusals

TEST(RiemannianMetric, NonPositiveDefiniteTensorsAreRefusedWithTheFaceId) {
  const TriangleMesh& mesh = *grid().mesh;
  std::string reason;

  RiemannianMetric m2 = scaling_2d(mesh, 1);
  m2.values[3 * 17 + 1] = 1.5;  // [[1, 1.5], [1.5, 1]]: eigenvalues 2.5 and -0.5
  std::string message = message_of([&] { metric_edge_lengths(mesh, m2); }, reason);
  EXPECT_EQ(reason, "NotPositiveDefinite");
  EXPECT_NE(message.find("face 17:"), std::string::npos) << message;
  EXPECT_NE(message.find("-0.5"), std::string::npos) << message;

  RiemannianMetric semi = scaling_2d(mesh, 1);
  semi.values[3 * 5 + 2] = 0;  // positive semi-definite only
  message = message_of([&] { metric_edge_lengths(mesh, semi); }, reason);
  EXPECT_EQ(reason, "NotPositiveDefinite");
  EXPECT_NE(message.find("face 5:"), std::string::npos) << message;

  RiemannianMetric m3 = scaling_3d(mesh, 1);
  m3.values[6 * 40 + 5] = -1;  // m_zz < 0
  message = message_of([&] { metric_edge_lengths(mesh, m3); }, reason);
  EXPECT_EQ(reason, "NotPositiveDefinite");
  EXPECT_NE(message.find("face 40:"), std::string::npos) << message;

  RiemannianMetric nan = scaling_3d(mesh, 1);
  nan.values[6 * 9 + 1] = std::nan("");
  message = message_of([&] { metric_edge_lengths(mesh, nan); }, reason);
  EXPECT_EQ(reason, "BadMetric");
  EXPECT_NE(message.find("face 9:"), std::string::npos) << message;

  RiemannianMetric short_metric = scaling_2d(mesh, 1);
  short_metric.values.resize(short_metric.values.size() - 3);
  message = message_of([&] { metric_edge_lengths(mesh, short_metric); }, reason);
  EXPECT_EQ(reason, "BadMetric");
  EXPECT_NE(message.find(std::to_string(mesh.num_faces()) + " faces"), std::string::npos)
      << message;

  RiemannianMetric negative{MetricKind::EdgeLengths, IntrinsicGeometry(mesh).edge_lengths()};
  negative.values[33] = -0.1;
  message = message_of([&] { metric_edge_lengths(mesh, negative); }, reason);
  EXPECT_EQ(reason, "BadMetric");
  EXPECT_NE(message.find("edge 33 "), std::string::npos) << message;
}

TEST(RiemannianMetric, BrokenTriangleInequalitiesAreRefusedWithTheFaceId) {
  const TriangleMesh& mesh = *grid().mesh;
  std::string reason;

  // Explicit lengths: one edge far too long; the first face holding it is named.
  RiemannianMetric lengths{MetricKind::EdgeLengths, IntrinsicGeometry(mesh).edge_lengths()};
  const std::uint32_t edge = 100;
  lengths.values[edge] = 10;
  const std::uint32_t first_face = TriangleMesh::face_of(mesh.edge_halfedge(edge));
  std::string message = message_of([&] { metric_edge_lengths(mesh, lengths); }, reason);
  EXPECT_EQ(reason, "TriangleInequality");
  EXPECT_NE(message.find("face " + std::to_string(first_face) + ":"), std::string::npos)
      << message;
  EXPECT_NE(message.find(std::to_string(edge)), std::string::npos) << message;

  // Face tensors, each fine alone: face 0 (the corner cell's first triangle) 100 times longer
  // than its neighbours. The mean on the diagonal it shares with face 1 is then longer than
  // face 1's two other sides together; face 0 itself keeps its long boundary edge.
  RiemannianMetric tensors = scaling_2d(mesh, 1);
  tensors.values[0] = tensors.values[2] = 1e4;
  message = message_of([&] { metric_edge_lengths(mesh, tensors); }, reason);
  EXPECT_EQ(reason, "TriangleInequality");
  EXPECT_NE(message.find("face 1:"), std::string::npos) << message;
  EXPECT_NE(message.find("averaging"), std::string::npos) << message;
}

TEST(RiemannianMetric, LoadGeometryReadsTheSideFile) {
  const TriangleMesh& mesh = *grid().mesh;
  std::string dir = (fs::temp_directory_path() / "geoprox-metric-XXXXXX").string();
  ASSERT_NE(::mkdtemp(dir.data()), nullptr);
  const std::string path = dir + "/grid.metric";
  const RiemannianMetric metric = PlaneMetric{}.as_2d(mesh);
  {
    std::ofstream out(path);
    out << format_metric(metric);
  }
  EXPECT_EQ(load_geometry(mesh, path).edge_lengths(), metric_edge_lengths(mesh, metric));
  EXPECT_EQ(load_geometry(mesh, "").edge_lengths(), IntrinsicGeometry(mesh).edge_lengths());
  RiemannianMetric bad = metric;
  bad.values[3 * 8] = -2;
  {
    std::ofstream out(path);
    out << format_metric(bad);
  }
  std::string reason;
  const std::string message = message_of([&] { load_geometry(mesh, path); }, reason);
  EXPECT_EQ(reason, "NotPositiveDefinite");
  EXPECT_NE(message.find(path + ": face 8:"), std::string::npos) << message;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace geoprox
