// The daemon's life: geoproxd as a subprocess (command-line errors and exit codes, JSON request
// log lines, SIGTERM drain, SIGHUP reload with a good and a corrupted graph, --check),
// background builds (a mesh that fails does not take the others down), admin methods (token,
// path confinement, register / rebuild / unregister / reload; a mesh whose long faces leave gaps
// between its samples, served with a warning) and the config file.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>
#include <vector>

#include "server/compute_pool.h"
#include "server/service.h"
#include "server/thread_slice.h"
#include "tests/core/test_meshes.h"
#include "tests/server/server_test_support.h"

namespace geoprox::server::testing {
namespace {

/// geoproxd started with `args`, stderr to a file; killed if still running at the end.
class Daemon {
 public:
  explicit Daemon(std::vector<std::string> args, const fs::path& log) {
    pid_ = fork();
    if (pid_ == 0) {
      FILE* f = std::freopen(log.c_str(), "w", stderr);
      (void)f;
      std::vector<char*> argv;
      std::string binary = GEOPROXD_BINARY;
      argv.push_back(binary.data());
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      execv(binary.c_str(), argv.data());
      _exit(127);
    }
  }
  ~Daemon() {
    if (pid_ > 0 && !exited_) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      waitpid(pid_, &status, 0);
    }
  }
  void signal(int sig) { ::kill(pid_, sig); }
  /// Exit code, or -1 on timeout / killed by a signal.
  int wait(std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      int status = 0;
      const pid_t r = waitpid(pid_, &status, WNOHANG);
      if (r == pid_) {
        exited_ = true;
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
      }
      std::this_thread::sleep_for(5ms);
    }
    return -1;
  }

 private:
  pid_t pid_ = -1;
  bool exited_ = false;
};

/// Waits for the port file and returns the query port.
std::uint16_t wait_for_port(const fs::path& port_file, const fs::path& log) {
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (std::chrono::steady_clock::now() < deadline) {
    if (fs::exists(port_file)) {
      return json::parse(read_bytes(port_file))["port"].get<std::uint16_t>();
    }
    std::this_thread::sleep_for(10ms);
  }
  ADD_FAILURE() << "geoproxd did not start:\n" << read_bytes(log);
  return 0;
}

/// A config file for the daemon serving spot from `data`.
fs::path write_config(const TestData& data, const json& extra = json::object()) {
  json config = {{"bind", "127.0.0.1"},
                 {"port", 0},
                 {"admin_port", 0},
                 {"http_port", 0},
                 {"compute_threads", 2},
                 {"data_dir", "data"},
                 {"graph_dir", "graphs"},
                 {"shutdown_timeout_ms", 5000},
                 {"meshes",
                  {{{"id", "spot"},
                    {"mesh", "meshes/spot.obj"},
                    {"samples", small_spot_params().samples},
                    {"neighbors", small_spot_params().neighbors},
                    {"sampling", "fmm"}}}}};
  config.update(extra);
  const fs::path path = data.dir.path() / "geoproxd.json";
  write_text(path, config.dump(2));
  return path;
}

json heavy_field_params() {
  json sources = json::array();
  for (int i = 0; i < 300; ++i) sources.push_back({{"face", i * 7}, {"bary", {0.2, 0.3, 0.5}}});
  return {{"mesh", "spot"}, {"sources", sources}};
}

TEST(Daemon, SigtermDrainsRequestsInFlightAndExitsZero) {
  TestData data;
  const fs::path config = write_config(data, {{"compute_threads", 1}});
  const fs::path port_file = data.dir.path() / "ports.json";
  const fs::path log = data.dir.path() / "daemon.log";
  Daemon daemon({"--config", config.string(), "--port-file", port_file.string()}, log);
  const std::uint16_t port = wait_for_port(port_file, log);
  ASSERT_NE(port, 0);
  wait_for_state(port, "spot", "ready");
  Client c(port);
  // Two heavy requests in flight, then SIGTERM: both are answered before the exit.
  c.send(1, "geodesic.field", heavy_field_params());
  c.send(2, "geodesic.field", heavy_field_params());
  std::this_thread::sleep_for(20ms);
  daemon.signal(SIGTERM);
  std::set<int> answered;
  for (int i = 0; i < 2; ++i) {
    const json reply = c.read_json(30s);
    EXPECT_TRUE(reply.contains("result")) << reply.dump();
    answered.insert(reply["id"].get<int>());
  }
  EXPECT_EQ(answered, (std::set<int>{1, 2}));
  EXPECT_EQ(daemon.wait(30s), 0) << read_bytes(log);
  EXPECT_THROW(Client{port}, std::runtime_error);  // no longer accepting
  const std::string text = read_bytes(log);
  EXPECT_NE(text.find("shutting down gracefully"), std::string::npos) << text;
  EXPECT_NE(text.find("geoproxd stopped"), std::string::npos) << text;
}

