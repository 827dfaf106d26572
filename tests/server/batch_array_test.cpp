// JSON-RPC 2.0 batch arrays over a real socket: one line in, one array line out, the same answers
// as single requests; notifications, refusals of the whole array, server.auth, metrics, overload,
// deadlines, cancellation and the drain.
#include <map>
#include <set>

#include "server/metrics.h"
#include "server/service.h"
#include "tests/server/server_test_support.h"

namespace geoprox::server::testing {
namespace {

constexpr const char* kBatchToken = "batch-array-query-token";

class BatchArrayTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = new TestData();
    server_ = new RunningServer(spot_config(*data_));
    reference_ = new Reference(data_->data_dir() / "meshes/spot.obj",
                               data_->graph_dir() / "spot.geoprox");
  }
  static void TearDownTestSuite() {
    delete reference_;
    delete server_;
    delete data_;
  }
  static TestData* data_;
  static RunningServer* server_;
  static Reference* reference_;
};
TestData* BatchArrayTest::data_ = nullptr;
RunningServer* BatchArrayTest::server_ = nullptr;
Reference* BatchArrayTest::reference_ = nullptr;

/// A request object; a null `id` makes a notification.
json request(const json& id, const std::string& method, const json& params = json::object()) {
  json r = {{"jsonrpc", "2.0"}, {"method", method}, {"params", params}};
  if (!id.is_null()) r["id"] = id;
  return r;
}

/// "d0", "d1", ...: ids of the tests.
std::string numbered(std::string_view prefix, std::size_t i) {
  std::string id(prefix);
  id += std::to_string(i);
  return id;
}

json distance_params(const json& source, const json& target) {
  return {{"mesh", "spot"}, {"source", source}, {"target", target}};
}

/// A field from 300 face points: milliseconds of work (each point linked by its own solve).
json heavy_field_params() {
  json sources = json::array();
  for (int i = 0; i < 300; ++i) sources.push_back({{"face", i * 7}, {"bary", {0.2, 0.3, 0.5}}});
  return {{"mesh", "spot"}, {"sources", sources}};
}

std::string error_of(const json& reply) {
  if (!reply.contains("error")) return "no error: " + reply.dump();
  return reply["error"]["data"]["reason"].get<std::string>();
}

/// The replies of an array line by id (ids of the tests are unique strings, or null).
std::map<std::string, json> by_id(const json& replies) {
  std::map<std::string, json> out;
  for (const json& reply : replies) {
    out[reply["id"].is_null() ? "null" : reply["id"].get<std::string>()] = reply;
  }
  return out;
}

/// geoprox_requests_total of `method` with outcome `outcome`, whatever other labels it has.
double requests_counted(Server& server, const std::string& method, const std::string& outcome) {
  std::istringstream text(server.service().metrics_text());
  double total = 0;
  for (std::string line; std::getline(text, line);) {
    if (!line.starts_with("geoprox_requests_total{")) continue;
    if (line.find("method=\"" + method + "\"") == std::string::npos) continue;
    if (line.find("outcome=\"" + outcome + "\"") == std::string::npos) continue;
    total += std::stod(line.substr(line.rfind(' ') + 1));
  }
  return total;
}

