// Helpers of the server tests: a blocking line client over a real TCP socket, temporary
// directories, a spot.obj graph built once per test binary, in-process servers on ephemeral
// ports, and a log sink that keeps what it is given.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <spdlog/sinks/base_sink.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <thread>

#include "core/graph/graph_file.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh_io.h"
#include "core/graph/proximity_graph.h"
#include "protocol/json_rpc.h"
#include "server/config.h"
#include "server/logging.h"
#include "server/registry.h"
#include "server/server.h"

namespace geoprox::server::testing {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;

inline fs::path source_dir() { return fs::path(GEOPROX_SOURCE_DIR); }
inline fs::path spot_obj() { return source_dir() / "data/meshes/spot.obj"; }
inline fs::path dragon_off() { return source_dir() / "data/meshes/ChineseDragon-10kv.off"; }

/// The whole file as bytes (empty if it cannot be read).
inline std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = fs::temp_directory_path() / ("geoprox-server-test-" + std::to_string(getpid()) + "-" +
                                         std::to_string(rd()));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

/// Small graphs, fast to build: used for every spot graph of the tests.
inline BuildParams small_spot_params() { return BuildParams{400, 12, 0, SamplingMethod::FastMarching}; }

/// A graph of `mesh` with `params`, built once and cached in the build tree for every test
/// process (ctest runs each test in its own process); a cached file that does not open and
/// verify against the mesh is rebuilt. Writes are atomic, so concurrent tests are safe.
inline fs::path cached_graph(const fs::path& mesh_path, const BuildParams& params) {
  static std::mutex mutex;
  std::lock_guard lock(mutex);
  const fs::path cache = GEOPROX_TEST_CACHE_DIR;
  fs::create_directories(cache);
  const fs::path out = cache / (mesh_path.stem().string() + "-v" +
                                std::to_string(kGraphFileVersion) + "-" +
                                std::to_string(params.samples) + "-" +
                                std::to_string(params.neighbors) + ".geoprox");
  const TriangleMesh mesh = load_mesh(mesh_path.string());
  const IntrinsicGeometry geometry(mesh);
  try {
    MappedGraphFile::open(out.string()).verify_mesh(mesh, geometry);
    return out;
  } catch (const std::exception&) {
  }
  ProximityGraphOptions options;
  options.num_samples = params.samples;
  options.neighbors = params.neighbors;
  options.sampling = params.sampling;
  const ProximityGraph graph = build_proximity_graph(mesh, geometry, options);
  write_graph_file(out.string(), mesh, geometry, graph);
  return out;
}

/// A data directory with meshes/ (copies of the sample meshes) and graphs/ (prebuilt spot).
struct TestData {
  TempDir dir;
  fs::path data_dir() const { return dir.path() / "data"; }
  fs::path graph_dir() const { return dir.path() / "graphs"; }
  TestData() {
    fs::create_directories(data_dir() / "meshes");
    fs::create_directories(graph_dir());
    fs::copy_file(spot_obj(), data_dir() / "meshes/spot.obj");
    fs::copy_file(cached_graph(spot_obj(), small_spot_params()), graph_dir() / "spot.geoprox");
  }
};

/// A config serving spot from `data` on ephemeral ports.
/// Writes `text` to `path`, creating its directory.
inline void write_text(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
}

inline Config spot_config(const TestData& data) {
  Config config;
  config.port = 0;
  config.admin_port = 0;
  config.http_port = 0;
  config.compute_threads = 2;
  config.build_threads = 2;
  config.data_dir = data.data_dir();
  config.graph_dir = data.graph_dir();
  config.shutdown_timeout_ms = 5000;
  MeshConfig spot;
  spot.id = "spot";
  spot.mesh_path = data.data_dir() / "meshes/spot.obj";
  spot.graph_path = data.graph_dir() / "spot.geoprox";
  spot.build = small_spot_params();
  config.meshes.push_back(spot);
  return config;
}

/// A blocking client: one TCP connection, line in, line out.
class Client {
 public:
  explicit Client(std::uint16_t port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(port);
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      ::close(fd_);
      fd_ = -1;
      throw std::runtime_error("cannot connect to port " + std::to_string(port));
    }
    int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  }
  ~Client() { close(); }
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  void shutdown_write() { ::shutdown(fd_, SHUT_WR); }
  /// Closes with a reset (SO_LINGER 0) rather than a FIN, which the server takes for a
  /// half-close: the server sees the connection fail at once.
  void reset() {
    if (fd_ < 0) return;
    linger abort{1, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_LINGER, &abort, sizeof abort);
    close();
  }

  bool send_raw(std::string_view bytes) {
    while (!bytes.empty()) {
      const ssize_t n = ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (n <= 0) return false;
      bytes.remove_prefix(static_cast<std::size_t>(n));
    }
    return true;
  }
  bool send_line(const std::string& line) { return send_raw(line + "\n"); }
  void send(const json& id, const std::string& method, const json& params = json::object()) {
    json request = {{"jsonrpc", "2.0"}, {"id", id}, {"method", method}, {"params", params}};
    ASSERT_TRUE(send_line(request.dump()));
  }