TEST(Daemon, DrainingServerRefusesNewWorkAsShuttingDown) {
  TestData data;
  Config config = spot_config(data);
  config.compute_threads = 1;
  RunningServer server(config);
  Client c(server.port());
  c.send(1, "geodesic.field", heavy_field_params());
  std::this_thread::sleep_for(20ms);
  server.server->shutdown();
  std::this_thread::sleep_for(20ms);
  c.send(2, "geodesic.distance", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:1"}});
  c.send(3, "server.health");
  std::map<int, json> replies;
  for (int i = 0; i < 3; ++i) {
    const json reply = c.read_json(30s);
    replies[reply["id"].get<int>()] = reply;
  }
  EXPECT_TRUE(replies[1].contains("result"));
  EXPECT_EQ(replies[2]["error"]["data"]["reason"], "ShuttingDown");
  EXPECT_EQ(replies[3]["result"]["status"], "draining");
  EXPECT_EQ(replies[3]["result"]["ready"], false);
}

TEST(Daemon, SighupReloadsAGoodGraphAndKeepsTheOldOneOnACorruptedOne) {
  TestData data;
  const fs::path config = write_config(data);
  const fs::path port_file = data.dir.path() / "ports.json";
  const fs::path log = data.dir.path() / "daemon.log";
  Daemon daemon({"--config", config.string(), "--port-file", port_file.string()}, log);
  const std::uint16_t port = wait_for_port(port_file, log);
  ASSERT_NE(port, 0);
  const json before = wait_for_state(port, "spot", "ready");
  const std::string v1 = before["mesh_version"];
  const fs::path graph = data.graph_dir() / "spot.geoprox";

  // A good new graph (other parameters), renamed into place: SIGHUP swaps it in.
  const fs::path other = cached_graph(spot_obj(), BuildParams{300, 10, 0, SamplingMethod::FastMarching});
  fs::copy_file(other, data.graph_dir() / "new.tmp");
  fs::rename(data.graph_dir() / "new.tmp", graph);
  daemon.signal(SIGHUP);
  std::string v2;
  for (int i = 0; i < 500 && (v2.empty() || v2 == v1); ++i) {
    std::this_thread::sleep_for(10ms);
    v2 = Client(port).result("mesh.list")["meshes"][0]["mesh_version"];
  }
  EXPECT_NE(v2, v1);
  Client c(port);
  EXPECT_EQ(c.result("geodesic.distance",
                     {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:1"}})["mesh_version"],
            v2);
  EXPECT_EQ(c.result("mesh.list")["meshes"][0]["samples"], 300);

  // A corrupted graph (one flipped byte): the reload fails, the old graph keeps serving.
  std::string bytes = read_bytes(graph);
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x5a);
  write_text(data.graph_dir() / "bad.tmp", bytes);
  fs::rename(data.graph_dir() / "bad.tmp", graph);
  daemon.signal(SIGHUP);
  bool failed_logged = false;
  for (int i = 0; i < 500 && !failed_logged; ++i) {
    std::this_thread::sleep_for(10ms);
    failed_logged = read_bytes(log).find("reload failed") != std::string::npos;
  }
  EXPECT_TRUE(failed_logged) << read_bytes(log);
  const json after = c.result("geodesic.distance", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:1"}});
  EXPECT_EQ(after["mesh_version"], v2);
  daemon.signal(SIGTERM);
  EXPECT_EQ(daemon.wait(30s), 0);
}

TEST(Daemon, ProbeReportsReadinessForContainerHealthChecks) {
  TestData data;
  // Admin port 0 turns it off, so take a free one from the kernel (released just before use).
  std::uint16_t admin_port = 0;
  {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in any{};
    any.sin_family = AF_INET;
    any.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t length = sizeof any;
    ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&any), sizeof any), 0);
    ASSERT_EQ(::getsockname(fd, reinterpret_cast<sockaddr*>(&any), &length), 0);
    admin_port = ntohs(any.sin_port);
    ::close(fd);
  }
  const fs::path config = write_config(data, {{"admin_port", admin_port}});
  const fs::path log = data.dir.path() / "daemon.log";
  const fs::path port_file = data.dir.path() / "ports.json";
  Daemon daemon({"--config", config.string(), "--port-file", port_file.string()}, log);
  wait_for_port(port_file, log);
  ASSERT_EQ(json::parse(read_bytes(port_file))["admin_port"].get<std::uint16_t>(), admin_port);
  const fs::path probe_log = data.dir.path() / "probe.log";
  int code = -1;
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  while (std::chrono::steady_clock::now() < deadline) {
    Daemon probe({"--probe", "--admin-port", std::to_string(admin_port)}, probe_log);
    code = probe.wait(10s);
    if (code == 0) break;
    EXPECT_EQ(code, 1) << read_bytes(probe_log);  // not ready yet (spot's graph is building)
    std::this_thread::sleep_for(50ms);
  }
  EXPECT_EQ(code, 0) << "never ready: " << read_bytes(log);
  daemon.signal(SIGTERM);
  EXPECT_EQ(daemon.wait(30s), 0);
  // Nothing listening any more: not ready.
  Daemon probe({"--probe", "--admin-port", std::to_string(admin_port)}, probe_log);
  EXPECT_EQ(probe.wait(10s), 1);
  EXPECT_NE(read_bytes(probe_log).find("not ready"), std::string::npos) << read_bytes(probe_log);
}