TEST_F(BatchArrayTest, DistancesEqualThoseOfSingleRequestsInOrderOnOneLine) {
  Client c(server_->port());
  const std::vector<std::pair<json, json>> pairs = {
      {"v:0", "v:1"},
      {"v:5", {{"face", 100}, {"bary", {0.2, 0.3, 0.5}}}},
      {"e:7:0.25", "v:1200"},
      {{{"face", 9}, {"bary", {1, 0, 0}}}, "s:3"},
  };
  std::vector<double> single;
  for (const auto& [source, target] : pairs) {
    single.push_back(
        c.result("geodesic.distance", distance_params(source, target))["distance"].get<double>());
  }
  json array = json::array();
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    array.push_back(request(numbered("d", i), "geodesic.distance",
                            distance_params(pairs[i].first, pairs[i].second)));
  }
  array.push_back(request(nullptr, "geodesic.distance", distance_params("v:0", "v:2")));
  array.push_back(1);
  array.push_back(request("unknown-mesh", "geodesic.distance",
                          {{"mesh", "nope"}, {"source", "v:0"}, {"target", "v:1"}}));
  array.push_back(request("bad-point", "geodesic.distance", distance_params("v:0", "v:x")));
  array.push_back(request("health", "server.health"));
  ASSERT_TRUE(c.send_line(array.dump()));
  c.send("after", "server.health");

  // Two lines: the array's reply and, maybe first (it is answered inline), the next request's.
  json replies = c.read_json(30s);
  json after = c.read_json(30s);
  if (after.is_array()) std::swap(replies, after);
  EXPECT_EQ(after["id"], "after") << after.dump();
  ASSERT_TRUE(replies.is_array()) << replies.dump();
  // Every element owed a reply has one, in the order of the elements; the notification none.
  ASSERT_EQ(replies.size(), pairs.size() + 4) << replies.dump();
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const json& reply = replies[i];
    EXPECT_EQ(reply["jsonrpc"], "2.0");
    EXPECT_EQ(reply["id"], numbered("d", i));
    ASSERT_TRUE(reply.contains("result")) << reply.dump();
    // Byte for byte the distance of the single request.
    EXPECT_EQ(reply["result"]["distance"].get<double>(), single[i]) << i;
    EXPECT_EQ(reply["result"]["mesh"], "spot");
  }
  const double expected = reference_->query
                              .distance(SurfacePoint::vertex(5),
                                        SurfacePoint::face(100, 0.2, 0.3, 0.5), reference_->scratch)
                              .distance;
  EXPECT_DOUBLE_EQ(replies[1]["result"]["distance"].get<double>(), expected);
  const json& not_a_request = replies[pairs.size()];
  EXPECT_TRUE(not_a_request["id"].is_null());
  EXPECT_EQ(error_of(not_a_request), "InvalidRequest");
  EXPECT_EQ(not_a_request["error"]["message"], "a request must be a JSON object, not a number");
  EXPECT_EQ(replies[pairs.size() + 1]["id"], "unknown-mesh");
  EXPECT_EQ(error_of(replies[pairs.size() + 1]), "UnknownMesh");
  EXPECT_EQ(replies[pairs.size() + 2]["id"], "bad-point");
  EXPECT_EQ(error_of(replies[pairs.size() + 2]), "BadPoint");
  EXPECT_EQ(replies[pairs.size() + 3]["id"], "health");
  EXPECT_EQ(replies[pairs.size() + 3]["result"]["status"], "ok");
  EXPECT_FALSE(c.read_line(200ms)) << "nothing more";
}

TEST_F(BatchArrayTest, InlineMethodsOnlyAreAnsweredToo) {
  Client c(server_->port());
  const json array = json::array({request("list", "mesh.list"),
                                  request("info", "mesh.info", {{"mesh", "spot"}}),
                                  request("server", "server.info")});
  ASSERT_TRUE(c.send_line(array.dump()));
  const json replies = c.read_json();
  ASSERT_EQ(replies.size(), 3u) << replies.dump();
  EXPECT_EQ(replies[0]["result"]["meshes"][0]["id"], "spot");
  EXPECT_EQ(replies[1]["result"]["mesh"], "spot");
  EXPECT_EQ(replies[1]["result"]["vertices"], reference_->mesh.num_vertices());
  EXPECT_EQ(replies[2]["result"]["limits"]["max_batch_requests"], 1000);
}

