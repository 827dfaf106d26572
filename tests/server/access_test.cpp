// Access control of the query port (issue 8, section 4): the optional query token (server.auth,
// per connection, in line order, 5 failures close the connection), its separation from the
// admin token, and tokens kept out of the logs and the metrics. Real sockets on 127.0.0.1.
#include <spdlog/spdlog.h>

#include <cstdlib>
#include <map>

#include "server/service.h"
#include "tests/server/server_test_support.h"

namespace geoprox::server::testing {
namespace {

constexpr const char* kQueryToken = "q-7f3a9c51e2d84b06";
constexpr const char* kAdminToken = "a-91bc04d7f2e65a38";

std::string request_line(const json& id, const std::string& method,
                         const json& params = json::object()) {
  return json({{"jsonrpc", "2.0"}, {"id", id}, {"method", method}, {"params", params}}).dump() +
         "\n";
}

const json kDistance = {{"mesh", "spot"}, {"source", "v:0"}, {"target", "f:100:0.2:0.3:0.5"}};

/// The replies to `count` requests, by id (they may come in any order).
std::map<int, json> replies_by_id(Client& c, std::size_t count) {
  std::map<int, json> out;
  for (std::size_t i = 0; i < count; ++i) {
    const json reply = c.read_json();
    out[reply.at("id").get<int>()] = reply;
  }
  return out;
}

std::string reason_of(const json& reply) {
  if (!reply.contains("error")) return "result";
  return reply["error"]["data"]["reason"].get<std::string>();
}

/// One server for the suite, with a query token and an admin token, logging everything (trace)
/// into a CaptureSink.
class AccessTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    sink_ = std::make_shared<CaptureSink>();
    previous_logger_ = spdlog::default_logger();
    auto logger = std::make_shared<spdlog::logger>("access-test", sink_);
    logger->set_level(spdlog::level::trace);
    spdlog::set_default_logger(logger);
    data_ = new TestData();
    Config config = spot_config(*data_);
    config.query_token = kQueryToken;
    config.admin_token = kAdminToken;
    server_ = new Server(config);
    server_->start();
    ASSERT_TRUE(server_->registry().wait_idle(60s));
    reference_ = new Reference(data_->data_dir() / "meshes/spot.obj",
                               data_->graph_dir() / "spot.geoprox");
  }
  static void TearDownTestSuite() {
    server_->shutdown();
    server_->wait();
    delete server_;
    delete reference_;
    delete data_;
    spdlog::set_default_logger(previous_logger_);
    previous_logger_.reset();
    sink_.reset();
  }

  static std::uint16_t port() { return server_->port(); }
  static double expected_distance() {
    return reference_->query
        .distance(SurfacePoint::vertex(0), SurfacePoint::face(100, 0.2, 0.3, 0.5),
                  reference_->scratch)
        .distance;
  }
  static void authenticate(Client& c) {
    EXPECT_EQ(c.result("server.auth", {{"token", kQueryToken}}), json({{"authenticated", true}}));
  }

  static std::shared_ptr<CaptureSink> sink_;
  static std::shared_ptr<spdlog::logger> previous_logger_;
  static TestData* data_;
  static Server* server_;
  static Reference* reference_;
};
std::shared_ptr<CaptureSink> AccessTest::sink_;
std::shared_ptr<spdlog::logger> AccessTest::previous_logger_;
TestData* AccessTest::data_ = nullptr;
Server* AccessTest::server_ = nullptr;
Reference* AccessTest::reference_ = nullptr;

TEST(AccessOpen, WithoutAQueryTokenQueriesAreOpenAndServerAuthAlwaysSucceeds) {
  TestData data;
  RunningServer server(spot_config(data));
  Client c(server.port());
  EXPECT_EQ(c.result("server.health")["auth_required"], false);
  EXPECT_GT(c.result("geodesic.distance", kDistance)["distance"].get<double>(), 0);
  EXPECT_GT(c.result("mesh.list")["meshes"].size(), 0u);
  // A client configured with a token works with an open server too.
  EXPECT_EQ(c.result("server.auth", {{"token", "anything"}}), json({{"authenticated", true}}));
  EXPECT_EQ(c.result("server.auth", {{"token", ""}}), json({{"authenticated", true}}));
  EXPECT_GT(c.result("geodesic.distance", kDistance)["distance"].get<double>(), 0);
}

