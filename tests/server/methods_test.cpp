// Every method end to end over a real socket, compared with in-process GeodesicQuery answers.
#include <bit>
#include <cmath>
#include <limits>

#include "core/geodesic/exact_geodesic.h"
#include "protocol/base64.h"
#include "server/service.h"
#include "tests/server/server_test_support.h"

namespace geoprox::server::testing {
namespace {

class MethodsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = new TestData();
    Config config = spot_config(*data_);
    config.admin_token = "s3cret";
    server_ = new RunningServer(config);
    reference_ = new Reference(data_->data_dir() / "meshes/spot.obj",
                               data_->graph_dir() / "spot.geoprox");
  }
  static void TearDownTestSuite() {
    delete reference_;
    delete server_;
    delete data_;
  }
  static std::string version() { return mesh_version_of(reference_->file); }

  static TestData* data_;
  static RunningServer* server_;
  static Reference* reference_;
};
TestData* MethodsTest::data_ = nullptr;
RunningServer* MethodsTest::server_ = nullptr;
Reference* MethodsTest::reference_ = nullptr;

TEST_F(MethodsTest, DistanceEqualsInProcessForEveryPointKind) {
  Client c(server_->port());
  Reference& r = *reference_;
  const SurfacePoint s = SurfacePoint::vertex(0);
  struct Case {
    json wire;
    SurfacePoint point;
  };
  const std::vector<Case> cases = {
      {"v:1500", SurfacePoint::vertex(1500)},
      {json{{"face", 100}, {"bary", {0.2, 0.3, 0.5}}}, SurfacePoint::face(100, 0.2, 0.3, 0.5)},
      {json{{"edge", 208}, {"t", 0.25}}, SurfacePoint::edge(208, 0.25)},
      {json{{"sample", 7}}, r.query.sample_point(7)},
  };
  for (const Case& k : cases) {
    const json result =
        c.result("geodesic.distance", {{"mesh", "spot"}, {"source", "v:0"}, {"target", k.wire}});
    const DistanceResult expected = r.query.distance(s, k.point, r.scratch);
    EXPECT_DOUBLE_EQ(result["distance"].get<double>(), expected.distance) << k.wire.dump();
    EXPECT_EQ(result["exact"].get<bool>(), expected.exact);
    EXPECT_EQ(result["mesh"], "spot");
    EXPECT_EQ(result["mesh_version"], version());
    EXPECT_EQ(result["source"], json({{"vertex", 0}}));
  }
  // A position snaps to the surface: the answer is the snapped point's.
  const Vec3 p = r.mesh.face_point(100, {0.2, 0.3, 0.5});
  const json result = c.result("geodesic.distance", {{"mesh", "spot"},
                                                     {"source", "v:0"},
                                                     {"target", {{"position", {p.x, p.y, p.z}}}}});
  const SnapResult snapped = r.query.snap(p);
  EXPECT_DOUBLE_EQ(result["distance"].get<double>(),
                   r.query.distance(s, snapped.point, r.scratch).distance);
}

