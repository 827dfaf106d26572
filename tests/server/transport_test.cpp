// The transport under abuse: bad input of every kind, pipelining with out-of-order replies, a
// client that disconnects mid-request, overload, deadlines, the connection cap, a client that
// never reads, the admin HTTP endpoint.
#include <set>

#include "server/metrics.h"
#include "server/service.h"
#include "tests/server/server_test_support.h"

namespace geoprox::server::testing {
namespace {

class TransportTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = new TestData();
    server_ = new RunningServer(spot_config(*data_));
  }
  static void TearDownTestSuite() {
    delete server_;
    delete data_;
  }
  static TestData* data_;
  static RunningServer* server_;
};
TestData* TransportTest::data_ = nullptr;
RunningServer* TransportTest::server_ = nullptr;

std::string error_of(const json& reply) {
  if (!reply.contains("error")) return "no error: " + reply.dump();
  return reply["error"]["data"]["reason"].get<std::string>();
}

TEST_F(TransportTest, EveryBadInputGetsItsErrorAndTheConnectionKeepsWorking) {
  Client c(server_->port());
  struct Case {
    std::string line;
    std::string reason;
    json id;
  };
  std::string deep = R"({"jsonrpc":"2.0","id":5,"method":"server.info","params":{"x":)";
  for (int i = 0; i < 200; ++i) deep += "[";
  const std::vector<Case> cases = {
      {"{not json", "ParseError", nullptr},
      {"\xff\xfe garbage", "ParseError", nullptr},
      {deep, "TooLarge", 5},
      {R"({"jsonrpc":"2.0","id":1,"method":"geodesic.distance","params":{"mesh":"spot","source":"v:0","target":"v:1","extra":1}})",
       "InvalidParams", 1},
      {R"({"jsonrpc":"2.0","id":2,"method":"geodesic.distance","params":{"mesh":7,"source":"v:0","target":"v:1"}})",
       "InvalidParams", 2},
      {R"({"jsonrpc":"2.0","id":3,"method":"geodesic.distances","params":{}})", "UnknownMethod", 3},
      {R"({"jsonrpc":"2.0","id":4,"method":"geodesic.distance","params":{"mesh":"spott","source":"v:0","target":"v:1"}})",
       "UnknownMesh", 4},
      {R"({"jsonrpc":"2.0","id":6,"method":"geodesic.distance","params":{"mesh":"spot","source":"v:0","target":"f:99999:1:0:0"}})",
       "FaceOutOfRange", 6},
      {R"({"jsonrpc":"2.0","id":7,"method":"geodesic.distance","params":{"mesh":"spot","source":"v:99999","target":"v:1"}})",
       "VertexOutOfRange", 7},
      {R"({"jsonrpc":"2.0","id":8,"method":"geodesic.distance","params":{"mesh":"spot","source":"e:999999:0.5","target":"v:1"}})",
       "EdgeOutOfRange", 8},
      {R"({"jsonrpc":"2.0","id":9,"method":"geodesic.distance","params":{"mesh":"spot","source":"s:99999","target":"v:1"}})",
       "SampleOutOfRange", 9},
      {R"({"jsonrpc":"2.0","id":10,"method":"geodesic.distance","params":{"mesh":"spot","source":{"face":5,"bary":[0.2,0.3,0.6]},"target":"v:1"}})",
       "BadBarycentric", 10},
      {R"({"jsonrpc":"2.0","id":11,"method":"geodesic.distance","params":{"mesh":"spot","source":"e:7:1.5","target":"v:1"}})",
       "BadEdgeParameter", 11},
      {R"({"jsonrpc":"2.0","id":12,"method":"geodesic.distance","params":{"mesh":"spot","source":{"position":[NaN,0,0]},"target":"v:1"}})",
       "ParseError", 12},
      {R"({"jsonrpc":"2.0","id":13,"method":"geodesic.distance","params":{"mesh":"spot","source":{"position":[1e400,0,0]},"target":"v:1"}})",
       "ParseError", 13},
      {R"({"jsonrpc":"2.0","id":14,"method":"geodesic.distance","params":{"mesh":"spot","source":"p:nan,0,0","target":"v:1"}})",
       "BadPoint", 14},
      {R"({"jsonrpc":"2.0","id":15,"method":"geodesic.distance","params":{"mesh":"spot","source":{"position":[100,100,100]},"target":"v:1"}})",
       "BadPoint", 15},
      {R"({"jsonrpc":"2.0","method":7})", "InvalidRequest", nullptr},
      {"[]", "InvalidRequest", nullptr},
      {R"({"jsonrpc":"2.0","id":16,"method":"geodesic.field","params":{"mesh":"spot","source":"v:0","encoding":"f64"}})",
       "InvalidParams", 16},
      {R"({"jsonrpc":"2.0","id":17,"method":"admin.unregister","params":{"mesh":"spot","token":"x"}})",
       "Unauthorized", 17},
  };
  int probe = 100;
  for (const Case& k : cases) {
    ASSERT_TRUE(c.send_line(k.line));
    const json reply = c.read_json();
    EXPECT_EQ(error_of(reply), k.reason) << k.line << "\n" << reply.dump();
    EXPECT_EQ(reply["id"], k.id) << k.line;
    EXPECT_TRUE(reply["error"]["code"].is_number_integer());
    // The connection still answers.
    c.send(probe, "geodesic.distance", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:1"}});
    const json ok = c.read_json();
    EXPECT_EQ(ok["id"], probe++);
    EXPECT_TRUE(ok.contains("result")) << ok.dump();
  }
  // A notification (no id) is carried out and never answered, even when it fails.
  ASSERT_TRUE(c.send_line(R"({"jsonrpc":"2.0","method":"geodesic.distance","params":{"mesh":"nope","source":"v:0","target":"v:1"}})"));
  c.send(999, "server.health");
  EXPECT_EQ(c.read_json()["id"], 999);
}

TEST_F(TransportTest, OverLongLineIsRefusedAndTheNextLineIsRead) {
  Config config = spot_config(*data_);
  config.limits.max_line_bytes = 4096;
  RunningServer server(config);
  Client c(server.port());
  std::string long_line = R"({"jsonrpc":"2.0","id":1,"method":"server.info","params":{"pad":")";
  long_line += std::string(100000, 'x') + "\"}}";
  ASSERT_TRUE(c.send_line(long_line));
  c.send(2, "server.health");
  const json first = c.read_json();
  EXPECT_EQ(error_of(first), "TooLarge");
  EXPECT_TRUE(first["id"].is_null());
  const json second = c.read_json();
  EXPECT_EQ(second["id"], 2);
  EXPECT_TRUE(second.contains("result"));
}