TEST(Daemon, CheckValidatesConfigMeshesAndGraphs) {
  TestData data;
  const fs::path log = data.dir.path() / "check.log";
  {
    const fs::path config = write_config(data);
    Daemon check({"--config", config.string(), "--check"}, log);
    EXPECT_EQ(check.wait(60s), 0) << read_bytes(log);
  }
  {
    // A corrupted graph file fails the check.
    write_text(data.graph_dir() / "spot.geoprox", "GEOPROXG not really a graph");
    const fs::path config = write_config(data);
    Daemon check({"--config", config.string(), "--check"}, log);
    EXPECT_EQ(check.wait(60s), 1);
    EXPECT_NE(read_bytes(log).find("graph spot"), std::string::npos) << read_bytes(log);
  }
  {
    // An unknown key is refused, naming it.
    const fs::path config = write_config(data, {{"prot", 1}});
    Daemon check({"--config", config.string(), "--check"}, log);
    EXPECT_EQ(check.wait(60s), 1);
    EXPECT_NE(read_bytes(log).find("unknown key \"prot\""), std::string::npos) << read_bytes(log);
  }
}

TEST(Daemon, CommandLineErrorsKeepTheirExitCodes) {
  TempDir dir;
  const fs::path log = dir.path() / "cli.log";
  struct Case {
    std::vector<std::string> args;
    int exit_code;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"--version"}, 0, ""},
      {{"--bogus"}, 2, "geoproxd: unknown argument \"--bogus\""},
      {{"stray"}, 2, "geoproxd: unknown argument \"stray\""},
      {{}, 2, "geoproxd: --config FILE is required"},
      {{"--port"}, 1, "geoproxd: config error: --port: needs a value"},
      {{"--probe", "--admin-port", "x"},
       1,
       "geoproxd: config error: --admin-port: \"x\" is not a port number (0 to 65535)"},
      {{"--config", (dir.path() / "missing.json").string()}, 1, "geoproxd: config error: "},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.args.empty() ? std::string("(no arguments)") : c.args.front());
    Daemon daemon(c.args, log);
    EXPECT_EQ(daemon.wait(30s), c.exit_code) << read_bytes(log);
    EXPECT_NE(read_bytes(log).find(c.message), std::string::npos) << read_bytes(log);
  }
}