TEST_F(MethodsTest, NearPairsEqualInProcessWithTheirSolvesSplitAcrossThreads) {
  // Pairs 1.5 to 3 link radii apart are near pairs (refined through two exact disks). The
  // server (2 compute threads, one request at a time) runs the second disk on its idle thread;
  // the answers must be those of one thread (the same solves: equal to a few ulps at most).
  Client c(server_->port());
  Reference& r = *reference_;
  const double rho = r.query.link_radius();
  ExactGeodesicSolver solver(r.mesh, r.geometry);
  ExactGeodesicOptions options;
  options.max_distance = 3 * rho;
  std::size_t pairs = 0, near_solves = 0;
  r.scratch.set_run_both([&](const std::function<void()>& first,
                             const std::function<void()>& second) {
    ++near_solves;  // in-process: one after the other
    first();
    second();
  });
  for (std::uint32_t source = 0; source < r.mesh.num_vertices(); source += 97) {
    solver.solve(SurfacePoint::vertex(source), options);
    std::uint32_t target = UINT32_MAX;
    for (const std::uint32_t v : solver.touched_vertices()) {
      const double d = solver.distance(v);
      if (d >= 1.5 * rho && d <= 3 * rho) target = v;
    }
    if (target == UINT32_MAX) continue;
    const SurfacePoint s = SurfacePoint::vertex(source), t = SurfacePoint::vertex(target);
    const std::string sw = "v:" + std::to_string(source), tw = "v:" + std::to_string(target);
    const DistanceResult expected = r.query.distance(s, t, r.scratch);
    const json result =
        c.result("geodesic.distance", {{"mesh", "spot"}, {"source", sw}, {"target", tw}});
    EXPECT_DOUBLE_EQ(result["distance"].get<double>(), expected.distance) << sw << " " << tw;
    const PathResult path = r.query.path(s, t, r.scratch);
    const json wire_path =
        c.result("geodesic.path", {{"mesh", "spot"}, {"source", sw}, {"target", tw}});
    EXPECT_DOUBLE_EQ(wire_path["distance"].get<double>(), path.distance) << sw << " " << tw;
    EXPECT_EQ(wire_path["points"].size(), path.points.size()) << sw << " " << tw;
    ++pairs;
  }
  r.scratch.set_run_both({});
  EXPECT_GE(pairs, 20u);
  EXPECT_GE(near_solves, pairs);  // the near-pair route ran (for the distance and the path)
  // ... and the server ran second halves on its idle compute thread.
  EXPECT_GT(server_->server->metrics().split_halves.load(), 0u);
}

TEST_F(MethodsTest, ExactDistanceEqualsTheExactSolver) {
  // The server bounds its exact solve by the graph's answer and directs it at the target; the
  // answers must be a full solve's, near and far, at vertices, edges and faces.
  Client c(server_->port());
  ExactGeodesicSolver solver(reference_->mesh, reference_->geometry);
  const std::vector<std::pair<SurfacePoint, std::string>> sources{
      {SurfacePoint::vertex(0), "v:0"},
      {SurfacePoint::face(2000, 0.3, 0.3, 0.4), "f:2000:0.3:0.3:0.4"}};
  const std::vector<std::pair<SurfacePoint, std::string>> targets{
      {SurfacePoint::face(100, 0.2, 0.3, 0.5), "f:100:0.2:0.3:0.5"},
      {SurfacePoint::vertex(1), "v:1"},
      {SurfacePoint::vertex(2900), "v:2900"},
      {SurfacePoint::edge(5000, 0.25), "e:5000:0.25"},
      {SurfacePoint::face(2000, 0.3, 0.3, 0.4), "f:2000:0.3:0.3:0.4"}};
  for (const auto& [s, s_text] : sources) {
    solver.solve(s);
    for (const auto& [t, t_text] : targets) {
      const json result = c.result("geodesic.distance", {{"mesh", "spot"},
                                                         {"source", s_text},
                                                         {"target", t_text},
                                                         {"exact", true}});
      EXPECT_TRUE(result["exact"].get<bool>()) << s_text << " " << t_text;
      EXPECT_NEAR(result["distance"].get<double>(), solver.distance(t), 1e-12)
          << s_text << " " << t_text;
    }
  }
}

TEST_F(MethodsTest, PathEqualsInProcess) {
  Client c(server_->port());
  const json result =
      c.result("geodesic.path", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "e:208:0.5"}});
  const PathResult expected = reference_->query.path(
      SurfacePoint::vertex(0), SurfacePoint::edge(208, 0.5), reference_->scratch);
  EXPECT_DOUBLE_EQ(result["distance"].get<double>(), expected.distance);
  ASSERT_EQ(result["points"].size(), expected.points.size());
  for (std::size_t i = 0; i < expected.points.size(); ++i) {
    const json& point = result["points"][i];
    const auto [face, bary] = expected.points[i].point.in_face(reference_->mesh);
    EXPECT_EQ(point["face"].get<std::uint32_t>(), face);
    EXPECT_DOUBLE_EQ(point["position"][0].get<double>(), expected.points[i].position.x);
    EXPECT_DOUBLE_EQ(point["bary"][1].get<double>(), bary[1]);
  }
  EXPECT_EQ(result["target"], json({{"edge", 208}, {"t", 0.5}}));
}