TEST_F(BatchArrayTest, NotificationsOnlyGetNoReplyAndTheConnectionGoesOn) {
  Client c(server_->port());
  Server& server = *server_->server;
  const double distances_before = requests_counted(server, "geodesic.distance", "ok");
  const double failures_before = requests_counted(server, "geodesic.distance", "UnknownMesh");
  const json array = {
      request(nullptr, "geodesic.distance", distance_params("v:0", "v:1")),
      request(nullptr, "geodesic.distance",
              {{"mesh", "nope"}, {"source", "v:0"}, {"target", "v:1"}}),
      request(nullptr, "server.health"),
      request(nullptr, "no.such.method"),
  };
  ASSERT_TRUE(c.send_line(array.dump()));
  c.send("next", "server.health");
  const json next = c.read_json();
  EXPECT_EQ(next["id"], "next") << next.dump();
  EXPECT_EQ(next["result"]["status"], "ok");
  // The notifications were carried out (on a compute thread: maybe after "next").
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (requests_counted(server, "geodesic.distance", "UnknownMesh") < failures_before + 1 &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(5ms);
  }
  EXPECT_GE(requests_counted(server, "geodesic.distance", "ok"), distances_before + 1);
  EXPECT_GE(requests_counted(server, "geodesic.distance", "UnknownMesh"), failures_before + 1);
  // Nothing else arrives.
  EXPECT_FALSE(c.read_line(200ms));

  // An empty array is one error object, not an array.
  ASSERT_TRUE(c.send_line(" [ ] "));
  const json empty = c.read_json();
  ASSERT_TRUE(empty.is_object()) << empty.dump();
  EXPECT_TRUE(empty["id"].is_null());
  EXPECT_EQ(error_of(empty), "InvalidRequest");
  EXPECT_EQ(empty["error"]["code"], -32600);
}

TEST_F(BatchArrayTest, MetricsCountEachElementAsItsOwnRequest) {
  Client c(server_->port());
  Server& server = *server_->server;
  const double ok_before = requests_counted(server, "geodesic.distance", "ok");
  const double bad_before = requests_counted(server, "geodesic.distance", "BadPoint");
  const double health_before = requests_counted(server, "server.health", "ok");
  const json array = {request("a", "geodesic.distance", distance_params("v:0", "v:1")),
                      request("b", "geodesic.distance", distance_params("v:0", "v:2")),
                      request(nullptr, "geodesic.distance", distance_params("v:0", "v:3")),
                      request("c", "geodesic.distance", distance_params("v:0", "v:x")),
                      request("d", "server.health")};
  ASSERT_TRUE(c.send_line(array.dump()));
  ASSERT_EQ(c.read_json(30s).size(), 4u);
  EXPECT_EQ(requests_counted(server, "geodesic.distance", "ok"), ok_before + 3);
  EXPECT_EQ(requests_counted(server, "geodesic.distance", "BadPoint"), bad_before + 1);
  EXPECT_EQ(requests_counted(server, "server.health", "ok"), health_before + 1);
}

TEST_F(BatchArrayTest, AnElementsOwnTimeoutFailsItAlone) {
  Client c(server_->port());
  json short_field = heavy_field_params();
  short_field["timeout_ms"] = 1;
  const json array = {request("short", "geodesic.field", short_field),
                      request("next", "geodesic.distance", distance_params("v:0", "v:1"))};
  ASSERT_TRUE(c.send_line(array.dump()));
  const json replies = c.read_json(30s);
  ASSERT_EQ(replies.size(), 2u) << replies.dump();
  EXPECT_EQ(error_of(replies[0]), "DeadlineExceeded");
  EXPECT_EQ(replies[0]["error"]["code"], -32031);
  EXPECT_TRUE(replies[1].contains("result")) << replies[1].dump();
}