TEST(Daemon, JsonLogLinesCarryTheRequestFields) {
  TestData data;
  const fs::path config = write_config(data, {{"log_json", true}, {"log_level", "debug"}});
  const fs::path port_file = data.dir.path() / "ports.json";
  const fs::path log = data.dir.path() / "daemon.log";
  Daemon daemon({"--config", config.string(), "--port-file", port_file.string()}, log);
  const std::uint16_t port = wait_for_port(port_file, log);
  ASSERT_NE(port, 0);
  wait_for_state(port, "spot", "ready");
  {
    Client c(port);
    c.send(7, "geodesic.distance",
           {{"mesh", "spot"}, {"source", {{"vertex", 0}}}, {"target", {{"vertex", 5}}}});
    EXPECT_TRUE(c.read_json().contains("result"));
    c.send("eight", "mesh.info", {{"mesh", "no-such-mesh"}});
    EXPECT_TRUE(c.read_json().contains("error"));
  }
  daemon.signal(SIGTERM);
  ASSERT_EQ(daemon.wait(30s), 0) << read_bytes(log);

  std::map<std::string, json> requests;  // by id, as text
  std::istringstream lines(read_bytes(log));
  std::string line;
  while (std::getline(lines, line)) {
    json entry;
    ASSERT_NO_THROW(entry = json::parse(line)) << line;
    for (const char* key : {"time", "level", "thread", "msg"}) {
      EXPECT_TRUE(entry.contains(key)) << key << " missing: " << line;
    }
    if (entry["msg"] == "request") requests[entry["id"].dump()] = entry;
  }
  ASSERT_EQ(requests.count("7"), 1u) << read_bytes(log);
  const json& ok = requests["7"];
  EXPECT_EQ(ok["level"], "debug");
  EXPECT_EQ(ok["method"], "geodesic.distance");
  EXPECT_EQ(ok["mesh"], "spot");
  EXPECT_EQ(ok["outcome"], "ok");
  EXPECT_TRUE(ok["duration_ms"].is_number()) << ok.dump();
  EXPECT_TRUE(ok["peer"].is_string()) << ok.dump();
  ASSERT_EQ(requests.count("\"eight\""), 1u) << read_bytes(log);
  const json& failed = requests["\"eight\""];
  EXPECT_EQ(failed["method"], "mesh.info");
  EXPECT_TRUE(failed["mesh"].is_null()) << failed.dump();
  EXPECT_EQ(failed["outcome"], "UnknownMesh");
}