TEST_F(MethodsTest, FieldInBothEncodingsEqualsInProcess) {
  Client c(server_->port());
  const std::vector<SurfacePoint> sources = {SurfacePoint::vertex(0),
                                             SurfacePoint::vertex(2000)};
  DistanceFieldOptions options;
  options.max_distance = 0.5;
  const DistanceField expected = reference_->query.field(sources, reference_->scratch, options);

  const json j = c.result("geodesic.field", {{"mesh", "spot"},
                                             {"sources", {"v:0", "v:2000"}},
                                             {"cutoff", 0.5}});
  ASSERT_EQ(j["distances"].size(), reference_->mesh.num_vertices());
  EXPECT_EQ(j["encoding"], "json");
  EXPECT_EQ(j["vertices"], reference_->mesh.num_vertices());
  std::size_t reached = 0;
  for (std::size_t v = 0; v < expected.distances.size(); ++v) {
    if (std::isfinite(expected.distances[v])) {
      ++reached;
      EXPECT_DOUBLE_EQ(j["distances"][v].get<double>(), expected.distances[v]);
      EXPECT_EQ(j["nearest_source"][v].get<int>(), expected.nearest_source[v]);
    } else {
      EXPECT_TRUE(j["distances"][v].is_null());
      EXPECT_TRUE(j["nearest_source"][v].is_null());
    }
  }
  EXPECT_EQ(j["reached"], reached);

  const json b = c.result("geodesic.field", {{"mesh", "spot"},
                                             {"sources", {"v:0", "v:2000"}},
                                             {"cutoff", 0.5},
                                             {"encoding", "f32le-base64"}});
  const std::vector<float> f = protocol::decode_f32le_base64(b["distances"].get<std::string>());
  const std::vector<std::uint32_t> n =
      protocol::decode_u32le_base64(b["nearest_source"].get<std::string>());
  ASSERT_EQ(f.size(), expected.distances.size());
  for (std::size_t v = 0; v < f.size(); ++v) {
    EXPECT_EQ(f[v], static_cast<float>(expected.distances[v]));
    EXPECT_EQ(n[v], expected.nearest_source[v] < 0 ? 0xFFFFFFFFu
                                                   : static_cast<std::uint32_t>(
                                                         expected.nearest_source[v]));
  }
}

TEST_F(MethodsTest, MatrixEqualsInProcess) {
  Client c(server_->port());
  const json result = c.result("geodesic.matrix", {{"mesh", "spot"},
                                                   {"sources", {"v:0", "v:1"}},
                                                   {"targets", {"v:2", "f:5:0.2:0.3:0.5", "s:7"}}});
  const std::vector<SurfacePoint> s = {SurfacePoint::vertex(0), SurfacePoint::vertex(1)};
  const std::vector<SurfacePoint> t = {SurfacePoint::vertex(2),
                                       SurfacePoint::face(5, 0.2, 0.3, 0.5),
                                       reference_->query.sample_point(7)};
  const std::vector<double> expected = reference_->query.matrix(s, t, reference_->scratch);
  ASSERT_EQ(result["distances"].size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    for (std::size_t k = 0; k < 3; ++k) {
      EXPECT_DOUBLE_EQ(result["distances"][i][k].get<double>(), expected[i * 3 + k]);
    }
  }
  EXPECT_EQ(result["unreachable"], 0);
  EXPECT_EQ(result["sources"], 2);
  EXPECT_EQ(result["targets"], 3);
}

// The bits of a distance as the JSON encoding sends it (+inf for null: not reached).
std::uint64_t json_bits(const json& number) {
  return std::bit_cast<std::uint64_t>(number.is_null() ? std::numeric_limits<double>::infinity()
                                                       : number.get<double>());
}

