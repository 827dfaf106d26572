// Meshes repaired on load (the config's "repair", admin.register's repair): a non-manifold mesh
// is served with the ids of the file `geoprox repair` writes, mesh.info and the log say what
// repair changed, and without repair the mesh fails with an error that says how to serve it.
#include <cmath>
#include <functional>
#include <sstream>

#include "core/geodesic/exact_geodesic.h"
#include "core/graph/loaded_graph.h"
#include "core/mesh/mesh_io.h"
#include "core/mesh/surface_point.h"
#include "tests/server/server_test_support.h"

namespace geoprox::server::testing {
namespace {

constexpr int kQuads = 6;  ///< each grid of touching_grids_obj() is kQuads x kQuads unit squares
constexpr int kGridVertices = (kQuads + 1) * (kQuads + 1);
constexpr int kFileVertices = 2 * kGridVertices - 1;  ///< the grids share vertex 0
constexpr int kGridFaces = 2 * kQuads * kQuads;
/// The copy of vertex 0 that repair appends for the second grid's fan.
const std::string kCopyOfVertex0 = "v:" + std::to_string(kFileVertices);
/// The second grid's first face, (0, 0) (1, 0) (1, 1) of that grid: its corner 0 is the copy.
const std::string kCopyCorner = "f:" + std::to_string(kGridFaces) + ":1:0:0";
/// The far corners: (kQuads, kQuads) of the first grid, (-kQuads, -kQuads) of the second.
const std::string kFarCornerA = "v:" + std::to_string(kGridVertices - 1);
const std::string kFarCornerB = "v:" + std::to_string(kFileVertices - 1);

/// Two flat grids that touch at one corner: grid A has vertex (i, j) at (i, j, 0) with id
/// j (kQuads + 1) + i; grid B is A turned half round about the origin, (-i, -j, 0), sharing
/// vertex 0 and numbering the others after A's in the same order. Vertex 0 is where two fans
/// meet (non-manifold); B's last face is turned round, and A's first face is listed again at the
/// end. Repair splits vertex 0 (B's fan gets the copy), turns the face back and drops the copy.
std::string touching_grids_obj() {
  const int n = kQuads;
  std::ostringstream obj;
  for (int sign : {1, -1}) {
    for (int j = 0; j <= n; ++j) {
      for (int i = 0; i <= n; ++i) {
        if (sign < 0 && i == 0 && j == 0) continue;
        obj << "v " << sign * i << ' ' << sign * j << " 0\n";
      }
    }
  }
  // OBJ ids (1-based) of the corners of both grids.
  auto a = [n](int i, int j) { return j * (n + 1) + i + 1; };
  auto b = [n](int i, int j) { return i == 0 && j == 0 ? 1 : kGridVertices + j * (n + 1) + i; };
  // Two faces per cell; with `turn_last`, the grid's last face the wrong way round.
  auto write_faces = [&obj, n](const std::function<int(int, int)>& id, bool turn_last) {
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        obj << "f " << id(i, j) << ' ' << id(i + 1, j) << ' ' << id(i + 1, j + 1) << '\n';
        if (turn_last && i == n - 1 && j == n - 1) {
          obj << "f " << id(i, j) << ' ' << id(i, j + 1) << ' ' << id(i + 1, j + 1) << '\n';
        } else {
          obj << "f " << id(i, j) << ' ' << id(i + 1, j + 1) << ' ' << id(i, j + 1) << '\n';
        }
      }
    }
  };
  write_faces(a, false);
  write_faces(b, true);
  obj << "f " << a(0, 0) << ' ' << a(1, 0) << ' ' << a(1, 1) << '\n';
  return obj.str();
}

/// What mesh.info says repair changed in touching_grids_obj().
json expected_repair() {
  return {{"vertices_in", kFileVertices},
          {"faces_in", 2 * kGridFaces + 1},
          {"vertices_out", kFileVertices + 1},
          {"faces_out", 2 * kGridFaces},
          {"degenerate_faces_dropped", 0},
          {"duplicate_faces_dropped", 1},
          {"edges_cut", 0},
          {"faces_flipped", 1},
          {"vertices_split", 1},
          {"vertices_added", 1}};
}

