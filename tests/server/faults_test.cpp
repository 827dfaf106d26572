// Faults (issue 8, section 3): damaged graph files swapped in on disk and reloaded (refused,
// the old graph keeps answering the same results), a client trickling one byte at a time (read
// timeout), blank-line keep-alives (not a timeout), and running out of file descriptors
// (accepting recovers). The client that never reads its replies is in transport_test.cpp
// (ClientThatNeverReadsIsDisconnected).
#include <fcntl.h>
#include <sys/resource.h>

#include <cerrno>
#include <sstream>
#include <string>
#include <vector>

#include "server/metrics.h"
#include "tests/server/server_test_support.h"

namespace geoprox::server::testing {
namespace {

/// Replaces `path` the way graph files are replaced: a complete file renamed over it.
void replace_file(const fs::path& path, const std::string& bytes) {
  const fs::path tmp = path.string() + ".tmp";
  std::ofstream(tmp, std::ios::binary | std::ios::trunc) << bytes;
  fs::rename(tmp, path);
}

/// Answers that depend on every part of the graph: the field from one vertex (samples, edges,
/// cover table) and a distance between faces.
json answers(Client& c) {
  return {c.result("geodesic.field", {{"mesh", "spot"}, {"source", "v:0"}})["distances"],
          c.result("geodesic.distance", {{"mesh", "spot"},
                                         {"source", {{"face", 10}, {"bary", {0.2, 0.3, 0.5}}}},
                                         {"target", {{"face", 5000}, {"bary", {0.6, 0.2, 0.2}}}}})};
}

class GraphFileFaults : public ::testing::Test {
 protected:
  TestData data_;
  RunningServer server_{spot_config(data_)};
  fs::path graph_ = data_.graph_dir() / "spot.geoprox";
  std::string good_ = read_bytes(graph_);

  std::string version() {
    return Client(server_.port()).result("mesh.list")["meshes"][0]["mesh_version"];
  }
  /// Reloads spot (what SIGHUP does for every mesh) and returns the error of the refusal.
  std::string refused_reload() {
    const std::vector<protocol::ReloadOutcome> outcomes =
        server_.server->registry().reload(std::string("spot"));
    EXPECT_EQ(outcomes.size(), 1u);
    if (outcomes.size() != 1) return "";
    EXPECT_FALSE(outcomes[0].reloaded);
    EXPECT_TRUE(outcomes[0].error.has_value());
    return outcomes[0].error ? outcomes[0].error->what() : "reloaded";
  }
};

TEST_F(GraphFileFaults, TruncatedGraphIsRefusedAndTheOldOneKeepsServing) {
  Client c(server_.port());
  const std::string v1 = version();
  const json before = answers(c);
  // Cut inside the header, inside the section table, inside the arrays, and just the checksum.
  for (const std::size_t size : {std::size_t{100}, std::size_t{400}, good_.size() / 2,
                                 good_.size() - 8}) {
    SCOPED_TRACE("truncated to " + std::to_string(size) + " of " + std::to_string(good_.size()));
    replace_file(graph_, good_.substr(0, size));
    EXPECT_NE(refused_reload().find("truncated"), std::string::npos);
    EXPECT_EQ(version(), v1);
    EXPECT_EQ(answers(c), before);
  }
}

TEST_F(GraphFileFaults, FlippedBytesAreRefusedAndTheOldOneKeepsServing) {
  Client c(server_.port());
  const std::string v1 = version();
  const json before = answers(c);
  // One flipped byte in: the magic, the version, a count, the section table, the faces, the
  // middle of the arrays, the last array byte, the checksum.
  struct Flip {
    std::size_t offset;
    const char* reason;  // in the refusal's message
  };
  const Flip flips[] = {{0, "no GEOPROXG magic"},        {8, "format version"},
                        {64, "header counts imply"},           {384 + 8, "section"},
                        {good_.size() / 3, "checksum"},  {good_.size() / 2, "checksum"},
                        {good_.size() - 9, "checksum"},  {good_.size() - 1, "checksum"}};
  for (const Flip& flip : flips) {
    SCOPED_TRACE("byte " + std::to_string(flip.offset) + " of " + std::to_string(good_.size()));
    std::string bad = good_;
    bad[flip.offset] = static_cast<char>(bad[flip.offset] ^ 0x5a);
    replace_file(graph_, bad);
    const std::string error = refused_reload();
    EXPECT_NE(error.find(flip.reason), std::string::npos) << error;
    EXPECT_EQ(version(), v1);
    EXPECT_EQ(answers(c), before);
  }
  // The intact file again: nothing to swap (same checksum), and still the same answers.
  replace_file(graph_, good_);
  const std::vector<protocol::ReloadOutcome> outcomes =
      server_.server->registry().reload(std::string("spot"));
  ASSERT_EQ(outcomes.size(), 1u);
  EXPECT_FALSE(outcomes[0].error.has_value());
  EXPECT_EQ(version(), v1);
  EXPECT_EQ(answers(c), before);
}

Config with_read_timeout(const TestData& data, std::int64_t milliseconds) {
  Config config = spot_config(data);
  config.server_limits.read_timeout_ms = milliseconds;
  return config;
}

TEST(SlowClientFaults, OneByteAtATimeIsCutByTheReadTimeout) {
  TestData data;
  RunningServer server(with_read_timeout(data, 300));
  Client c(server.port());
  // A valid request, one byte every 50 ms: its 49 bytes would take 2.5 s, eight read timeouts.
  const std::string request = R"({"jsonrpc":"2.0","id":1,"method":"server.health"})";
  std::size_t sent = 0;
  bool closed = false;
  while (sent < request.size() && !closed) {
    if (!c.send_raw(request.substr(sent, 1))) break;
    ++sent;
    std::this_thread::sleep_for(50ms);
    closed = server.server->metrics().read_timeouts.load() > 0;
  }
  EXPECT_TRUE(closed) << "the server still waited after " << sent << " bytes";
  EXPECT_LT(sent, request.size());
  EXPECT_TRUE(c.closed_by_peer(2s));  // and nothing was answered
  EXPECT_EQ(server.server->metrics().read_timeouts.load(), 1u);
  Client d(server.port());
  EXPECT_EQ(d.result("server.health")["status"], "ok");
}

TEST(SlowClientFaults, BlankLinesKeepAConnectionAliveAndLinesInPiecesArrive) {
  TestData data;
  RunningServer server(with_read_timeout(data, 1000));
  Client c(server.port());
  // Keep-alives for three read timeouts, then a request split in two pieces within one.
  for (int i = 0; i < 30; ++i) {
    ASSERT_TRUE(c.send_raw("\n"));
    std::this_thread::sleep_for(100ms);
  }
  ASSERT_TRUE(c.send_raw(R"({"jsonrpc":"2.0","id":7,)"));
  std::this_thread::sleep_for(100ms);
  ASSERT_TRUE(c.send_raw(R"("method":"server.health"})" "\n"));
  const json reply = c.read_json();
  EXPECT_EQ(reply["id"], 7);
  EXPECT_EQ(reply["result"]["status"], "ok");
  EXPECT_EQ(server.server->metrics().read_timeouts.load(), 0u);
}

// Not in sanitizer builds: with every descriptor in use, the sanitizer runtime cannot check
// memory (sanitizer_common's IsAccessibleMemoryRange probes it through a pipe), so UBSan's vptr
// check reports a false "invalid vptr" in std::shared_ptr and aborts. The normal build runs it.
#ifndef __SANITIZE_ADDRESS__
/// Lowers the soft limit on open files to `limit` while it lives.
class FileLimit {
 public:
  explicit FileLimit(rlim_t limit) {
    ::getrlimit(RLIMIT_NOFILE, &saved_);
    rlimit lowered = saved_;
    lowered.rlim_cur = limit;
    ok_ = ::setrlimit(RLIMIT_NOFILE, &lowered) == 0;
  }
  ~FileLimit() { ::setrlimit(RLIMIT_NOFILE, &saved_); }
  FileLimit(const FileLimit&) = delete;
  FileLimit& operator=(const FileLimit&) = delete;
  bool ok() const { return ok_; }