TEST_F(MethodsTest, F64Base64FieldAndMatrixAreTheJsonNumbersBitForBit) {
  Client c(server_->port());
  // A cutoff leaves vertices unreached: +inf in f64le-base64 where JSON has null.
  const json params = {{"mesh", "spot"}, {"sources", {"v:0", "f:100:0.2:0.3:0.5"}},
                       {"cutoff", 0.4}};
  json f64_params = params;
  f64_params["encoding"] = "f64le-base64";
  const json as_json = c.result("geodesic.field", params);
  const json as_f64 = c.result("geodesic.field", f64_params);
  EXPECT_EQ(as_f64["encoding"], "f64le-base64");
  EXPECT_EQ(as_f64["reached"], as_json["reached"]);
  const std::vector<double> field =
      protocol::decode_f64le_base64(as_f64["distances"].get<std::string>());
  const std::vector<std::uint32_t> nearest =
      protocol::decode_u32le_base64(as_f64["nearest_source"].get<std::string>());
  ASSERT_EQ(field.size(), as_json["distances"].size());
  std::size_t unreached = 0;
  for (std::size_t v = 0; v < field.size(); ++v) {
    ASSERT_EQ(std::bit_cast<std::uint64_t>(field[v]), json_bits(as_json["distances"][v])) << v;
    const json& k = as_json["nearest_source"][v];
    EXPECT_EQ(nearest[v], k.is_null() ? 0xFFFFFFFFu : k.get<std::uint32_t>()) << v;
    unreached += std::isinf(field[v]) ? 1 : 0;
  }
  EXPECT_GT(unreached, 0u);
  EXPECT_EQ(field.size() - unreached, as_f64["reached"].get<std::size_t>());

  const json sources = {"v:0", "v:1", "f:5:0.2:0.3:0.5"};
  const json targets = {"v:2", "f:7:0.6:0.3:0.1", "s:7", "e:3:0.25"};
  const json matrix_json =
      c.result("geodesic.matrix", {{"mesh", "spot"}, {"sources", sources}, {"targets", targets}});
  const json matrix_f64 = c.result("geodesic.matrix", {{"mesh", "spot"},
                                                       {"sources", sources},
                                                       {"targets", targets},
                                                       {"encoding", "f64le-base64"}});
  EXPECT_FALSE(matrix_json.contains("encoding"));
  EXPECT_EQ(matrix_f64["encoding"], "f64le-base64");
  EXPECT_EQ(matrix_f64["sources"], 3);
  EXPECT_EQ(matrix_f64["targets"], 4);
  EXPECT_EQ(matrix_f64["unreachable"], 0);
  const std::vector<double> matrix =
      protocol::decode_f64le_base64(matrix_f64["distances"].get<std::string>());
  ASSERT_EQ(matrix.size(), 12u);
  for (std::size_t i = 0; i < 3; ++i) {
    for (std::size_t k = 0; k < 4; ++k) {
      EXPECT_EQ(std::bit_cast<std::uint64_t>(matrix[i * 4 + k]),
                json_bits(matrix_json["distances"][i][k]))
          << i << "," << k;
    }
  }

  // In a batch too, and f32le-base64 is refused for a matrix.
  const json batch = c.result(
      "batch", {{"requests",
                 {{{"method", "geodesic.matrix"},
                   {"params", {{"mesh", "spot"}, {"sources", sources}, {"targets", targets},
                               {"encoding", "f64le-base64"}}}},
                  {{"method", "geodesic.matrix"},
                   {"params", {{"mesh", "spot"}, {"sources", sources}, {"targets", targets},
                               {"encoding", "f32le-base64"}}}}}}});
  EXPECT_EQ(batch["results"][0]["result"]["distances"], matrix_f64["distances"]);
  EXPECT_EQ(batch["results"][1]["error"]["data"]["reason"], "InvalidParams");
}