/// A config serving the grids from `dir` (data/meshes/grids.obj), repaired or not, with a small
/// graph; `extra` entries are appended to its meshes.
Config grids_config(const TempDir& dir, bool repair, const json& extra = json::array()) {
  json grids = {{"id", "grids"},
                {"mesh", "meshes/grids.obj"},
                {"samples", 30},
                {"neighbors", 6},
                {"sampling", "fmm"}};
  if (repair) grids["repair"] = true;
  json meshes = json::array({grids});
  for (const json& m : extra) meshes.push_back(m);
  Config config =
      parse_config({{"data_dir", "data"}, {"graph_dir", "graphs"}, {"meshes", meshes}}, dir.path());
  config.port = 0;
  config.admin_port = 0;
  config.http_port = 0;
  config.compute_threads = 2;
  config.build_threads = 1;
  config.shutdown_timeout_ms = 5000;
  return config;
}

/// A started server, its meshes loaded, whose log lines are kept (RunningServer sets up the
/// process's logging on first use, which would replace a capture made before it).
class LoggedServer {
 public:
  explicit LoggedServer(Config config) : previous_(spdlog::default_logger()) {
    spdlog::set_default_logger(std::make_shared<spdlog::logger>("repair-test", sink_));
    server_ = std::make_unique<Server>(std::move(config));
    server_->start();
    EXPECT_TRUE(server_->registry().wait_idle(60s));
  }
  ~LoggedServer() {
    server_->shutdown();
    server_->wait();
    spdlog::set_default_logger(previous_);
  }
  std::uint16_t port() const { return server_->port(); }
  std::string log() const { return sink_->text(); }

 private:
  std::shared_ptr<CaptureSink> sink_ = std::make_shared<CaptureSink>();
  std::shared_ptr<spdlog::logger> previous_;
  std::unique_ptr<Server> server_;
};

json mesh_entry(Client& c, const std::string& id) {
  const json list = c.result("mesh.list");
  for (const json& m : list["meshes"]) {
    if (m["id"] == id) return m;
  }
  ADD_FAILURE() << "no mesh " << id << ": " << list.dump();
  return {};
}

json distance_params(const std::string& mesh, const std::string& source, const std::string& target,
                     bool exact = false) {
  json params = {{"mesh", mesh}, {"source", source}, {"target", target}};
  if (exact) params["exact"] = true;
  return params;
}