TEST_F(AccessTest, BeforeServerAuthOnlyHealthIsAnswered) {
  Client c(port());
  const json health = c.result("server.health");
  EXPECT_EQ(health["auth_required"], true);
  EXPECT_EQ(health["status"], "ok");

  const json refused = c.call("geodesic.distance", kDistance);
  ASSERT_TRUE(refused.contains("error")) << refused.dump();
  EXPECT_EQ(refused["error"]["code"], -32040);
  EXPECT_EQ(refused["error"]["data"], json({{"reason", "Unauthorized"}, {"retryable", false}}));
  EXPECT_NE(refused["error"]["message"].get<std::string>().find("server.auth"), std::string::npos);
  // Nothing is looked at before authentication: not the mesh (a face out of range), not even
  // the params (a bad barycentric the parser would refuse).
  EXPECT_EQ(c.error_reason("geodesic.distance",
                           {{"mesh", "spot"}, {"source", "v:0"}, {"target", "f:99999:1:0:0"}}),
            "Unauthorized");
  EXPECT_EQ(c.error_reason("geodesic.distance",
                           {{"mesh", "spot"}, {"source", "v:0"}, {"target", "f:1:2:0:0"}}),
            "Unauthorized");
  EXPECT_EQ(c.error_reason("geodesic.distance", {{"mesh", "nope"}, {"source", "v:0"},
                                                 {"target", "v:1"}}),
            "Unauthorized");
  for (const char* method : {"mesh.list", "server.info", "server.metrics"}) {
    EXPECT_EQ(c.error_reason(method), "Unauthorized") << method;
  }
  EXPECT_EQ(c.error_reason("mesh.info", {{"mesh", "spot"}}), "Unauthorized");
  EXPECT_EQ(c.error_reason("geodesic.field", {{"mesh", "spot"}, {"source", "v:0"}}),
            "Unauthorized");
  EXPECT_EQ(c.error_reason("batch", {{"requests", {{{"method", "geodesic.distance"},
                                                    {"params", kDistance}}}}}),
            "Unauthorized");
  // Lines that are no request of a known method get their usual error: nothing to authorize.
  ASSERT_TRUE(c.send_line("{\"jsonrpc\":\"2.0\",\"id\":7,"));
  EXPECT_EQ(reason_of(c.read_json()), "ParseError");
  EXPECT_EQ(c.error_reason("geodesic.distances", kDistance), "UnknownMethod");
  // A server.auth without a string token is malformed (InvalidParams), not a guess.
  EXPECT_EQ(c.error_reason("server.auth", json::object()), "InvalidParams");
  EXPECT_EQ(c.error_reason("server.auth", {{"token", 42}}), "InvalidParams");
  EXPECT_EQ(c.result("server.health")["auth_required"], true);
  // Still open to authentication afterwards.
  authenticate(c);
  EXPECT_DOUBLE_EQ(c.result("geodesic.distance", kDistance)["distance"].get<double>(),
                   expected_distance());
}

TEST_F(AccessTest, TheRightTokenOpensThatConnectionOnly) {
  Client a(port());
  Client b(port());
  EXPECT_EQ(a.error_reason("server.auth", {{"token", "wrong"}}), "Unauthorized");
  EXPECT_EQ(b.error_reason("server.auth", {{"token", ""}}), "Unauthorized");
  EXPECT_EQ(a.error_reason("server.auth", {{"token", std::string(kQueryToken) + "x"}}),
            "Unauthorized");
  EXPECT_EQ(a.error_reason("server.auth", {{"token", std::string(kQueryToken).substr(1)}}),
            "Unauthorized");
  EXPECT_EQ(a.error_reason("geodesic.distance", kDistance), "Unauthorized");
  authenticate(a);
  EXPECT_DOUBLE_EQ(a.result("geodesic.distance", kDistance)["distance"].get<double>(),
                   expected_distance());
  EXPECT_EQ(a.result("mesh.list")["meshes"][0]["id"], "spot");
  EXPECT_EQ(a.result("server.info")["admin_enabled"], true);
  // The other connection is not opened by a's server.auth, nor is a new one.
  EXPECT_EQ(b.error_reason("geodesic.distance", kDistance), "Unauthorized");
  Client c(port());
  EXPECT_EQ(c.error_reason("mesh.list"), "Unauthorized");
  // The last server.auth decides: a wrong one closes a again.
  EXPECT_EQ(a.error_reason("server.auth", {{"token", "wrong"}}), "Unauthorized");
  EXPECT_EQ(a.error_reason("geodesic.distance", kDistance), "Unauthorized");
}