TEST_F(TransportTest, HalfClosedClientStillGetsItsLastReply) {
  Client c(server_->port());
  ASSERT_TRUE(c.send_raw(R"({"jsonrpc":"2.0","id":"last","method":"geodesic.distance","params":{"mesh":"spot","source":"v:0","target":"v:9"}})"));
  c.shutdown_write();
  const json reply = c.read_json();
  EXPECT_EQ(reply["id"], "last");
  EXPECT_TRUE(reply.contains("result"));
  EXPECT_TRUE(c.closed_by_peer());
}

TEST_F(TransportTest, PipelinedRequestsAreAllAnsweredAndMayComeOutOfOrder) {
  Client c(server_->port());
  // A slow request first (a field from 300 face points, each linked by its own exact solve:
  // milliseconds; a field from eight vertices finished first now and then, under a parallel
  // ctest), then cheap ones: the cheap ones overtake it.
  json slow_sources = json::array();
  for (int i = 0; i < 300; ++i) slow_sources.push_back({{"face", i * 7}, {"bary", {0.2, 0.3, 0.5}}});
  c.send("slow", "geodesic.field", {{"mesh", "spot"}, {"sources", slow_sources}});
  std::string burst;
  const int n = 200;
  for (int i = 0; i < n; ++i) {
    json request = {{"jsonrpc", "2.0"},
                    {"id", i},
                    {"method", i % 10 == 0 ? "server.health" : "geodesic.distance"},
                    {"params", i % 10 == 0 ? json::object()
                                           : json{{"mesh", "spot"},
                                                  {"source", "v:" + std::to_string(i)},
                                                  {"target", "v:" + std::to_string(2 * i + 1)}}}};
    burst += request.dump() + "\n";
  }
  ASSERT_TRUE(c.send_raw(burst));
  std::vector<json> order;
  std::set<std::string> seen;
  for (int i = 0; i < n + 1; ++i) {
    const json reply = c.read_json(30s);
    EXPECT_TRUE(reply.contains("result")) << reply.dump();
    EXPECT_TRUE(seen.insert(reply["id"].dump()).second) << "duplicate " << reply["id"];
    order.push_back(reply["id"]);
  }
  EXPECT_EQ(seen.size(), static_cast<std::size_t>(n + 1));
  // The first reply is not the slow request: replies came out of order.
  EXPECT_NE(order.front(), "slow");
}