 private:
  rlimit saved_{};
  bool ok_ = false;
};

int highest_open_fd() {
  int highest = 0;
  for (const auto& entry : fs::directory_iterator("/proc/self/fd")) {
    highest = std::max(highest, std::stoi(entry.path().filename().string()));
  }
  return highest;
}

TEST(DescriptorFaults, AcceptingRecoversAfterRunningOutOfFileDescriptors) {
  TestData data;
  RunningServer server(spot_config(data));
  std::vector<int> fillers;
  int client = -1;
  {
    // The server runs in this process: fill its descriptor table (under a lowered limit), then
    // free one slot for a client socket, so that the server's accept finds none left.
    const FileLimit limit(static_cast<rlim_t>(highest_open_fd() + 64));
    ASSERT_TRUE(limit.ok());
    for (;;) {
      const int fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
      if (fd < 0) {
        ASSERT_EQ(errno, EMFILE);
        break;
      }
      fillers.push_back(fd);
    }
    ASSERT_FALSE(fillers.empty());
    ::close(fillers.back());
    fillers.pop_back();
    client = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    ASSERT_GE(client, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(server.port());
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    // The kernel completes the handshake (backlog); the server's accept fails with EMFILE.
    ASSERT_EQ(::connect(client, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    const auto deadline = std::chrono::steady_clock::now() + 10s;
    while (server.server->metrics().accept_errors.load() == 0 &&
           std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(10ms);
    }
    EXPECT_GE(server.server->metrics().accept_errors.load(), 1u);
    for (const int fd : fillers) ::close(fd);
  }
  // Descriptors free again: the acceptor (retrying every 100 ms) takes the waiting connection.
  const std::string request = R"({"jsonrpc":"2.0","id":1,"method":"server.health"})" "\n";
  ASSERT_EQ(::send(client, request.data(), request.size(), MSG_NOSIGNAL),
            static_cast<ssize_t>(request.size()));
  pollfd p{client, POLLIN, 0};
  ASSERT_EQ(::poll(&p, 1, 10'000), 1);
  char reply[4096];
  const ssize_t n = ::recv(client, reply, sizeof reply, 0);
  ::close(client);
  ASSERT_GT(n, 0);
  const json answer = json::parse(std::string(reply, static_cast<std::size_t>(n)));
  EXPECT_EQ(answer["result"]["status"], "ok");
  Client other(server.port());
  EXPECT_EQ(other.result("server.health")["status"], "ok");
}
#endif  // __SANITIZE_ADDRESS__

}  // namespace
}  // namespace geoprox::server::testing