TEST_F(AccessTest, ARequestPipelinedAfterServerAuthSeesItsOutcome) {
  Client c(port());
  // One write: replies to queries may come out of order, yet each request is checked against
  // the server.auth lines before it.
  std::string lines;
  lines += request_line(1, "geodesic.distance", kDistance);
  lines += request_line(2, "server.auth", {{"token", kQueryToken}});
  lines += request_line(3, "geodesic.distance", kDistance);
  lines += request_line(4, "geodesic.path", kDistance);
  lines += request_line(5, "server.auth", {{"token", "wrong"}});
  lines += request_line(6, "geodesic.distance", kDistance);
  lines += request_line(7, "server.auth", {{"token", kQueryToken}});
  lines += request_line(8, "batch", {{"requests", {{{"method", "geodesic.distance"},
                                                    {"params", kDistance}}}}});
  lines += request_line(9, "geodesic.matrix", {{"mesh", "spot"},
                                               {"sources", {"v:0"}},
                                               {"targets", {"f:100:0.2:0.3:0.5", "v:0"}}});
  ASSERT_TRUE(c.send_raw(lines));
  std::map<int, json> r = replies_by_id(c, 9);
  EXPECT_EQ(reason_of(r[1]), "Unauthorized");
  EXPECT_EQ(r[2]["result"], json({{"authenticated", true}}));
  EXPECT_DOUBLE_EQ(r[3]["result"]["distance"].get<double>(), expected_distance());
  EXPECT_DOUBLE_EQ(r[4]["result"]["distance"].get<double>(), expected_distance());
  EXPECT_EQ(reason_of(r[5]), "Unauthorized");
  EXPECT_EQ(reason_of(r[6]), "Unauthorized");
  EXPECT_EQ(r[7]["result"], json({{"authenticated", true}}));
  ASSERT_EQ(reason_of(r[8]), "result") << r[8].dump();
  EXPECT_DOUBLE_EQ(r[8]["result"]["results"][0]["result"]["distance"].get<double>(),
                   expected_distance());
  ASSERT_EQ(reason_of(r[9]), "result") << r[9].dump();
  EXPECT_DOUBLE_EQ(r[9]["result"]["distances"][0][0].get<double>(), expected_distance());
  EXPECT_EQ(r[9]["result"]["distances"][0][1].get<double>(), 0.0);
  // server.auth is no batch entry: its slot fails, the connection's state does not change.
  const json batch = c.result("batch", {{"requests", {{{"method", "server.auth"},
                                                       {"params", {{"token", "wrong"}}}},
                                                      {{"method", "geodesic.distance"},
                                                       {"params", kDistance}}}}});
  EXPECT_EQ(batch["results"][0]["error"]["data"]["reason"], "InvalidParams");
  EXPECT_DOUBLE_EQ(batch["results"][1]["result"]["distance"].get<double>(), expected_distance());
}

TEST_F(AccessTest, FiveFailedServerAuthCloseTheConnection) {
  {
    // Five wrong tokens in one write, then the right one and a query: the five refusals are
    // written, then the connection is closed; nothing after the fifth is read.
    Client c(port());
    std::string lines;
    for (int i = 1; i <= 5; ++i) {
      lines += request_line(i, "server.auth", {{"token", "guess-" + std::to_string(i)}});
    }
    lines += request_line(6, "server.auth", {{"token", kQueryToken}});
    lines += request_line(7, "geodesic.distance", kDistance);
    ASSERT_TRUE(c.send_raw(lines));
    std::vector<json> replies;
    while (auto line = c.read_line(5s)) replies.push_back(json::parse(*line));
    EXPECT_TRUE(c.eof()) << "the connection is still open";
    ASSERT_EQ(replies.size(), 5u);
    for (int i = 0; i < 5; ++i) {
      EXPECT_EQ(replies[static_cast<std::size_t>(i)]["id"], i + 1);
      EXPECT_EQ(reason_of(replies[static_cast<std::size_t>(i)]), "Unauthorized");
    }
  }
  {
    // The count is per connection and in total: four failures, a success, one more failure.
    Client c(port());
    for (int i = 0; i < 4; ++i) {
      EXPECT_EQ(c.error_reason("server.auth", {{"token", "guess"}}), "Unauthorized");
    }
    authenticate(c);
    EXPECT_DOUBLE_EQ(c.result("geodesic.distance", kDistance)["distance"].get<double>(),
                     expected_distance());
    EXPECT_EQ(c.error_reason("server.auth", {{"token", "guess"}}), "Unauthorized");
    EXPECT_TRUE(c.closed_by_peer());
  }
  // Other connections are not affected.
  Client d(port());
  authenticate(d);
  EXPECT_DOUBLE_EQ(d.result("geodesic.distance", kDistance)["distance"].get<double>(),
                   expected_distance());
}

TEST_F(AccessTest, AdminAndQueryTokensAreSeparate) {
  Client c(port());
  // The admin token does not authenticate a connection...
  EXPECT_EQ(c.error_reason("server.auth", {{"token", kAdminToken}}), "Unauthorized");
  EXPECT_EQ(c.error_reason("geodesic.distance", kDistance), "Unauthorized");
  // ...and admin calls need an authenticated connection as well as the admin token.
  EXPECT_EQ(c.error_reason("admin.reload", {{"token", kAdminToken}}), "Unauthorized");
  authenticate(c);
  // The query token is no admin token.
  EXPECT_EQ(c.error_reason("admin.reload", {{"token", kQueryToken}}), "Unauthorized");
  const json reloaded = c.result("admin.reload", {{"token", kAdminToken}});
  ASSERT_EQ(reloaded["meshes"].size(), 1u);
  EXPECT_EQ(reloaded["meshes"][0]["mesh"], "spot");
  EXPECT_EQ(reloaded["meshes"][0]["reloaded"], false);  // the file did not change
  EXPECT_TRUE(reloaded["meshes"][0]["error"].is_null());
}

