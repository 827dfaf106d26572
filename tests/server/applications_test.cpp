// Issue 7 in the daemon: geodesic.expmap and geodesic.spline end to end, compared with the core
// objects in process, and the `metric` key of a mesh in the config.
#include <cmath>
#include <fstream>

#include "core/apps/exponential_map.h"
#include "core/apps/geodesic_spline.h"
#include "tests/server/server_test_support.h"

namespace geoprox::server::testing {
namespace {

TEST(Applications, ExpmapAndSplineEqualTheCoreObjects) {
  TestData data;
  RunningServer server(spot_config(data));
  Reference r(data.data_dir() / "meshes/spot.obj", data.graph_dir() / "spot.geoprox");
  Client c(server.port());

  for (bool exact : {false, true}) {
    const json result = c.result(
        "geodesic.expmap", {{"mesh", "spot"}, {"source", "v:100"}, {"radius", 0.3}, {"exact", exact}});
    ExponentialMap map(r.query);
    ExponentialMapOptions options;
    options.radius = 0.3;
    options.mode = exact ? ExponentialMapMode::Exact : ExponentialMapMode::Graph;
    const ExponentialMapResult expected = map.compute(SurfacePoint::vertex(100), options);
    ASSERT_EQ(result["count"].get<std::size_t>(), expected.vertices.size());
    ASSERT_GT(expected.vertices.size(), 50u);
    EXPECT_EQ(result["exact"], exact);
    for (std::size_t k = 0; k < expected.vertices.size(); ++k) {
      EXPECT_EQ(result["vertices"][k].get<std::uint32_t>(), expected.vertices[k].vertex);
      EXPECT_DOUBLE_EQ(result["u"][k].get<double>(), expected.vertices[k].u);
      EXPECT_DOUBLE_EQ(result["v"][k].get<double>(), expected.vertices[k].v);
    }
  }

  const std::vector<SurfacePoint> control = {SurfacePoint::vertex(100), SurfacePoint::vertex(120),
                                             SurfacePoint::vertex(140), SurfacePoint::vertex(160)};
  const json result = c.result("geodesic.spline", {{"mesh", "spot"},
                                                   {"control", {"v:100", "v:120", "v:140", "v:160"}},
                                                   {"type", "bspline"},
                                                   {"samples", 20}});
  GeodesicSpline spline(r.query);
  GeodesicSplineOptions options;
  options.type = SplineType::BSpline;
  options.samples = 20;
  const GeodesicSplineResult expected = spline.compute(control, options);
  ASSERT_EQ(result["points"].size(), 20u);
  ASSERT_EQ(result["control_polygon"].size(), 3u);
  for (std::size_t k = 0; k < 20; ++k) {
    const json& p = result["points"][k];
    const Vec3 at = r.mesh.face_point(p["face"].get<std::uint32_t>(), p["bary"].get<std::array<double, 3>>());
    EXPECT_LT(norm(at - expected.curve[k].position), 1e-12) << k;
    EXPECT_DOUBLE_EQ(p["position"][0].get<double>(), expected.curve[k].position.x);
  }
  EXPECT_EQ(result["type"], "bspline");

  // Refusals name the parameter.
  EXPECT_EQ(c.error_reason("geodesic.expmap", {{"mesh", "spot"}, {"source", "v:0"}}), "InvalidParams");
  EXPECT_EQ(c.error_reason("geodesic.spline",
                           {{"mesh", "spot"}, {"control", {"v:0", "v:1", "v:2", "v:9999999"}}}),
            "VertexOutOfRange");
  EXPECT_EQ(c.error_reason("geodesic.expmap", {{"mesh", "nope"}, {"source", "v:0"}, {"radius", 1}}),
            "UnknownMesh");
}

/// A flat n x n grid of unit cells as OBJ (vertex (i, j) is j*(n+1) + i), and a metric file
/// scaling every length by `scale` (one 3D tensor per face), with face `bad_face` indefinite
/// when >= 0.
void write_grid(const fs::path& obj, const fs::path& metric, int n, double scale, int bad_face) {
  std::ofstream out(obj);
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) out << "v " << i << " " << j << " 0\n";
  }
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i + 1, b = a + 1, c = a + n + 2, d = a + n + 1;
      out << "f " << a << " " << b << " " << c << "\nf " << a << " " << c << " " << d << "\n";
    }
  }
  std::ofstream m(metric);
  m << "geoprox-metric 1 face-tensor-3d\n";
  const double s2 = scale * scale;
  for (int f = 0; f < 2 * n * n; ++f) {
    if (f == bad_face) {
      m << "1 0 0 -1 0 1\n";
    } else {
      m << s2 << " 0 0 " << s2 << " 0 " << s2 << "\n";
    }
  }
}