TEST(RepairOnLoad, ConfigKeyServesANonManifoldMeshWithTheIdsOfTheRepairedFile) {
  TempDir dir;
  write_text(dir.path() / "data/meshes/grids.obj", touching_grids_obj());
  const fs::path mesh_path = dir.path() / "data/meshes/grids.obj";
  const fs::path graph_path = dir.path() / "graphs/grids.geoprox";
  // The same file without repair, as a second mesh: it fails, and says how to serve it.
  const json as_is = {{"id", "as-is"}, {"mesh", "meshes/grids.obj"}, {"samples", 30}};
  std::string version;
  {
    LoggedServer server(grids_config(dir, true, json::array({as_is})));
    Client c(server.port());
    const json grids = mesh_entry(c, "grids");
    ASSERT_EQ(grids["state"], "ready") << grids;
    EXPECT_EQ(grids["vertices"], kFileVertices + 1);
    EXPECT_EQ(grids["faces"], 2 * kGridFaces);
    version = grids["mesh_version"];
    const json failed = mesh_entry(c, "as-is");
    EXPECT_EQ(failed["state"], "failed") << failed;
    const std::string error = failed["error"];
    EXPECT_EQ(error.rfind("grids.obj: ", 0), 0u) << error;
    EXPECT_NE(error.find("(\"repair\": true serves it repaired)"), std::string::npos) << error;

    const json info = c.result("mesh.info", {{"mesh", "grids"}});
    EXPECT_EQ(info["repair"], expected_repair()) << info;
    EXPECT_TRUE(info["polygons"].is_null()) << "every face record of the file is a triangle";
    EXPECT_NE(server.log().find("mesh grids: repaired grids.obj: 1 duplicate face dropped, 1 face "
                                "flipped, 1 vertex split (+1 copy)"),
              std::string::npos)
        << server.log();

    // The graph answers as in process on the repaired mesh, with the same graph file.
    const LoadedGraph reference(mesh_path.string(), graph_path.string(), "", {}, {.repair = true});
    QueryScratch scratch = reference.query->make_scratch();
    for (const auto& [s, t] : std::vector<std::pair<std::string, std::string>>{
             {"v:0", kFarCornerA}, {kCopyCorner, kFarCornerB}, {"f:3:0.2:0.3:0.5", "v:10"}}) {
      SCOPED_TRACE(s + " -> " + t);
      const double expected =
          reference.query->distance(parse_surface_point(s), parse_surface_point(t), scratch)
              .distance;
      EXPECT_EQ(c.result("geodesic.distance", distance_params("grids", s, t))["distance"],
                expected);
    }
    // Exact distances on the flat grids: straight lines, each grid on its own.
    const double diagonal = kQuads * std::sqrt(2.0);
    EXPECT_NEAR(c.result("geodesic.distance",
                         distance_params("grids", "v:0", kFarCornerA, true))["distance"]
                    .get<double>(),
                diagonal, 1e-12 * diagonal);
    EXPECT_NEAR(c.result("geodesic.distance",
                         distance_params("grids", kCopyCorner, kFarCornerB, true))["distance"]
                    .get<double>(),
                diagonal, 1e-12 * diagonal);
    // A point on a face at its split corner is the copy on that face, not vertex 0.
    EXPECT_EQ(c.result("geodesic.distance",
                       distance_params("grids", kCopyCorner, kCopyOfVertex0, true))["distance"],
              0.0);
    EXPECT_EQ(c.error_reason("geodesic.distance", distance_params("grids", kCopyCorner, "v:0")),
              "Unreachable");
    EXPECT_EQ(c.error_reason("geodesic.distance", distance_params("grids", "v:0", kFarCornerB)),
              "Unreachable");
  }
  // Repair switched off: the mesh fails to load with the same clear error, and its graph file
  // is left as it is.
  const std::string graph_bytes = read_bytes(graph_path);
  {
    RunningServer server(grids_config(dir, false));
    Client c(server.port());
    const json grids = mesh_entry(c, "grids");
    EXPECT_EQ(grids["state"], "failed") << grids;
    EXPECT_NE(grids["error"].get<std::string>().find("\"repair\": true"), std::string::npos);
    EXPECT_EQ(read_bytes(graph_path), graph_bytes);
  }
  // And on again: the graph built for the repaired mesh verifies against it and is mapped, not
  // rebuilt.
  {
    RunningServer server(grids_config(dir, true));
    Client c(server.port());
    const json grids = mesh_entry(c, "grids");
    EXPECT_EQ(grids["state"], "ready") << grids;
    EXPECT_EQ(grids["mesh_version"], version);
    EXPECT_EQ(read_bytes(graph_path), graph_bytes);
  }
}

TEST(RepairOnLoad, AMeshThatNeedsNoRepairIsServedAsItIsWithItsGraph) {
  TestData data;
  Config config = spot_config(data);
  config.meshes[0].build.repair = true;
  const std::string graph_bytes = read_bytes(data.graph_dir() / "spot.geoprox");
  LoggedServer server(config);
  Client c(server.port());
  const json info = c.result("mesh.info", {{"mesh", "spot"}});
  EXPECT_EQ(info["state"], "ready") << info;
  EXPECT_EQ(info["repair"]["vertices_out"], info["repair"]["vertices_in"]);
  EXPECT_EQ(info["repair"]["faces_out"], 5856);
  for (const char* count : {"degenerate_faces_dropped", "duplicate_faces_dropped", "edges_cut",
                            "faces_flipped", "vertices_split", "vertices_added"}) {
    EXPECT_EQ(info["repair"][count], 0) << count;
  }
  EXPECT_EQ(read_bytes(data.graph_dir() / "spot.geoprox"), graph_bytes) << "rebuilt";
  EXPECT_NE(server.log().find("mesh spot: repaired spot.obj: nothing changed"), std::string::npos)
      << server.log();
  // Without repair, mesh.info has no report.
  TestData plain_data;
  RunningServer plain(spot_config(plain_data));
  Client d(plain.port());
  EXPECT_TRUE(d.result("mesh.info", {{"mesh", "spot"}})["repair"].is_null());
}