  /// The next line (without "\n"), or nothing on timeout or EOF.
  std::optional<std::string> read_line(std::chrono::milliseconds timeout = 10s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      const auto nl = buffer_.find('\n');
      if (nl != std::string::npos) {
        std::string line = buffer_.substr(0, nl);
        buffer_.erase(0, nl + 1);
        return line;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return std::nullopt;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) return std::nullopt;
      char chunk[65536];
      const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
      if (n <= 0) {
        eof_ = true;
        return std::nullopt;
      }
      buffer_.append(chunk, static_cast<std::size_t>(n));
    }
  }
  bool eof() const { return eof_; }

  /// Exactly `n` bytes (fewer on timeout or EOF).
  std::string read_bytes(std::size_t n, std::chrono::milliseconds timeout = 10s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (buffer_.size() < n) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) break;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) break;
      char chunk[65536];
      const ssize_t got = ::recv(fd_, chunk, sizeof chunk, 0);
      if (got <= 0) {
        eof_ = true;
        break;
      }
      buffer_.append(chunk, static_cast<std::size_t>(got));
    }
    std::string out = buffer_.substr(0, std::min(n, buffer_.size()));
    buffer_.erase(0, out.size());
    return out;
  }

  /// True when the server closed the connection (EOF or reset) within `timeout`.
  bool closed_by_peer(std::chrono::milliseconds timeout = 5s) {
    while (read_line(timeout)) {
    }
    return eof_;
  }

  json read_json(std::chrono::milliseconds timeout = 10s) {
    auto line = read_line(timeout);
    if (!line) throw std::runtime_error("no reply");
    return json::parse(*line);
  }

  /// One request, its reply (the connection must have nothing else in flight).
  json call(const std::string& method, const json& params = json::object()) {
    const int id = next_id_++;
    send(id, method, params);
    json reply = read_json();
    EXPECT_EQ(reply.at("id"), id) << reply.dump();
    return reply;
  }
  json result(const std::string& method, const json& params = json::object()) {
    json reply = call(method, params);
    if (!reply.contains("result")) throw std::runtime_error("error reply: " + reply.dump());
    return reply.at("result");
  }
  /// The data.reason of the error reply (fails the test on a result).
  std::string error_reason(const std::string& method, const json& params = json::object()) {
    json reply = call(method, params);
    EXPECT_TRUE(reply.contains("error")) << reply.dump();
    if (!reply.contains("error")) return "";
    return reply["error"]["data"]["reason"].get<std::string>();
  }

 private:
  int fd_ = -1;
  std::string buffer_;
  bool eof_ = false;
  int next_id_ = 1000;
};

/// Waits until mesh `id` reaches `state` (via mesh.list), up to `timeout`.
inline json wait_for_state(std::uint16_t port, const std::string& id, const std::string& state,
                           std::chrono::milliseconds timeout = 60s) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  json last;
  while (std::chrono::steady_clock::now() < deadline) {
    Client c(port);
    const json list = c.result("mesh.list");
    for (const json& m : list["meshes"]) {
      if (m["id"] == id) {
        last = m;
        if (m["state"] == state) return m;
      }
    }
    std::this_thread::sleep_for(20ms);
  }
  ADD_FAILURE() << "mesh " << id << " did not reach state " << state << ": " << last.dump();
  return last;
}

/// An in-process server, started, with spot ready.
struct RunningServer {
  explicit RunningServer(Config config, bool wait_ready = true) {
    static std::once_flag logging;
    std::call_once(logging, [] {
      configure_logging(std::getenv("GEOPROX_LOG_LEVEL") ? std::getenv("GEOPROX_LOG_LEVEL")
                                                          : "warn",
                        false);
    });
    server = std::make_unique<Server>(std::move(config));
    server->start();
    if (wait_ready) {
      EXPECT_TRUE(server->registry().wait_idle(60s));
    }
  }
  ~RunningServer() {
    server->shutdown();
    server->wait();
  }
  std::uint16_t port() const { return server->port(); }
  std::unique_ptr<Server> server;
};

/// Every log line of the process, kept in memory (the default logger while a test runs).
class CaptureSink final : public spdlog::sinks::base_sink<std::mutex> {
 public:
  std::string text() {
    std::lock_guard lock(mutex_);
    return text_;
  }

 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override {
    spdlog::memory_buf_t formatted;
    formatter_->format(msg, formatted);
    text_.append(formatted.data(), formatted.size());
  }
  void flush_() override {}

 private:
  std::string text_;
};

/// The in-process reference: the same mesh and graph, queried directly.
struct Reference {
  Reference(const fs::path& mesh_path, const fs::path& graph_path)
      : mesh(load_mesh(mesh_path.string())),
        geometry(mesh),
        file(MappedGraphFile::open(graph_path.string())),
        query(mesh, geometry, file.view()),
        scratch(query.make_scratch()) {}
  TriangleMesh mesh;
  IntrinsicGeometry geometry;
  MappedGraphFile file;
  GeodesicQuery query;
  QueryScratch scratch;
};

}  // namespace geoprox::server::testing