TEST(Applications, MeshWithAMetricRebuildsAPlainGraphAndAnswersInTheMetric) {
  TestData data;
  const int n = 8;
  write_grid(data.data_dir() / "meshes/grid.obj", data.data_dir() / "meshes/grid.metric", n, 3, -1);
  write_grid(data.data_dir() / "meshes/bad.obj", data.data_dir() / "meshes/bad.metric", n, 3, 10);
  // A graph built without the metric sits where the daemon looks: it must not be used.
  const BuildParams small{16, 5, 0, SamplingMethod::FastMarching};
  {
    const TriangleMesh mesh = load_mesh((data.data_dir() / "meshes/grid.obj").string());
    const IntrinsicGeometry geometry(mesh);
    ProximityGraphOptions options;
    options.num_samples = small.samples;
    options.neighbors = small.neighbors;
    write_graph_file((data.graph_dir() / "grid.geoprox").string(), mesh, geometry,
                     build_proximity_graph(mesh, geometry, options));
  }
  const json document = {
      {"data_dir", data.data_dir().string()},
      {"graph_dir", data.graph_dir().string()},
      {"meshes",
       {{{"id", "grid"}, {"mesh", "meshes/grid.obj"}, {"metric", "meshes/grid.metric"},
         {"samples", 16}, {"neighbors", 5}, {"sampling", "fmm"}},
        {{"id", "bad"}, {"mesh", "meshes/bad.obj"}, {"metric", "meshes/bad.metric"},
         {"samples", 16}, {"neighbors", 5}}}}};
  Config config = parse_config(document, "/");
  ASSERT_EQ(config.meshes.size(), 2u);
  EXPECT_EQ(config.meshes[0].build.metric_path, data.data_dir() / "meshes/grid.metric");
  config.port = 0;
  config.admin_port = 0;
  config.http_port = 0;
  config.compute_threads = 2;
  config.build_threads = 1;
  RunningServer server(config);
  Client c(server.port());
  const json list = c.result("mesh.list");
  ASSERT_EQ(list["meshes"].size(), 2u);
  EXPECT_EQ(list["meshes"][0]["state"], "ready") << list.dump();
  EXPECT_EQ(list["meshes"][1]["state"], "failed");
  const std::string error = list["meshes"][1]["error"].get<std::string>();
  EXPECT_NE(error.find("face 10:"), std::string::npos) << error;
  EXPECT_NE(error.find("NotPositiveDefinite"), std::string::npos) << error;

  // Distances are the metric's: 3 times the Euclidean ones (exact and graph).
  const double diagonal = 3 * n * std::sqrt(2.0);
  const json exact = c.result("geodesic.distance",
                              {{"mesh", "grid"}, {"source", "v:0"}, {"target", "v:80"}, {"exact", true}});
  EXPECT_NEAR(exact["distance"].get<double>(), diagonal, 1e-9 * diagonal);
  const json graph = c.result("geodesic.distance", {{"mesh", "grid"}, {"source", "v:0"}, {"target", "v:80"}});
  EXPECT_GE(graph["distance"].get<double>(), diagonal * (1 - 1e-9));
  EXPECT_LE(graph["distance"].get<double>(), diagonal * 1.1);
  // The plain graph on disk was replaced by one built under the metric.
  const TriangleMesh mesh = load_mesh((data.data_dir() / "meshes/grid.obj").string());
  const IntrinsicGeometry plain(mesh);
  const MappedGraphFile file = MappedGraphFile::open((data.graph_dir() / "grid.geoprox").string());
  EXPECT_THROW(file.verify_mesh(mesh, plain), FileError);

  // The config refuses an empty metric.
  json empty = document;
  empty["meshes"][0]["metric"] = "";
  try {
    parse_config(empty, "/");
    ADD_FAILURE() << "an empty metric was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("meshes[0].metric"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace geoprox::server::testing