TEST(RepairOnLoad, AdminRegisterWithRepairOverASocket) {
  TestData data;
  write_text(data.data_dir() / "meshes/grids.obj", touching_grids_obj());
  Config config = spot_config(data);
  config.admin_token = "s3cret";
  RunningServer server(config);
  Client c(server.port());
  const json small = {{"samples", 30}, {"neighbors", 6}};
  const json registered = c.result("admin.register", {{"token", "s3cret"},
                                                      {"mesh", "grids"},
                                                      {"mesh_file", "meshes/grids.obj"},
                                                      {"repair", true},
                                                      {"build", small}});
  EXPECT_EQ(registered["state"], "building");
  const json ready = wait_for_state(server.port(), "grids", "ready");
  EXPECT_EQ(ready["vertices"], kFileVertices + 1);
  EXPECT_EQ(c.result("mesh.info", {{"mesh", "grids"}})["repair"], expected_repair());
  EXPECT_EQ(c.result("geodesic.distance",
                     distance_params("grids", kCopyCorner, kCopyOfVertex0, true))["distance"],
            0.0);
  // A rebuild keeps the repair: the same mesh, another graph.
  c.result("admin.rebuild", {{"token", "s3cret"}, {"mesh", "grids"}, {"build", {{"samples", 40}}}});
  ASSERT_TRUE(server.server->registry().wait_idle(60s));
  const json rebuilt = c.result("mesh.info", {{"mesh", "grids"}});
  EXPECT_EQ(rebuilt["state"], "ready") << rebuilt;
  EXPECT_EQ(rebuilt["samples"], 40);
  EXPECT_EQ(rebuilt["repair"], expected_repair());

  // Without repair the same file fails to load, saying how to serve it.
  c.result("admin.register", {{"token", "s3cret"},
                              {"mesh", "grids-as-is"},
                              {"mesh_file", "meshes/grids.obj"},
                              {"build", small}});
  const json failed = wait_for_state(server.port(), "grids-as-is", "failed");
  EXPECT_NE(failed["error"].get<std::string>().find("(\"repair\": true serves it repaired)"),
            std::string::npos)
      << failed;
  EXPECT_EQ(c.error_reason("admin.register", {{"token", "s3cret"},
                                              {"mesh", "x"},
                                              {"mesh_file", "meshes/grids.obj"},
                                              {"repair", "yes"}}),
            "InvalidParams");
}

TEST(RepairOnLoad, ConfigRefusesARepairThatIsNotABoolean) {
  auto refused = [](const json& mesh) -> std::string {
    try {
      parse_config({{"meshes", json::array({mesh})}}, "/tmp");
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "accepted";
  };
  EXPECT_EQ(refused({{"id", "a"}, {"mesh", "a.obj"}, {"repair", "yes"}}),
            "config.meshes[0].repair: expected true or false");
  EXPECT_NE(refused({{"id", "a"}, {"mesh", "a.obj"}, {"repaired", true}})
                .find("unknown key \"repaired\" (known keys: id, mesh, graph, metric, repair,"),
            std::string::npos);
  const Config config = parse_config(
      {{"meshes",
        {{{"id", "a"}, {"mesh", "a.obj"}, {"repair", true}}, {{"id", "b"}, {"mesh", "b.obj"}}}}},
      "/tmp");
  EXPECT_TRUE(config.meshes[0].build.repair);
  EXPECT_FALSE(config.meshes[1].build.repair);
}

}  // namespace
}  // namespace geoprox::server::testing