TEST_F(MethodsTest, BatchAnswersEachEntryInOrder) {
  Client c(server_->port());
  const json result = c.result(
      "batch",
      {{"requests",
        {{{"method", "geodesic.distance"},
          {"params", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:1"}}}},
         {{"method", "geodesic.distance"},
          {"params", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "f:9999:1:0:0"}}}},
         {{"method", "mesh.list"}},
         {{"method", "geodesic.nope"}},
         {{"method", "geodesic.field"},
          {"params", {{"mesh", "spot"}, {"source", "v:3"}, {"encoding", "f32le-base64"}}}}}}});
  const json& results = result["results"];
  ASSERT_EQ(results.size(), 5u);
  EXPECT_DOUBLE_EQ(results[0]["result"]["distance"].get<double>(),
                   reference_->query
                       .distance(SurfacePoint::vertex(0), SurfacePoint::vertex(1),
                                 reference_->scratch)
                       .distance);
  EXPECT_EQ(results[1]["error"]["data"]["reason"], "FaceOutOfRange");
  EXPECT_EQ(results[1]["error"]["code"], -32602);
  EXPECT_EQ(results[2]["result"]["meshes"][0]["id"], "spot");
  EXPECT_EQ(results[3]["error"]["data"]["reason"], "UnknownMethod");
  EXPECT_EQ(results[4]["result"]["vertices"], reference_->mesh.num_vertices());
}

TEST_F(MethodsTest, MeshListAndInfo) {
  Client c(server_->port());
  const json list = c.result("mesh.list");
  ASSERT_EQ(list["meshes"].size(), 1u);
  const json& spot = list["meshes"][0];
  EXPECT_EQ(spot["id"], "spot");
  EXPECT_EQ(spot["state"], "ready");
  EXPECT_EQ(spot["progress"], 1.0);
  EXPECT_EQ(spot["mesh_version"], version());
  EXPECT_EQ(spot["vertices"], reference_->mesh.num_vertices());
  EXPECT_EQ(spot["samples"], reference_->file.counts().samples);
  EXPECT_TRUE(spot["error"].is_null());

  const json info = c.result("mesh.info", {{"mesh", "spot"}});
  EXPECT_EQ(info["mesh"], "spot");
  EXPECT_EQ(info["edges"], reference_->mesh.num_edges());
  EXPECT_EQ(info["graph_edges"], reference_->file.counts().graph_edges);
  EXPECT_EQ(info["mesh_file"], "meshes/spot.obj");
  EXPECT_EQ(info["build"]["samples"], small_spot_params().samples);
  EXPECT_DOUBLE_EQ(info["covering_radius"].get<double>(), reference_->file.covering_radius());
  EXPECT_DOUBLE_EQ(info["link_radius"].get<double>(), reference_->file.link_radius());
  EXPECT_GT(info["link_radius"].get<double>(), 2 * info["covering_radius"].get<double>())
      << "spot's samples leave no gap: Theorem 4.2 bounds its answers";
  EXPECT_EQ(c.error_reason("mesh.info", {{"mesh", "nope"}}), "UnknownMesh");
}