TEST_F(BatchArrayTest, TooManyElementsOrPointsRefuseTheWholeArray) {
  Config config = spot_config(*data_);
  config.limits.max_batch_requests = 3;
  config.limits.max_points_per_request = 4;
  RunningServer server(config);
  Client c(server.port());
  const json health = request("h", "server.health");
  ASSERT_TRUE(c.send_line(json::array({health, health, health, health}).dump()));
  const json many = c.read_json();
  ASSERT_TRUE(many.is_object()) << many.dump();
  EXPECT_TRUE(many["id"].is_null());
  EXPECT_EQ(error_of(many), "TooLarge");
  EXPECT_EQ(many["error"]["message"], "batch array: 4 requests exceed max_batch_requests = 3");

  const json three_distances = {
      request("a", "geodesic.distance", distance_params("v:0", "v:1")),
      request("b", "geodesic.distance", distance_params("v:0", "v:2")),
      request(nullptr, "geodesic.distance", distance_params("v:0", "v:3"))};
  ASSERT_TRUE(c.send_line(three_distances.dump()));
  const json points = c.read_json();
  EXPECT_TRUE(points["id"].is_null()) << points.dump();
  EXPECT_EQ(error_of(points), "TooLarge");
  EXPECT_EQ(points["error"]["message"],
            "batch array: 6 points exceed the limit of 4 points per request (a batch array counts "
            "all its requests)");

  // Within the limits: answered.
  const json two = {request("a", "geodesic.distance", distance_params("v:0", "v:1")),
                    request("b", "geodesic.distance", distance_params("v:0", "v:2"))};
  ASSERT_TRUE(c.send_line(two.dump()));
  const json replies = c.read_json();
  ASSERT_EQ(replies.size(), 2u) << replies.dump();
  EXPECT_TRUE(replies[0].contains("result"));
  EXPECT_TRUE(replies[1].contains("result"));
}

TEST_F(BatchArrayTest, RepliesBeyondMaxOutputBytesTogetherBecomeTooLarge) {
  Config config = spot_config(*data_);
  config.limits.max_output_bytes = 400;  // two distance replies of about 170 bytes
  RunningServer server(config);
  Client c(server.port());
  json array = json::array();
  for (const char* id : {"a", "b", "c", "d"}) {
    array.push_back(request(id, "geodesic.distance", distance_params("v:0", "v:1")));
  }
  ASSERT_TRUE(c.send_line(array.dump()));
  const std::string line = c.read_line(30s).value_or("");
  EXPECT_LE(line.size(), 400u + 2 * 250u) << line;  // two short errors past the budget
  const json replies = json::parse(line);
  ASSERT_EQ(replies.size(), 4u) << line;
  EXPECT_TRUE(replies[0].contains("result"));
  EXPECT_TRUE(replies[1].contains("result"));
  for (int k = 2; k < 4; ++k) {
    EXPECT_EQ(replies[k]["id"], k == 2 ? "c" : "d");
    EXPECT_EQ(error_of(replies[k]), "TooLarge");
    EXPECT_EQ(replies[k]["error"]["message"],
              "the replies of this batch array take more than max_output_bytes (400)");
  }
}

TEST(BatchArrayAccess, BeforeServerAuthEachElementIsUnauthorizedAndServerAuthMustBeAlone) {
  TestData data;
  Config config = spot_config(data);
  config.query_token = kBatchToken;
  RunningServer server(config);
  Client c(server.port());
  const json array = {
      request("health", "server.health"),
      request("distance", "geodesic.distance", distance_params("v:0", "v:1")),
      request("auth", "server.auth", {{"token", kBatchToken}}),
      request("list", "mesh.list"),
      request("malformed", "mesh.info", json::object()),
      request(nullptr, "geodesic.distance", distance_params("v:0", "v:1")),
      7,
  };
  ASSERT_TRUE(c.send_line(array.dump()));
  std::map<std::string, json> replies = by_id(c.read_json(30s));
  ASSERT_EQ(replies.size(), 6u);
  EXPECT_EQ(replies["health"]["result"]["auth_required"], true);
  EXPECT_EQ(error_of(replies["distance"]), "Unauthorized");
  EXPECT_EQ(replies["distance"]["error"]["code"], -32040);
  EXPECT_EQ(error_of(replies["auth"]), "InvalidRequest");
  EXPECT_EQ(replies["auth"]["error"]["message"],
            "server.auth must be sent alone, not in a batch array");
  EXPECT_EQ(error_of(replies["list"]), "Unauthorized");
  EXPECT_EQ(error_of(replies["malformed"]), "Unauthorized");
  EXPECT_EQ(error_of(replies["null"]), "InvalidRequest");
  // server.auth in the array did not authenticate the connection.
  EXPECT_EQ(c.error_reason("mesh.list"), "Unauthorized");

  EXPECT_EQ(c.result("server.auth", {{"token", kBatchToken}}), json({{"authenticated", true}}));
  ASSERT_TRUE(c.send_line(array.dump()));
  replies = by_id(c.read_json(30s));
  ASSERT_EQ(replies.size(), 6u);
  EXPECT_EQ(replies["health"]["result"]["status"], "ok");
  EXPECT_GT(replies["distance"]["result"]["distance"].get<double>(), 0.0);
  EXPECT_EQ(error_of(replies["auth"]), "InvalidRequest");
  EXPECT_EQ(replies["list"]["result"]["meshes"][0]["id"], "spot");
  EXPECT_EQ(error_of(replies["malformed"]), "InvalidParams");
  // ... and did not unauthenticate it either.
  EXPECT_TRUE(c.call("mesh.list").contains("result"));
}