TEST(Registry, AFailingMeshDoesNotTakeTheOthersDown) {
  TestData data;
  fs::copy_file(source_dir() / "tests/data/nonmanifold_edge.obj",
                data.data_dir() / "meshes/broken.obj");
  Config config = spot_config(data);
  MeshConfig broken;
  broken.id = "broken";
  broken.mesh_path = data.data_dir() / "meshes/broken.obj";
  broken.graph_path = data.graph_dir() / "broken.geoprox";
  config.meshes.push_back(broken);
  MeshConfig missing;
  missing.id = "missing";
  missing.mesh_path = data.data_dir() / "meshes/missing.obj";
  missing.graph_path = data.graph_dir() / "missing.geoprox";
  config.meshes.push_back(missing);
  RunningServer server(config);
  Client c(server.port());
  const json list = c.result("mesh.list");
  ASSERT_EQ(list["meshes"].size(), 3u);
  EXPECT_EQ(list["meshes"][0]["state"], "ready");
  EXPECT_EQ(list["meshes"][1]["state"], "failed");
  EXPECT_NE(list["meshes"][1]["error"].get<std::string>().find("NonManifold"), std::string::npos)
      << list.dump();
  EXPECT_EQ(list["meshes"][2]["state"], "failed");
  EXPECT_NE(list["meshes"][2]["error"].get<std::string>().find("FileNotFound"), std::string::npos);
  EXPECT_EQ(c.error_reason("geodesic.distance",
                           {{"mesh", "broken"}, {"source", "v:0"}, {"target", "v:1"}}),
            "MeshBuildFailed");
  EXPECT_TRUE(c.result("geodesic.distance", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:1"}})
                  .contains("distance"));
  const json health = c.result("server.health");
  EXPECT_EQ(health["status"], "ok");
  EXPECT_EQ(health["meshes_ready"], 1);
  EXPECT_EQ(health["meshes_total"], 3);
}

TEST(Registry, MissingGraphIsBuiltInTheBackgroundWithProgress) {
  TestData data;
  fs::remove(data.graph_dir() / "spot.geoprox");
  Config config = spot_config(data);
  config.build_threads = 1;
  RunningServer server(config, /*wait_ready=*/false);
  Client c(server.port());
  const json first = c.result("mesh.list")["meshes"][0];
  if (first["state"] == "building") {
    EXPECT_TRUE(first["mesh_version"].is_null());
    EXPECT_EQ(c.error_reason("geodesic.distance", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:1"}}),
              "MeshNotReady");
    EXPECT_EQ(c.result("server.health")["status"], "starting");
  }
  const json ready = wait_for_state(server.port(), "spot", "ready");
  EXPECT_TRUE(fs::exists(data.graph_dir() / "spot.geoprox"));
  EXPECT_EQ(ready["samples"], small_spot_params().samples);
}

class AdminTest : public ::testing::Test {
 protected:
  void SetUp() override {
    Config config = spot_config(data_);
    config.admin_token = "s3cret";
    server_ = std::make_unique<RunningServer>(config);
  }
  TestData data_;
  std::unique_ptr<RunningServer> server_;
};

TEST_F(AdminTest, AdminMethodsNeedTheToken) {
  Client c(server_->port());
  EXPECT_EQ(c.error_reason("admin.reload", {{"token", "wrong"}}), "Unauthorized");
  EXPECT_EQ(c.error_reason("admin.reload", {{"token", ""}}), "Unauthorized");
  EXPECT_EQ(c.error_reason("admin.unregister", {{"mesh", "spot"}, {"token", "s3cre"}}),
            "Unauthorized");
  EXPECT_EQ(c.result("mesh.list")["meshes"].size(), 1u);
  // Without a configured token, admin methods are off whatever is sent.
  TestData other;
  RunningServer off(spot_config(other));
  Client d(off.port());
  EXPECT_EQ(d.error_reason("admin.reload", {{"token", "s3cret"}}), "Unauthorized");
  EXPECT_EQ(d.result("server.info")["admin_enabled"], false);
}

TEST_F(AdminTest, PathsAreConfinedToTheDataDirectory) {
  Client c(server_->port());
  auto reg = [&](const std::string& path) {
    return c.error_reason("admin.register",
                          {{"token", "s3cret"}, {"mesh", "x"}, {"mesh_file", path}});
  };
  EXPECT_EQ(reg("../meshes/spot.obj"), "PathNotAllowed");
  EXPECT_EQ(reg("meshes/../../graphs/spot.geoprox"), "PathNotAllowed");
  EXPECT_EQ(reg("/etc/passwd"), "PathNotAllowed");
  EXPECT_EQ(reg(spot_obj().string()), "PathNotAllowed");  // absolute, outside
  fs::create_symlink(spot_obj(), data_.data_dir() / "meshes/link.obj");
  EXPECT_EQ(reg("meshes/link.obj"), "PathNotAllowed");  // a symlink resolving outside
  fs::create_directory_symlink(fs::path("/etc"), data_.data_dir() / "etc");
  EXPECT_EQ(reg("etc/passwd"), "PathNotAllowed");
  EXPECT_EQ(reg("meshes/none.obj"), "NotFound");
  EXPECT_EQ(reg("meshes"), "BadMeshFile");  // a directory
  EXPECT_EQ(c.error_reason("admin.register", {{"token", "s3cret"},
                                               {"mesh", "x"},
                                               {"mesh_file", "meshes/spot.obj"},
                                               {"graph_file", "/tmp/x.geoprox"}}),
            "PathNotAllowed");
  EXPECT_EQ(c.error_reason("admin.register",
                           {{"token", "s3cret"}, {"mesh", "spot"}, {"mesh_file", "meshes/spot.obj"}}),
            "MeshExists");
  // An absolute path inside the data directory is fine.
  const json ok = c.result("admin.register",
                           {{"token", "s3cret"},
                            {"mesh", "abs"},
                            {"mesh_file", (data_.data_dir() / "meshes/spot.obj").string()},
                            {"build", {{"samples", 200}, {"neighbors", 8}}}});
  EXPECT_EQ(ok["mesh"], "abs");
}

TEST_F(AdminTest, RegisterRebuildReloadUnregister) {
  Client c(server_->port());
  const json registered = c.result("admin.register",
                                   {{"token", "s3cret"},
                                    {"mesh", "spot2"},
                                    {"mesh_file", "meshes/spot.obj"},
                                    {"graph_file", "spot2.geoprox"},
                                    {"build", {{"samples", 200}, {"neighbors", 8}, {"sampling", "fmm"}}}});
  EXPECT_EQ(registered["mesh"], "spot2");
  EXPECT_EQ(registered["state"], "building");
  const json ready = wait_for_state(server_->port(), "spot2", "ready");
  EXPECT_EQ(ready["samples"], 200);
  EXPECT_TRUE(fs::exists(data_.data_dir() / "spot2.geoprox"));
  const std::string v1 = ready["mesh_version"];
  const json info = c.result("mesh.info", {{"mesh", "spot2"}});
  EXPECT_EQ(info["graph_file"], "spot2.geoprox");

  // Rebuild with other parameters: the old graph serves until the new one is swapped in.
  const json rebuilding = c.result("admin.rebuild", {{"token", "s3cret"}, {"mesh", "spot2"},
                                                     {"build", {{"samples", 250}}}});
  EXPECT_EQ(rebuilding["mesh_version"], v1);
  EXPECT_TRUE(c.result("geodesic.distance", {{"mesh", "spot2"}, {"source", "v:0"}, {"target", "v:1"}})
                  .contains("distance"));
  ASSERT_TRUE(server_->server->registry().wait_idle(60s));
  const json rebuilt = wait_for_state(server_->port(), "spot2", "ready");
  EXPECT_EQ(rebuilt["samples"], 250);
  EXPECT_NE(rebuilt["mesh_version"], v1);

  // admin.reload: unchanged files are not swapped; a corrupted one is refused with an error.
  const json unchanged = c.result("admin.reload", {{"token", "s3cret"}});
  ASSERT_EQ(unchanged["meshes"].size(), 2u);
  EXPECT_EQ(unchanged["meshes"][0]["reloaded"], false);
  EXPECT_TRUE(unchanged["meshes"][0]["error"].is_null());
  write_text(data_.data_dir() / "bad.tmp", "GEOPROXG garbage");
  fs::rename(data_.data_dir() / "bad.tmp", data_.data_dir() / "spot2.geoprox");
  const json refused = c.result("admin.reload", {{"token", "s3cret"}, {"mesh", "spot2"}});
  ASSERT_EQ(refused["meshes"].size(), 1u);
  EXPECT_EQ(refused["meshes"][0]["reloaded"], false);
  EXPECT_EQ(refused["meshes"][0]["error"]["data"]["reason"], "BadMeshFile");
  EXPECT_EQ(refused["meshes"][0]["mesh_version"], rebuilt["mesh_version"]);
  EXPECT_TRUE(c.result("geodesic.distance", {{"mesh", "spot2"}, {"source", "v:0"}, {"target", "v:1"}})
                  .contains("distance"));

  const json gone = c.result("admin.unregister", {{"token", "s3cret"}, {"mesh", "spot2"}});
  EXPECT_EQ(gone, json({{"mesh", "spot2"}, {"unregistered", true}}));
  EXPECT_EQ(c.error_reason("geodesic.distance", {{"mesh", "spot2"}, {"source", "v:0"}, {"target", "v:1"}}),
            "UnknownMesh");
  EXPECT_EQ(c.error_reason("admin.unregister", {{"token", "s3cret"}, {"mesh", "spot2"}}),
            "UnknownMesh");
}

/// The long-faced strip of tests/core/test_meshes.h (a 10 x 10 grid on [0, 1]^2, then eleven
/// long faces out to x = 10 with no vertex inside) as an OBJ.
std::string long_faced_strip_obj() {
  const test_meshes::MeshData strip = test_meshes::long_faced_strip();
  std::ostringstream obj;
  obj.precision(17);
  for (const Vec3& p : strip.positions) obj << "v " << p.x << ' ' << p.y << ' ' << p.z << '\n';
  for (const Triangle& t : strip.faces) {
    obj << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
  }
  return obj.str();
}

TEST_F(AdminTest, AMeshWithGapsBetweenItsSamplesIsServedOnARefinement) {
  // Every vertex of the strip is a sample, yet the middles of its long faces are 4.51 from all
  // of them, beyond the link radius: the build refines the strip internally, says so in the
  // log, and serves it in its own ids, with r under rho and no warning.
  write_text(data_.data_dir() / "meshes/strip.obj", long_faced_strip_obj());
  auto sink = std::make_shared<CaptureSink>();
  const auto previous = spdlog::default_logger();
  spdlog::set_default_logger(std::make_shared<spdlog::logger>("gaps-test", sink));
  struct Restore {
    std::shared_ptr<spdlog::logger> logger;
    ~Restore() { spdlog::set_default_logger(logger); }
  } restore{previous};
  Client c(server_->port());
  c.result("admin.register",
           {{"token", "s3cret"}, {"mesh", "strip"}, {"mesh_file", "meshes/strip.obj"}});
  wait_for_state(server_->port(), "strip", "ready");
  ASSERT_TRUE(server_->server->registry().wait_idle(60s));
  const std::string log = sink->text();
  EXPECT_NE(log.find("mesh strip: the first pass left points 4.51"), std::string::npos) << log;
  EXPECT_NE(log.find("(11 faces, 90% of the area, beyond it); built on a refinement to "),
            std::string::npos)
      << log;
  EXPECT_EQ(log.find("far off"), std::string::npos) << log;
  const json info = c.result("mesh.info", {{"mesh", "strip"}});
  EXPECT_EQ(info["vertices"], 123) << info;
  EXPECT_EQ(info["faces"], 211) << info;
  EXPECT_LT(info["covering_radius"].get<double>(), info["link_radius"].get<double>()) << info;
  ASSERT_TRUE(info["refined"].is_object()) << info;
  EXPECT_GT(info["refined"]["faces"].get<std::uint64_t>(), 211u) << info;
  EXPECT_GT(info["refined"]["max_edge_length"].get<double>(), 0) << info;
  // Across the long faces, from the grid's corner (0, 0) to (10, 1): never below the straight
  // line on this flat strip, and close to it.
  const json answer = c.result("geodesic.distance",
                               {{"mesh", "strip"}, {"source", "v:0"}, {"target", "v:122"}});
  EXPECT_GE(answer["distance"].get<double>(), std::hypot(10.0, 1.0) * (1 - 1e-12)) << answer;
  EXPECT_LE(answer["distance"].get<double>(), std::hypot(10.0, 1.0) * 1.02) << answer;
  // A field has one value per vertex of the strip.
  const json field =
      c.result("geodesic.field", {{"mesh", "strip"}, {"source", "f:210:0.2:0.3:0.5"}});
  ASSERT_TRUE(field.contains("distances")) << field;
  EXPECT_EQ(field["distances"].size(), 123u) << field;
}

TEST(Config, ParsesEveryKeyAndRefusesUnknownOnes) {
  const json document = json::parse(read_bytes(source_dir() / "configs/default.json"));
  const Config config = parse_config(document, source_dir() / "configs");
  EXPECT_EQ(config.port, 7878);
  EXPECT_EQ(config.admin_port, 7879);
  EXPECT_EQ(config.bind, "127.0.0.1");
  EXPECT_EQ(config.data_dir, source_dir() / "data");
  ASSERT_EQ(config.meshes.size(), 2u);
  EXPECT_EQ(config.meshes[0].id, "spot");
  EXPECT_EQ(config.meshes[0].mesh_path, source_dir() / "data/meshes/spot.obj");
  EXPECT_EQ(config.meshes[1].id, "dragon");
  EXPECT_EQ(config.meshes[1].graph_path, source_dir() / "var/graphs/dragon.geoprox");
  EXPECT_TRUE(config.split_near_pairs);
  EXPECT_FALSE(parse_config(json{{"split_near_pairs", false}}, "/tmp").split_near_pairs);
  EXPECT_EQ(config.io_slice_us, 100u);
  EXPECT_EQ(parse_config(json{{"io_slice_us", 0}}, "/tmp").io_slice_us, 0u);

  auto refused = [&](const json& d) -> std::string {
    try {
      parse_config(d, "/tmp");
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "accepted";
  };
  EXPECT_NE(refused({{"limits", {{"max_queue", 1}, {"max_qeue", 2}}}}).find("\"max_qeue\""),
            std::string::npos);
  EXPECT_NE(refused({{"meshes", {{{"id", "a"}, {"mesh", "a.obj"}, {"sample", 3}}}}}).find("\"sample\""),
            std::string::npos);
  EXPECT_NE(refused({{"port", "7878"}}).find("port"), std::string::npos);
  EXPECT_NE(refused({{"port", 70000}}).find("port"), std::string::npos);
  EXPECT_NE(refused({{"log_level", "loud"}}).find("log_level"), std::string::npos);
  EXPECT_NE(refused({{"split_near_pairs", 1}}).find("split_near_pairs"), std::string::npos);
  EXPECT_NE(refused({{"io_slice_us", 50}}).find("io_slice_us"), std::string::npos);
  EXPECT_NE(refused({{"io_slice_us", 200000}}).find("io_slice_us"), std::string::npos);
  EXPECT_NE(refused({{"meshes", {{{"id", "../x"}, {"mesh", "a.obj"}}}}}).find("id"),
            std::string::npos);
  EXPECT_NE(refused({{"meshes", {{{"id", "a"}, {"mesh", "a.obj"}}, {{"id", "a"}, {"mesh", "b.obj"}}}}})
                .find("twice"),
            std::string::npos);
  EXPECT_NE(refused({{"limits", {{"default_timeout_ms", 5000}, {"max_timeout_ms", 100}}}})
                .find("default_timeout_ms"),
            std::string::npos);
  EXPECT_NE(refused({{"meshes", {{{"id", "a"}, {"mesh", "a.obj"}, {"sampling", "best"}}}}})
                .find("sampling"),
            std::string::npos);
}

// The time slice of a thread as the kernel reports it (ns; /proc/self/task/TID/sched, EEVDF
// kernels), or -1 when it reports none.
long long reported_slice_ns(const fs::path& task) {
  std::ifstream in(task / "sched");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("se.slice", 0) == 0) return std::stoll(line.substr(line.find(':') + 1));
  }
  return -1;
}

// The task directories of this process's threads named `name`.
std::vector<fs::path> threads_named(const std::string& name) {
  std::vector<fs::path> found;
  for (const auto& task : fs::directory_iterator("/proc/self/task")) {
    std::ifstream comm(task.path() / "comm");
    std::string text;
    if (std::getline(comm, text) && text == name) found.push_back(task.path());
  }
  return found;
}

TEST(Threads, IoThreadsAskForTheConfiguredTimeSlice) {
  if (reported_slice_ns("/proc/thread-self") < 0) {
    GTEST_SKIP() << "this kernel reports no time slice (/proc/*/sched has no se.slice)";
  }
  // Kernels before 6.12 report a slice but ignore the one asked for: try it on a thread first.
  long long probe = -1;
  std::thread([&] {
    name_this_thread("gp-slice-probe");
    if (!request_thread_slice(std::chrono::microseconds(300))) {
      probe = reported_slice_ns("/proc/thread-self");
    }
  }).join();
  if (probe != 300'000) GTEST_SKIP() << "this kernel ignores custom time slices (Linux 6.12+)";

  TestData data;
  Config config = spot_config(data);
  config.io_threads = 2;
  config.io_slice_us = 250;
  RunningServer server(config);
  const auto io = threads_named("gp-io-0"), io1 = threads_named("gp-io-1"),
             compute = threads_named("gp-compute-0");
  ASSERT_EQ(io.size(), 1u);
  ASSERT_EQ(io1.size(), 1u);
  ASSERT_EQ(compute.size(), 1u);
  EXPECT_EQ(reported_slice_ns(io[0]), 250'000);
  EXPECT_EQ(reported_slice_ns(io1[0]), 250'000);
  // The compute threads keep the kernel's default, the main thread's.
  EXPECT_EQ(reported_slice_ns(compute[0]), reported_slice_ns("/proc/thread-self"));
  EXPECT_NE(reported_slice_ns(compute[0]), 250'000);
  // Queries are answered as ever.
  Client c(server.port());
  EXPECT_GT(c.result("geodesic.distance", {{"mesh", "spot"}, {"source", {{"vertex", 0}}},
                                           {"target", {{"vertex", 100}}}})["distance"]
                .get<double>(),
            0);
}

TEST(Config, EnvironmentOverridesLogLevelAndAdminToken) {
  Config config;
  setenv("GEOPROX_LOG_LEVEL", "debug", 1);
  setenv("GEOPROX_ADMIN_TOKEN", "from-env", 1);
  apply_environment(config);
  unsetenv("GEOPROX_LOG_LEVEL");
  unsetenv("GEOPROX_ADMIN_TOKEN");
  EXPECT_EQ(config.log_level, "debug");
  EXPECT_EQ(config.admin_token, "from-env");
}

}  // namespace
}  // namespace geoprox::server::testing