TEST_F(TransportTest, ClientDisconnectingMidFieldCancelsItsWork) {
  Config config = spot_config(*data_);
  config.compute_threads = 1;
  RunningServer server(config);
  {
    Client c(server.port());
    // Several heavy requests (matrix of many exact link solves), then vanish.
    json sources = json::array();
    for (int i = 0; i < 300; ++i) sources.push_back({{"face", i * 7}, {"bary", {0.2, 0.3, 0.5}}});
    for (int k = 0; k < 5; ++k) {
      c.send(k, "geodesic.field", {{"mesh", "spot"}, {"sources", sources}});
    }
    std::this_thread::sleep_for(20ms);
  }
  // The work is cancelled: in-flight drops to zero quickly, and the server keeps answering.
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (server.server->metrics().in_flight.load() != 0 &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(5ms);
  }
  EXPECT_EQ(server.server->metrics().in_flight.load(), 0);
  Client d(server.port());
  EXPECT_DOUBLE_EQ(
      d.result("geodesic.distance", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:0"}})["distance"]
          .get<double>(),
      0.0);
  EXPECT_EQ(server.server->metrics().connections.load(), 1);
  // At least one of them was cancelled (recorded as DeadlineExceeded, never sent).
  const std::string text = server.server->service().metrics_text();
  EXPECT_NE(text.find("geoprox_requests_total{transport=\"tcp\",method=\"geodesic.field\",outcome=\"DeadlineExceeded\"}"),
            std::string::npos)
      << text.substr(0, 2000);
}

TEST_F(TransportTest, ConnectionOverItsInFlightCapIsNotReadUntilRepliesDrain) {
  Config config = spot_config(*data_);
  config.server_limits.max_inflight_per_connection = 1;
  RunningServer server(config);
  Client c(server.port());
  json sources = json::array();
  for (int i = 0; i < 300; ++i) sources.push_back({{"face", i * 7}, {"bary", {0.2, 0.3, 0.5}}});
  // With one request in flight allowed, the cheap server.health behind the slow field is not
  // even read before the field is answered: replies come in request order.
  c.send("slow", "geodesic.field", {{"mesh", "spot"}, {"sources", sources}});
  c.send("cheap", "server.health");
  EXPECT_EQ(c.read_json(30s)["id"], "slow");
  EXPECT_EQ(c.read_json(30s)["id"], "cheap");
  // With the default cap the cheap one overtakes the slow one.
  Client d(server_->port());
  d.send("slow", "geodesic.field", {{"mesh", "spot"}, {"sources", sources}});
  d.send("cheap", "server.health");
  EXPECT_EQ(d.read_json(30s)["id"], "cheap");
  EXPECT_EQ(d.read_json(30s)["id"], "slow");
}

TEST_F(TransportTest, FullQueueAnswersOverloadedWithRetryAfter) {
  Config config = spot_config(*data_);
  config.compute_threads = 1;
  config.server_limits.max_queue = 2;
  RunningServer server(config);
  Client c(server.port());
  json sources = json::array();
  for (int i = 0; i < 100; ++i) sources.push_back({{"face", i * 13}, {"bary", {0.2, 0.3, 0.5}}});
  std::string burst;
  const int n = 30;
  for (int i = 0; i < n; ++i) {
    burst += json({{"jsonrpc", "2.0"},
                   {"id", i},
                   {"method", "geodesic.matrix"},
                   {"params", {{"mesh", "spot"}, {"sources", sources}, {"targets", {"v:1"}}}}})
                 .dump() +
             "\n";
  }
  ASSERT_TRUE(c.send_raw(burst));
  int ok = 0, overloaded = 0;
  for (int i = 0; i < n; ++i) {
    const json reply = c.read_json(60s);
    if (reply.contains("result")) {
      ++ok;
    } else {
      EXPECT_EQ(error_of(reply), "Overloaded");
      EXPECT_EQ(reply["error"]["code"], -32030);
      EXPECT_EQ(reply["error"]["data"]["retryable"], true);
      EXPECT_GE(reply["error"]["data"]["retry_after_ms"].get<int>(), 10);
      ++overloaded;
    }
  }
  EXPECT_GE(ok, 1);
  EXPECT_GE(overloaded, 1);
  EXPECT_EQ(ok + overloaded, n);
  // Once the backlog drains, requests are accepted again.
  EXPECT_TRUE(c.result("geodesic.distance", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:1"}})
                  .contains("distance"));
}

TEST_F(TransportTest, DeadlineExceededWhileQueuedBehindABlockedPool) {
  Config config = spot_config(*data_);
  config.compute_threads = 1;
  RunningServer server(config);
  Client c(server.port());
  json sources = json::array();
  for (int i = 0; i < 300; ++i) sources.push_back({{"face", i * 7}, {"bary", {0.2, 0.3, 0.5}}});
  c.send("blocker", "geodesic.field", {{"mesh", "spot"}, {"sources", sources}});
  c.send("late", "geodesic.distance",
         {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:1"}, {"timeout_ms", 1}});
  std::map<std::string, json> replies;
  for (int i = 0; i < 2; ++i) {
    const json reply = c.read_json(60s);
    replies[reply["id"].get<std::string>()] = reply;
  }
  EXPECT_TRUE(replies["blocker"].contains("result"));
  EXPECT_EQ(error_of(replies["late"]), "DeadlineExceeded");
  EXPECT_EQ(replies["late"]["error"]["code"], -32031);
  // A deadline inside the search: a big field with a 1 ms budget.
  const json reply = c.call("geodesic.field", {{"mesh", "spot"}, {"sources", sources}, {"timeout_ms", 1}});
  EXPECT_EQ(error_of(reply), "DeadlineExceeded");
}

TEST_F(TransportTest, ConnectionCapRefusesExtraConnections) {
  Config config = spot_config(*data_);
  config.server_limits.max_connections = 2;
  RunningServer server(config);
  Client a(server.port());
  Client b(server.port());
  a.result("server.health");
  b.result("server.health");
  Client extra(server.port());
  const json reply = extra.read_json();
  EXPECT_EQ(error_of(reply), "Overloaded");
  EXPECT_TRUE(extra.closed_by_peer());
  a.close();
  // The slot frees up once a is gone.
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (server.server->metrics().connections.load() > 1 &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(5ms);
  }
  Client again(server.port());
  EXPECT_EQ(again.result("server.health")["status"], "ok");
}

TEST_F(TransportTest, ClientThatNeverReadsIsDisconnected) {
  Config config = spot_config(*data_);
  config.server_limits.max_write_buffer_bytes = 64 * 1024;
  RunningServer server(config);
  Client c(server.port());
  const std::string request =
      R"({"jsonrpc":"2.0","id":1,"method":"geodesic.field","params":{"mesh":"spot","source":"v:0"}})"
      "\n";
  std::string burst;
  for (int i = 0; i < 20; ++i) burst += request;
  // Write without ever reading, until the server gives up on us.
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (server.server->metrics().slow_reader_disconnects.load() == 0 &&
         std::chrono::steady_clock::now() < deadline) {
    if (!c.send_raw(burst)) break;
  }
  EXPECT_GE(server.server->metrics().slow_reader_disconnects.load(), 1u);
  Client d(server.port());
  EXPECT_EQ(d.result("server.health")["status"], "ok");
}

TEST_F(TransportTest, IdleConnectionIsClosedAfterTheReadTimeout) {
  Config config = spot_config(*data_);
  config.server_limits.read_timeout_ms = 100;
  RunningServer server(config);
  Client c(server.port());
  c.result("server.health");
  EXPECT_TRUE(c.closed_by_peer(5s));
  EXPECT_GE(server.server->metrics().read_timeouts.load(), 1u);
}

std::string http_get(std::uint16_t port, const std::string& path) {
  Client c(port);
  c.send_raw("GET " + path + " HTTP/1.1\r\nHost: localhost\r\n\r\n");
  std::string all;
  while (auto line = c.read_line(5s)) all += *line + "\n";
  return all;
}

TEST_F(TransportTest, AdminHttpServesMetricsLivenessAndReadiness) {
  Config config = spot_config(*data_);
  config.admin_port = 0;
  config.http_port = 0;
  RunningServer probe(config);
  EXPECT_EQ(probe.server->admin_port(), 0);  // 0 = off
  // An ephemeral admin port: bind to a free port chosen by the kernel first.
  Config with_admin = spot_config(*data_);
  {
    // Find a free port.
    int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    socklen_t len = sizeof addr;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
    with_admin.admin_port = ntohs(addr.sin_port);
    ::close(fd);
  }
  RunningServer server(with_admin);
  const std::uint16_t admin = server.server->admin_port();
  ASSERT_NE(admin, 0);
  Client(server.port()).result("geodesic.distance", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:1"}});
  const std::string metrics = http_get(admin, "/metrics");
  EXPECT_NE(metrics.find("HTTP/1.1 200 OK"), std::string::npos);
  EXPECT_NE(metrics.find("geoprox_requests_total{transport=\"tcp\",method=\"geodesic.distance\",outcome=\"ok\"} 1"),
            std::string::npos)
      << metrics;
  EXPECT_NE(metrics.find("geoprox_ready 1"), std::string::npos);
  EXPECT_NE(http_get(admin, "/healthz").find("200 OK"), std::string::npos);
  EXPECT_NE(http_get(admin, "/readyz").find("ready"), std::string::npos);
  EXPECT_NE(http_get(admin, "/nope").find("404"), std::string::npos);
}

}  // namespace
}  // namespace geoprox::server::testing