TEST_F(BatchArrayTest, AFullQueueAnswersEachRequestOfTheArrayOverloaded) {
  Config config = spot_config(*data_);
  config.compute_threads = 1;
  config.server_limits.max_queue = 2;
  RunningServer server(config);
  Client c(server.port());
  json sources = json::array();
  for (int i = 0; i < 100; ++i) sources.push_back({{"face", i * 13}, {"bary", {0.2, 0.3, 0.5}}});
  const json matrix = {{"mesh", "spot"}, {"sources", sources}, {"targets", {"v:1"}}};
  std::string burst;
  const int n = 30;
  for (int i = 0; i < n; ++i) {
    const json array = {request(numbered("m", i), "geodesic.matrix", matrix),
                        request(nullptr, "geodesic.matrix", matrix),
                        request(numbered("h", i), "server.health"), json::object()};
    burst += array.dump() + "\n";
  }
  ASSERT_TRUE(c.send_raw(burst));
  int answered = 0, overloaded = 0;
  std::set<std::string> seen;
  for (int i = 0; i < n; ++i) {
    const json replies = c.read_json(60s);
    ASSERT_EQ(replies.size(), 3u) << replies.dump();
    seen.insert(replies[0]["id"].get<std::string>());
    // The element that is no request keeps its own error.
    EXPECT_EQ(error_of(replies[2]), "InvalidRequest");
    if (replies[0].contains("result")) {
      ++answered;
      EXPECT_EQ(replies[1]["result"]["status"], "ok");
      continue;
    }
    ++overloaded;
    for (int k = 0; k < 2; ++k) {
      EXPECT_EQ(error_of(replies[k]), "Overloaded") << replies.dump();
      EXPECT_EQ(replies[k]["error"]["data"]["retryable"], true);
      EXPECT_GE(replies[k]["error"]["data"]["retry_after_ms"].get<int>(), 10);
    }
  }
  EXPECT_EQ(seen.size(), static_cast<std::size_t>(n));
  EXPECT_GE(answered, 1);
  EXPECT_GE(overloaded, 1);
  // Once the backlog drains, arrays are accepted again.
  ASSERT_TRUE(c.send_line(
      json::array({request("late", "geodesic.distance", distance_params("v:0", "v:1"))}).dump()));
  EXPECT_TRUE(c.read_json(60s)[0].contains("result"));
}

/// Waits (up to 10 s) until the server has a request in flight: a line it has read and dispatched.
bool wait_until_in_flight(Server& server) {
  const auto give_up = std::chrono::steady_clock::now() + 10s;
  while (server.metrics().in_flight.load() == 0 && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(1ms);
  }
  return server.metrics().in_flight.load() > 0;
}