TEST_F(MethodsTest, ServerInfoHealthMetrics) {
  Client c(server_->port());
  const json info = c.result("server.info");
  EXPECT_EQ(info["protocol_version"], 1);
  EXPECT_EQ(info["admin_enabled"], true);
  EXPECT_EQ(info["limits"]["max_line_bytes"], 1048576);
  EXPECT_EQ(info["encodings"], json({"json", "f32le-base64", "f64le-base64"}));

  const json health = c.result("server.health");
  EXPECT_EQ(health["status"], "ok");
  EXPECT_EQ(health["ready"], true);
  EXPECT_EQ(health["meshes_ready"], 1);
  EXPECT_EQ(health["meshes_total"], 1);

  c.result("geodesic.distance", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:1"}});
  const json metrics = c.result("server.metrics");
  EXPECT_EQ(metrics["format"], "prometheus-text-0.0.4");
  const std::string text = metrics["text"];
  EXPECT_NE(text.find("geoprox_requests_total{transport=\"tcp\",method=\"geodesic.distance\",outcome=\"ok\"}"),
            std::string::npos);
  EXPECT_NE(text.find("geoprox_request_duration_seconds_bucket{transport=\"tcp\",method=\"geodesic.distance\""),
            std::string::npos);
  // Bucket bounds in their shortest form that reads back as the same double.
  EXPECT_NE(text.find("method=\"geodesic.distance\",le=\"0.00025\"}"), std::string::npos);
  EXPECT_EQ(text.find("0.00025000000000000001"), std::string::npos);
  EXPECT_NE(text.find("geoprox_mesh_ready{mesh=\"spot\"} 1"), std::string::npos);
  EXPECT_NE(text.find("geoprox_queue_depth"), std::string::npos);
}

TEST_F(MethodsTest, UnreachableIsAnErrorInDistanceAndNullInMatrix) {
  // two_components.obj: two separate triangles' worth of surface.
  TempDir dir;
  fs::create_directories(dir.path() / "data/meshes");
  fs::copy_file(source_dir() / "tests/data/two_components.obj",
                dir.path() / "data/meshes/two.obj");
  const TriangleMesh mesh = load_mesh((dir.path() / "data/meshes/two.obj").string());
  Config config;
  config.port = 0;
  config.admin_port = 0;
  config.http_port = 0;
  config.compute_threads = 1;
  config.build_threads = 1;
  config.data_dir = dir.path() / "data";
  config.graph_dir = dir.path() / "graphs";
  MeshConfig two;
  two.id = "two";
  two.mesh_path = config.data_dir / "meshes/two.obj";
  two.graph_path = config.graph_dir / "two.geoprox";
  two.build = BuildParams{static_cast<std::uint32_t>(std::min<std::size_t>(4, mesh.num_vertices())),
                          1, 0, SamplingMethod::FastMarching};
  config.meshes.push_back(two);
  RunningServer server(config);
  Client c(server.port());
  const json list = c.result("mesh.list");
  for (const json& m : list["meshes"]) {
    ASSERT_EQ(m["state"], "ready") << list.dump();  // the server waited for every build
  }
  // The last vertex lies in the other component than vertex 0.
  const std::string far = "v:" + std::to_string(mesh.num_vertices() - 1);
  const json reply = c.call("geodesic.distance", {{"mesh", "two"}, {"source", "v:0"}, {"target", far}});
  ASSERT_TRUE(reply.contains("error")) << reply.dump();
  EXPECT_EQ(reply["error"]["data"]["reason"], "Unreachable");
  EXPECT_EQ(reply["error"]["code"], -32010);
  const json exact = c.call("geodesic.distance",
                            {{"mesh", "two"}, {"source", "v:0"}, {"target", far}, {"exact", true}});
  ASSERT_TRUE(exact.contains("error")) << exact.dump();
  EXPECT_EQ(exact["error"]["data"]["reason"], "Unreachable");
  const json matrix =
      c.result("geodesic.matrix", {{"mesh", "two"}, {"sources", {"v:0"}}, {"targets", {"v:0", far}}});
  EXPECT_EQ(matrix["distances"][0][0], 0.0);
  EXPECT_TRUE(matrix["distances"][0][1].is_null());
  EXPECT_EQ(matrix["unreachable"], 1);
  const json f64 = c.result("geodesic.matrix", {{"mesh", "two"},
                                                {"sources", {"v:0"}},
                                                {"targets", {"v:0", far}},
                                                {"encoding", "f64le-base64"}});
  EXPECT_EQ(f64["unreachable"], 1);
  EXPECT_EQ(protocol::decode_f64le_base64(f64["distances"].get<std::string>()),
            (std::vector<double>{0.0, std::numeric_limits<double>::infinity()}));
}

TEST(ConstantTimeEqual, ComparesWholeSecrets) {
  EXPECT_TRUE(constant_time_equal("s3cret", "s3cret"));
  EXPECT_FALSE(constant_time_equal("s3cre", "s3cret"));
  EXPECT_FALSE(constant_time_equal("s3cretx", "s3cret"));
  EXPECT_FALSE(constant_time_equal("", "s3cret"));
  EXPECT_FALSE(constant_time_equal("s3creT", "s3cret"));
  EXPECT_FALSE(constant_time_equal("", ""));
}

}  // namespace
}  // namespace geoprox::server::testing