TEST_F(AccessTest, TokensNeverReachTheLogsOrTheMetrics) {
  const std::string guess = "guess-5c1d8e0b";
  {
    Client c(port());
    EXPECT_EQ(c.error_reason("geodesic.distance", kDistance), "Unauthorized");
    EXPECT_EQ(c.error_reason("server.auth", {{"token", guess}}), "Unauthorized");
    EXPECT_EQ(c.error_reason("server.auth", {{"token", kAdminToken}}), "Unauthorized");
    EXPECT_EQ(c.error_reason("server.auth", {{"token", guess}, {"extra", guess}}),
              "InvalidParams");
    authenticate(c);
    EXPECT_EQ(c.error_reason("admin.reload", {{"token", guess}}), "Unauthorized");
    EXPECT_EQ(c.result("admin.reload", {{"token", kAdminToken}})["meshes"].size(), 1u);
    // A line cut inside the token: a parse error whose reply is the client's own business.
    ASSERT_TRUE(c.send_line(std::string("{\"jsonrpc\":\"2.0\",\"id\":9,\"method\":\"server.auth\","
                                        "\"params\":{\"token\":\"") +
                            kQueryToken));
    EXPECT_EQ(reason_of(c.read_json()), "ParseError");
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(c.error_reason("server.auth", {{"token", guess}}), "Unauthorized");
    }
    EXPECT_TRUE(c.closed_by_peer());
  }
  spdlog::default_logger()->flush();
  const std::string log = sink_->text();
  // The capture works: the per-request lines and the refusals are there...
  EXPECT_NE(log.find("method=server.auth"), std::string::npos) << log;
  EXPECT_NE(log.find("outcome=Unauthorized"), std::string::npos) << log;
  EXPECT_NE(log.find("server.auth refused (5 of 5 attempts)"), std::string::npos) << log;
  EXPECT_NE(log.find("closed after 5 failed server.auth attempts"), std::string::npos) << log;
  EXPECT_NE(log.find("admin call refused"), std::string::npos) << log;
  // ...and no token is.
  for (const std::string& secret : {std::string(kQueryToken), std::string(kAdminToken), guess}) {
    EXPECT_EQ(log.find(secret), std::string::npos) << secret << " logged:\n" << log;
  }
  const std::string metrics = server_->service().metrics_text();
  EXPECT_NE(metrics.find("method=\"server.auth\",outcome=\"Unauthorized\""), std::string::npos);
  for (const std::string& secret : {std::string(kQueryToken), std::string(kAdminToken), guess}) {
    EXPECT_EQ(metrics.find(secret), std::string::npos) << secret << " in the metrics";
  }
}

TEST(AccessConfig, QueryTokenFromTheFileTheEnvironmentWinsAndMustDifferFromTheAdminToken) {
  const Config from_file =
      parse_config(json{{"query_token", "from-file"}, {"admin_token", "admin"}}, "/tmp");
  EXPECT_EQ(from_file.query_token, "from-file");
  EXPECT_TRUE(parse_config(json::object(), "/tmp").query_token.empty());

  Config config = from_file;
  setenv("GEOPROX_QUERY_TOKEN", "from-env", 1);
  apply_environment(config);
  EXPECT_EQ(config.query_token, "from-env");
  setenv("GEOPROX_QUERY_TOKEN", "", 1);  // empty: the file's value stays
  config = from_file;
  apply_environment(config);
  EXPECT_EQ(config.query_token, "from-file");
  unsetenv("GEOPROX_QUERY_TOKEN");

  auto refusal = [](const json& document) -> std::string {
    try {
      parse_config(document, "/tmp");
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "accepted";
  };
  EXPECT_NE(refusal({{"query_token", "same"}, {"admin_token", "same"}})
                .find("query_token: must differ from admin_token"),
            std::string::npos);
  EXPECT_NE(refusal({{"query_token", 5}}).find("query_token: expected a string"),
            std::string::npos);
  // The environment cannot make them equal either.
  config = from_file;
  setenv("GEOPROX_QUERY_TOKEN", "admin", 1);
  EXPECT_THROW(apply_environment(config), ConfigError);
  unsetenv("GEOPROX_QUERY_TOKEN");
}

}  // namespace
}  // namespace geoprox::server::testing