/// 30 heavy fields: a second or so of work for one compute thread.
json long_array() {
  json array = json::array();
  for (int k = 0; k < 30; ++k) {
    array.push_back(request(numbered("f", k), "geodesic.field", heavy_field_params()));
  }
  return array;
}

TEST_F(BatchArrayTest, ClientDisconnectingCancelsTheRestOfItsArray) {
  Config config = spot_config(*data_);
  config.compute_threads = 1;
  RunningServer server(config);
  const double cancelled_before =
      requests_counted(*server.server, "geodesic.field", "DeadlineExceeded");
  {
    Client c(server.port());
    ASSERT_TRUE(c.send_line(long_array().dump()));
    // Once the array runs: a reset, not a FIN (after a FIN, a half-close, the server would
    // answer the whole array).
    ASSERT_TRUE(wait_until_in_flight(*server.server));
    c.reset();
  }
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (server.server->metrics().in_flight.load() != 0 &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(5ms);
  }
  EXPECT_EQ(server.server->metrics().in_flight.load(), 0);
  // The elements after the disconnect were cancelled (recorded, never sent).
  EXPECT_GE(requests_counted(*server.server, "geodesic.field", "DeadlineExceeded"),
            cancelled_before + 1);
  Client d(server.port());
  EXPECT_DOUBLE_EQ(
      d.result("geodesic.distance", distance_params("v:0", "v:0"))["distance"].get<double>(), 0.0);
}

TEST(BatchArrayDrain, TheShutdownDeadlineCancelsTheRestOfAnArray) {
  TestData data;
  Config config = spot_config(data);
  config.compute_threads = 1;
  config.shutdown_timeout_ms = 100;
  RunningServer server(config);
  Client c(server.port());
  ASSERT_TRUE(c.send_line(long_array().dump()));
  ASSERT_TRUE(wait_until_in_flight(*server.server));
  const auto started = std::chrono::steady_clock::now();
  server.server->shutdown();
  server.server->wait();
  // Not the whole array: its remaining elements failed fast once cancelled.
  EXPECT_LT(std::chrono::steady_clock::now() - started, 5s);
  EXPECT_GE(requests_counted(*server.server, "geodesic.field", "ShuttingDown"), 1);
  // Closed without a reply.
  EXPECT_TRUE(c.closed_by_peer());
}

TEST(BatchArrayDrain, AnArrayInFlightIsAnsweredAndNewOnesAreRefusedShuttingDown) {
  TestData data;
  Config config = spot_config(data);
  config.compute_threads = 1;
  RunningServer server(config);
  Client c(server.port());
  const json in_flight = {request("f1", "geodesic.field", heavy_field_params()),
                          request("f2", "geodesic.field", heavy_field_params())};
  ASSERT_TRUE(c.send_line(in_flight.dump()));
  ASSERT_TRUE(wait_until_in_flight(*server.server));
  server.server->shutdown();
  std::this_thread::sleep_for(20ms);
  const json late = {request("d", "geodesic.distance", distance_params("v:0", "v:1")),
                     request("h", "server.health")};
  ASSERT_TRUE(c.send_line(late.dump()));
  ASSERT_TRUE(c.send_line(json::array({request("h2", "server.health")}).dump()));
  std::map<std::string, json> replies;
  for (int i = 0; i < 3; ++i) {
    for (const json& reply : c.read_json(30s)) replies[reply["id"].get<std::string>()] = reply;
  }
  EXPECT_TRUE(replies["f1"].contains("result")) << replies["f1"].dump();
  EXPECT_TRUE(replies["f2"].contains("result")) << replies["f2"].dump();
  // An array that needs the compute pool is refused whole while draining...
  EXPECT_EQ(error_of(replies["d"]), "ShuttingDown");
  EXPECT_EQ(error_of(replies["h"]), "ShuttingDown");
  // ... one of cheap methods only is still answered.
  EXPECT_EQ(replies["h2"]["result"]["status"], "draining");
}

}  // namespace
}  // namespace geoprox::server::testing
