// Polygon meshes in the daemon: a quad mesh from the config and from admin.register (with repair
// too) is served as its triangles, mesh.info counts its polygons, and path points name the
// polygon of their triangle.
#include <cmath>
#include <sstream>

#include "tests/server/server_test_support.h"

namespace geoprox::server::testing {
namespace {

constexpr int kCells = 6;  ///< the grid is kCells x kCells unit squares

/// A flat grid of unit quads: vertex (i, j) at (i, j, 0), id j (kCells + 1) + i; quad (i, j)
/// is face record j kCells + i, so its triangles are faces 2 (j kCells + i) and the next.
/// With `pinched`, a second grid turned half round shares vertex 0 (a non-manifold vertex).
std::string quad_grid_obj(bool pinched) {
  const int n = kCells;
  std::ostringstream obj;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) obj << "v " << i << ' ' << j << " 0\n";
  }
  auto a = [n](int i, int j) { return j * (n + 1) + i + 1; };
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      obj << "f " << a(i, j) << ' ' << a(i + 1, j) << ' ' << a(i + 1, j + 1) << ' ' << a(i, j + 1)
          << '\n';
    }
  }
  if (pinched) {
    const int first = (n + 1) * (n + 1);
    for (int j = 0; j <= n; ++j) {
      for (int i = 0; i <= n; ++i) {
        if (i != 0 || j != 0) obj << "v " << -i << ' ' << -j << " 0\n";
      }
    }
    auto b = [first, n](int i, int j) { return i == 0 && j == 0 ? 1 : first + j * (n + 1) + i; };
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        obj << "f " << b(i, j) << ' ' << b(i + 1, j) << ' ' << b(i + 1, j + 1) << ' '
            << b(i, j + 1) << '\n';
      }
    }
  }
  return obj.str();
}

/// Checks a geodesic.path answer on the grid: every point names its triangle's quad.
void expect_polygons_named(const json& path) {
  ASSERT_TRUE(path.contains("points")) << path;
  for (const json& point : path["points"]) {
    ASSERT_TRUE(point.contains("polygon")) << point;
    EXPECT_EQ(point["polygon"].get<std::uint32_t>(), point["face"].get<std::uint32_t>() / 2)
        << point;
  }
}

TEST(PolygonMeshes, QuadsServedFromTheConfigAndFromAdminRegister) {
  TestData data;
  write_text(data.data_dir() / "meshes/quads.obj", quad_grid_obj(false));
  write_text(data.data_dir() / "meshes/pinched.obj", quad_grid_obj(true));
  Config config = spot_config(data);
  config.admin_token = "s3cret";
  config.meshes.push_back(config.meshes.front());
  config.meshes.back().id = "quads";
  config.meshes.back().mesh_path = data.data_dir() / "meshes/quads.obj";
  config.meshes.back().graph_path = data.graph_dir() / "quads.geoprox";
  config.meshes.back().build.samples = 20;
  config.meshes.back().build.neighbors = 6;
  RunningServer server(config);
  Client c(server.port());
  wait_for_state(server.port(), "quads", "ready");

  const json info = c.result("mesh.info", {{"mesh", "quads"}});
  EXPECT_EQ(info["faces"], 2 * kCells * kCells) << info;
  EXPECT_EQ(info["polygons"], kCells * kCells) << info;
  // Corner to corner across the flat grid: the straight line, never below it.
  const std::string far_corner = "v:" + std::to_string((kCells + 1) * (kCells + 1) - 1);
  const double diagonal = std::sqrt(2.0) * kCells;
  const json d = c.result("geodesic.distance",
                          {{"mesh", "quads"}, {"source", "v:0"}, {"target", far_corner}});
  EXPECT_GE(d["distance"].get<double>(), diagonal * (1 - 1e-12)) << d;
  EXPECT_LE(d["distance"].get<double>(), diagonal * 1.02) << d;
  expect_polygons_named(c.result(
      "geodesic.path", {{"mesh", "quads"}, {"source", "f:3:0.2:0.3:0.5"}, {"target", far_corner}}));
  // A triangle mesh's path points carry no polygon.
  const json spot_path =
      c.result("geodesic.path", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:5"}});
  EXPECT_FALSE(spot_path["points"][0].contains("polygon")) << spot_path;

  // admin.register: a pinched pair of quad grids loads only with repair, which splits the
  // shared vertex; the polygons keep their ids.
  const json small = {{"samples", 40}, {"neighbors", 6}};
  c.result("admin.register", {{"token", "s3cret"},
                              {"mesh", "pinched"},
                              {"mesh_file", "meshes/pinched.obj"},
                              {"repair", true},
                              {"build", small}});
  wait_for_state(server.port(), "pinched", "ready");
  const json pinched = c.result("mesh.info", {{"mesh", "pinched"}});
  EXPECT_EQ(pinched["faces"], 4 * kCells * kCells) << pinched;
  EXPECT_EQ(pinched["polygons"], 2 * kCells * kCells) << pinched;
  EXPECT_EQ(pinched["repair"]["vertices_split"], 1) << pinched;
  expect_polygons_named(c.result(
      "geodesic.path", {{"mesh", "pinched"}, {"source", "v:0"}, {"target", far_corner}}));
}

}  // namespace
}  // namespace geoprox::server::testing
