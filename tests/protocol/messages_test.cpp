// Methods, params validation for every method, limits, and the JSON of every result.
#include "protocol/messages.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <limits>
#include <set>
#include <string>

#include "protocol/base64.h"
#include "tests/protocol/messages_test_support.h"

namespace geoprox::protocol {
namespace {

using nlohmann::json;
using test_support::expect_refused;

constexpr double kInf = std::numeric_limits<double>::infinity();

template <typename T>
T parse_as(Method method, const json& params, const Limits& limits = {},
           std::optional<std::int64_t>* timeout = nullptr) {
  Params parsed = parse_params(method, params, limits, timeout);
  EXPECT_EQ(method_of(parsed), method);
  return std::get<T>(parsed);
}

json points(std::size_t count) {
  json array = json::array();
  for (std::size_t i = 0; i < count; ++i) array.push_back({{"vertex", i}});
  return array;
}

// ---- methods ----

TEST(Methods, NamesRoundTripAndAdminMethodsAreMarked) {
  std::set<std::string_view> names;
  for (Method method : all_methods()) {
    EXPECT_TRUE(names.insert(method_name(method)).second);
    EXPECT_EQ(method_from_name(method_name(method)), method);
  }
  EXPECT_EQ(names,
            (std::set<std::string_view>{
                "geodesic.distance", "geodesic.path", "geodesic.field", "geodesic.matrix", "batch",
                "mesh.list", "mesh.info", "server.info", "server.health", "server.metrics",
                "admin.register", "admin.rebuild", "admin.unregister", "admin.reload",
                "geodesic.expmap", "geodesic.spline", "server.auth"}));
  EXPECT_FALSE(method_from_name("geodesic.Distance"));
  EXPECT_FALSE(method_from_name("rpc.discover"));
  for (Method method : all_methods()) {
    EXPECT_EQ(is_admin_method(method), method_name(method).starts_with("admin."));
  }
}

TEST(Methods, OnlyHealthAndAuthAreAllowedBeforeAuthentication) {
  std::set<Method> open;
  for (Method method : all_methods()) {
    if (allowed_before_auth(method)) open.insert(method);
  }
  EXPECT_EQ(open, (std::set<Method>{Method::ServerHealth, Method::ServerAuth}));
}

TEST(Methods, MeshIds) {
  for (std::string_view good : {"spot", "bunny-2", "a.b_c", "0", "Z9"}) {
    EXPECT_TRUE(is_valid_mesh_id(good)) << good;
  }
  EXPECT_TRUE(is_valid_mesh_id(std::string(128, 'm')));
  for (std::string_view bad :
       {"", ".hidden", "-x", "_x", "a/b", "..", "a b", "caf\xC3\xA9", "a\\b", "a:b"}) {
    EXPECT_FALSE(is_valid_mesh_id(bad)) << bad;
  }
  EXPECT_FALSE(is_valid_mesh_id(std::string(129, 'm')));
}

TEST(Limits, TimeoutIsClampedNotRefused) {
  Limits limits;
  EXPECT_EQ(limits.effective_timeout_ms(std::nullopt), 10'000);
  EXPECT_EQ(limits.effective_timeout_ms(250), 250);
  EXPECT_EQ(limits.effective_timeout_ms(3'600'000), 60'000);
  EXPECT_EQ(json(limits), json::parse(R"({"max_line_bytes":1048576,"max_nesting_depth":64,
      "max_points_per_request":10000,"max_matrix_pairs":1000000,"max_field_sources":1000,
      "max_batch_requests":1000,"max_output_bytes":67108864,"default_timeout_ms":10000,
      "max_timeout_ms":60000})"));
}

// ---- params of every method ----

TEST(DistanceParamsTest, Parses) {
  std::optional<std::int64_t> timeout;
  const auto params = parse_as<DistanceParams>(
      Method::GeodesicDistance,
      json::parse(R"({"mesh":"spot","source":{"vertex":0},"target":"f:5:0.2:0.3:0.5",
                      "exact":true,"timeout_ms":250})"),
      {}, &timeout);
  EXPECT_EQ(params.mesh, "spot");
  EXPECT_EQ(params.source, WirePoint::vertex(0));
  EXPECT_EQ(params.target, WirePoint::face(5, {0.2, 0.3, 0.5}));
  EXPECT_TRUE(params.exact);
  EXPECT_EQ(timeout, 250);

  const auto plain = parse_as<DistanceParams>(
      Method::GeodesicDistance, json::parse(R"({"mesh":"spot","source":"v:1","target":"v:2"})"), {},
      &timeout);
  EXPECT_FALSE(plain.exact);
  EXPECT_FALSE(timeout);
}

TEST(DistanceParamsTest, Refusals) {
  const json good = json::parse(R"({"mesh":"spot","source":"v:1","target":"v:2"})");
  const auto with = [&](const std::string& key, const json& value) {
    json params = good;
    params[key] = value;
    return params;
  };
  const auto without = [&](const std::string& key) {
    json params = good;
    params.erase(key);
    return params;
  };
  const Method m = Method::GeodesicDistance;
  expect_refused(m, without("mesh"), ErrorReason::InvalidParams, "params.mesh is missing");
  expect_refused(m, without("source"), ErrorReason::InvalidParams, "params.source is missing");
  expect_refused(m, without("target"), ErrorReason::InvalidParams, "params.target is missing");
  expect_refused(m, with("mesh", 5), ErrorReason::InvalidParams,
                 "params.mesh must be a string, not a number");
  expect_refused(m, with("mesh", "../etc"), ErrorReason::InvalidParams,
                 "params.mesh \"../etc\" is not a mesh id");
  expect_refused(m, with("mesh", ""), ErrorReason::InvalidParams, "is not a mesh id");
  expect_refused(m, with("source", "v:x"), ErrorReason::BadPoint, "params.source: bad point");
  expect_refused(m, with("target", json::parse(R"({"face":1,"bary":[0.5,0.5,0.5]})")),
                 ErrorReason::BadBarycentric, "params.target: barycentric coordinates sum to 1.5");
  expect_refused(m, with("target", json::parse(R"({"edge":1,"t":2})")),
                 ErrorReason::BadEdgeParameter, "params.target: edge parameter t = 2");
  expect_refused(m, with("exact", "yes"), ErrorReason::InvalidParams,
                 "params.exact must be true or false, not a string");
  expect_refused(m, with("max_distance", 1), ErrorReason::InvalidParams,
                 "params: unknown member \"max_distance\" (expected mesh, source, target, exact, "
                 "timeout_ms)");
  for (const json& bad : {json(0), json(-5), json(1.5), json("100"), json(nullptr)}) {
    expect_refused(
        m, with("timeout_ms", bad), ErrorReason::InvalidParams,
        "params.timeout_ms must be an integer from 1 to 9223372036854775807, not " + bad.dump());
  }
  expect_refused(m, json::array(), ErrorReason::InvalidParams,
                 "params must be an object, not an array");
}

TEST(PathParamsTest, ParsesAndRefuses) {
  const auto params = parse_as<PathParams>(
      Method::GeodesicPath,
      json::parse(R"({"mesh":"spot","source":{"sample":4},"target":{"position":[0,1,2]}})"));
  EXPECT_EQ(params.mesh, "spot");
  EXPECT_EQ(params.source, WirePoint::sample(4));
  EXPECT_EQ(params.target, WirePoint::at_position({0, 1, 2}));
  expect_refused(Method::GeodesicPath,
                 json::parse(R"({"mesh":"spot","source":"v:1","target":"v:2","exact":true})"),
                 ErrorReason::InvalidParams, "unknown member \"exact\"");
  expect_refused(Method::GeodesicPath, json::parse(R"({"mesh":"spot","source":"v:1"})"),
                 ErrorReason::InvalidParams, "params.target is missing");
}

TEST(FieldParamsTest, ParsesOneOrSeveralSources) {
  const auto one = parse_as<FieldParams>(Method::GeodesicField,
                                         json::parse(R"({"mesh":"spot","source":"v:0"})"));
  EXPECT_EQ(one.sources, std::vector<WirePoint>{WirePoint::vertex(0)});
  EXPECT_FALSE(one.cutoff);
  EXPECT_EQ(one.encoding, FieldEncoding::Json);

  const auto several = parse_as<FieldParams>(
      Method::GeodesicField,
      json::parse(R"({"mesh":"spot","sources":["v:0",{"edge":3,"t":0.5}],"cutoff":0.25,
                      "encoding":"f32le-base64"})"));
  EXPECT_EQ(several.sources,
            (std::vector<WirePoint>{WirePoint::vertex(0), WirePoint::edge(3, 0.5)}));
  EXPECT_EQ(several.cutoff, 0.25);
  EXPECT_EQ(several.encoding, FieldEncoding::F32leBase64);
  EXPECT_EQ(
      parse_as<FieldParams>(Method::GeodesicField,
                            json::parse(R"({"mesh":"spot","source":"v:0","encoding":"json"})"))
          .encoding,
      FieldEncoding::Json);
  EXPECT_EQ(parse_as<FieldParams>(
                Method::GeodesicField,
                json::parse(R"({"mesh":"spot","source":"v:0","encoding":"f64le-base64"})"))
                .encoding,
            FieldEncoding::F64leBase64);
}

TEST(MatrixParamsTest, EncodingIsJsonOrF64) {
  const Method m = Method::GeodesicMatrix;
  EXPECT_EQ(parse_as<MatrixParams>(m, json::parse(R"({"mesh":"spot","sources":["v:0"],
                                                      "targets":["v:1"]})"))
                .encoding,
            FieldEncoding::Json);
  EXPECT_EQ(parse_as<MatrixParams>(m, json::parse(R"({"mesh":"spot","sources":["v:0"],
                                      "targets":["v:1"],"encoding":"f64le-base64"})"))
                .encoding,
            FieldEncoding::F64leBase64);
  expect_refused(m, json::parse(R"({"mesh":"spot","sources":["v:0"],"targets":["v:1"],
                                    "encoding":"f32le-base64"})"),
                 ErrorReason::InvalidParams,
                 "params.encoding must be \"json\" or \"f64le-base64\", not \"f32le-base64\"");
}

TEST(FieldParamsTest, Refusals) {
  const Method m = Method::GeodesicField;
  expect_refused(m, json::parse(R"({"mesh":"spot"})"), ErrorReason::InvalidParams,
                 "params.source (or params.sources) is missing");
  expect_refused(m, json::parse(R"({"mesh":"spot","source":"v:0","sources":["v:1"]})"),
                 ErrorReason::InvalidParams, "both given");
  expect_refused(m, json::parse(R"({"mesh":"spot","sources":[]})"), ErrorReason::InvalidParams,
                 "params.sources must not be empty");
  expect_refused(m, json::parse(R"({"mesh":"spot","sources":"v:0"})"), ErrorReason::InvalidParams,
                 "params.sources must be an array of points, not a "
                 "string");
  expect_refused(m, json::parse(R"({"mesh":"spot","sources":["v:0","f:1:1:1:1"]})"),
                 ErrorReason::BadBarycentric, "params.sources[1]: barycentric");
  expect_refused(m, json::parse(R"({"mesh":"spot","sources":["v:0",7]})"), ErrorReason::BadPoint,
                 "params.sources[1] must be a point, not a number");
  for (const char* cutoff : {"0", "-1", "\"1\"", "null"}) {
    expect_refused(
        m, json::parse(std::string(R"({"mesh":"spot","source":"v:0","cutoff":)") + cutoff + "}"),
        ErrorReason::InvalidParams,
        std::string("params.cutoff must be a finite number > 0, not ") + cutoff);
  }
  expect_refused(m, json::parse(R"({"mesh":"spot","source":"v:0","encoding":"binary"})"),
                 ErrorReason::InvalidParams,
                 "params.encoding must be \"json\", \"f32le-base64\" or \"f64le-base64\", "
                 "not \"binary\"");
  expect_refused(m, json::parse(R"({"mesh":"spot","source":"v:0","max_distance":1})"),
                 ErrorReason::InvalidParams, "unknown member \"max_distance\"");
}

TEST(FieldParamsTest, SourceLimits) {
  Limits limits;
  limits.max_field_sources = 3;
  json params = {{"mesh", "spot"}, {"sources", points(3)}};
  EXPECT_EQ(parse_as<FieldParams>(Method::GeodesicField, params, limits).sources.size(), 3u);
  params["sources"] = points(4);
  expect_refused(Method::GeodesicField, params, ErrorReason::TooLarge,
                 "params.sources: 4 points exceed max_field_sources = 3", limits);
  limits.max_field_sources = 100;
  limits.max_points_per_request = 2;
  params["sources"] = points(3);
  expect_refused(Method::GeodesicField, params, ErrorReason::TooLarge,
                 "params.sources: 3 points exceed the limit of 2 points per request", limits);
}

TEST(MatrixParamsTest, ParsesAndRefuses) {
  const auto params = parse_as<MatrixParams>(
      Method::GeodesicMatrix,
      json::parse(R"({"mesh":"spot","sources":["v:0","v:1"],"targets":["s:2","e:1:0.5","v:9"]})"));
  EXPECT_EQ(params.sources.size(), 2u);
  EXPECT_EQ(params.targets, (std::vector<WirePoint>{WirePoint::sample(2), WirePoint::edge(1, 0.5),
                                                    WirePoint::vertex(9)}));
  const Method m = Method::GeodesicMatrix;
  expect_refused(m, json::parse(R"({"mesh":"spot","sources":["v:0"]})"), ErrorReason::InvalidParams,
                 "params.targets is missing");
  expect_refused(m, json::parse(R"({"mesh":"spot","sources":[],"targets":["v:0"]})"),
                 ErrorReason::InvalidParams, "params.sources must not be empty");
  expect_refused(m, json::parse(R"({"mesh":"spot","sources":["v:0"],"targets":{"vertex":1}})"),
                 ErrorReason::InvalidParams, "params.targets must be an array of points");
  expect_refused(m, json::parse(R"({"mesh":"spot","sources":["v:0"],"targets":["v:0","z"]})"),
                 ErrorReason::BadPoint, "params.targets[1]: bad point \"z\"");
}

TEST(MatrixParamsTest, PairAndPointLimitsComeBeforeParsingPoints) {
  Limits limits;
  limits.max_matrix_pairs = 6;
  json params = {{"mesh", "spot"}, {"sources", points(2)}, {"targets", points(3)}};
  EXPECT_EQ(parse_as<MatrixParams>(Method::GeodesicMatrix, params, limits).targets.size(), 3u);
  params["sources"] = json::array({"garbage", "garbage", "garbage"});
  expect_refused(Method::GeodesicMatrix, params, ErrorReason::TooLarge,
                 "params: 3 x 3 pairs exceed max_matrix_pairs = 6", limits);
  limits.max_matrix_pairs = 1'000'000;
  limits.max_points_per_request = 5;
  expect_refused(Method::GeodesicMatrix, params, ErrorReason::TooLarge,
                 "params.sources + params.targets: 6 points exceed the limit of 5", limits);
}

TEST(BatchParamsTest, EntriesParseOrFailOneByOne) {
  const json params = json::parse(R"({"requests":[
      {"method":"geodesic.distance","params":{"mesh":"spot","source":"v:0","target":"v:1",
                                              "timeout_ms":50}},
      {"method":"geodesic.distance","params":{"mesh":"spot","source":"v:0","target":"f:1:2:0:0"}},
      {"method":"geodesic.nope"},
      {"method":"batch","params":{"requests":[]}},
      {"method":"admin.reload","params":{"token":"t"}},
      {"method":"mesh.list"},
      [1,2],
      {"method":"mesh.info","params":{"mesh":"spot"},"id":3},
      {"method":"mesh.info","params":[]}
    ],"timeout_ms":500})");
  std::optional<std::int64_t> timeout;
  const auto batch = parse_as<BatchParams>(Method::Batch, params, {}, &timeout);
  EXPECT_EQ(timeout, 500);
  ASSERT_EQ(batch.requests.size(), 9u);

  const BatchEntry& first = batch.requests[0];
  ASSERT_TRUE(first.params);
  EXPECT_FALSE(first.error);
  EXPECT_EQ(first.method, "geodesic.distance");
  EXPECT_EQ(std::get<DistanceParams>(*first.params).target, WirePoint::vertex(1));
  EXPECT_EQ(first.timeout_ms, 50);

  const auto expect_entry_error = [&](std::size_t index, ErrorReason reason,
                                      std::string_view fragment) {
    const BatchEntry& entry = batch.requests[index];
    EXPECT_FALSE(entry.params) << index;
    ASSERT_TRUE(entry.error) << index;
    EXPECT_EQ(entry.error->reason(), reason) << entry.error->what();
    EXPECT_NE(std::string(entry.error->what()).find(fragment), std::string::npos)
        << "entry " << index << ": '" << entry.error->what() << "' lacks '" << fragment << "'";
  };
  expect_entry_error(1, ErrorReason::BadBarycentric,
                     "params.requests[1]: params.target: barycentric coordinates sum to 2");
  expect_entry_error(2, ErrorReason::UnknownMethod,
                     "params.requests[2].method: unknown method \"geodesic.nope\"");
  expect_entry_error(3, ErrorReason::InvalidParams, "\"batch\" cannot be batched");
  expect_entry_error(4, ErrorReason::InvalidParams, "\"admin.reload\" cannot be batched");
  EXPECT_TRUE(batch.requests[5].params);
  EXPECT_TRUE(std::holds_alternative<MeshListParams>(*batch.requests[5].params));
  expect_entry_error(6, ErrorReason::InvalidParams,
                     "params.requests[6] must be an object, not an array");
  expect_entry_error(7, ErrorReason::InvalidParams,
                     "params.requests[7]: unknown member \"id\" (expected method, params)");
  expect_entry_error(8, ErrorReason::InvalidParams,
                     "params.requests[8].params must be an object, not an array");
}

TEST(BatchParamsTest, WholeBatchRefusals) {
  const Method m = Method::Batch;
  expect_refused(m, json::object(), ErrorReason::InvalidParams, "params.requests is missing");
  expect_refused(m, json::parse(R"({"requests":[]})"), ErrorReason::InvalidParams,
                 "params.requests must not be empty");
  expect_refused(m, json::parse(R"({"requests":{"method":"mesh.list"}})"),
                 ErrorReason::InvalidParams, "params.requests must be an array");
  Limits limits;
  limits.max_batch_requests = 2;
  expect_refused(m, json::parse(R"({"requests":[{"method":"mesh.list"},{"method":"mesh.list"},
                                                {"method":"mesh.list"}]})"),
                 ErrorReason::TooLarge, "params.requests: 3 requests exceed max_batch_requests = 2",
                 limits);
  limits = {};
  limits.max_points_per_request = 3;
  const json two_distances = json::parse(R"({"requests":[
      {"method":"geodesic.distance","params":{"mesh":"a","source":"v:0","target":"v:1"}},
      {"method":"geodesic.distance","params":{"mesh":"a","source":"v:0","target":"v:1"}}]})");
  expect_refused(m, two_distances, ErrorReason::TooLarge,
                 "params.requests: 4 points exceed the limit of 3 points per request", limits);
}

TEST(RegistryParams, MeshListInfoAndServerMethods) {
  for (Method method :
       {Method::MeshList, Method::ServerInfo, Method::ServerHealth, Method::ServerMetrics}) {
    EXPECT_EQ(method_of(parse_params(method, json::object(), {})), method);
    std::optional<std::int64_t> timeout;
    parse_params(method, json{{"timeout_ms", 5}}, {}, &timeout);
    EXPECT_EQ(timeout, 5);
    expect_refused(method, json{{"mesh", "spot"}}, ErrorReason::InvalidParams,
                   "params: unknown member \"mesh\" (expected timeout_ms)");
  }
  EXPECT_EQ(parse_as<MeshInfoParams>(Method::MeshInfo, json{{"mesh", "spot"}}).mesh, "spot");
  expect_refused(Method::MeshInfo, json::object(), ErrorReason::InvalidParams,
                 "params.mesh is missing");
}

TEST(ServerAuthParamsTest, AnyStringIsATokenAndMessagesNeverQuoteIt) {
  EXPECT_EQ(parse_as<ServerAuthParams>(Method::ServerAuth, json{{"token", "s3cret"}}).token,
            "s3cret");
  // Empty and odd tokens parse: whether they match is the server's (constant-time) answer.
  EXPECT_EQ(parse_as<ServerAuthParams>(Method::ServerAuth, json{{"token", ""}}).token, "");
  EXPECT_EQ(parse_as<ServerAuthParams>(Method::ServerAuth, json{{"token", "a\"b\n\u00e9"}}).token,
            "a\"b\n\u00e9");
  std::optional<std::int64_t> timeout;
  parse_as<ServerAuthParams>(Method::ServerAuth, json{{"token", "t"}, {"timeout_ms", 7}}, {},
                             &timeout);
  EXPECT_EQ(timeout, 7);
  const auto refusal = [](const json& params) -> std::string {
    try {
      parse_params(Method::ServerAuth, params, {});
    } catch (const ProtocolError& error) {
      EXPECT_EQ(error.reason(), ErrorReason::InvalidParams) << error.what();
      return error.what();
    }
    ADD_FAILURE() << "accepted " << params.dump();
    return "";
  };
  EXPECT_EQ(refusal(json::object()), "params.token is missing");
  EXPECT_EQ(refusal(json{{"token", 12345}}), "params.token must be a string, not a number");
  EXPECT_EQ(refusal(json{{"token", json::array({"s3cret"})}}),
            "params.token must be a string, not an array");
  const std::string extra = refusal(json{{"token", "s3cret"}, {"tokne", "s3cret"}});
  EXPECT_NE(extra.find("unknown member \"tokne\" (expected token, timeout_ms)"), std::string::npos)
      << extra;
  EXPECT_EQ(extra.find("s3cret"), std::string::npos) << extra;
  // Never inside a batch: authentication belongs to the connection, in line order.
  const auto batch = parse_as<BatchParams>(
      Method::Batch, json::parse(R"({"requests":[{"method":"server.auth","params":{"token":"t"}}]})"));
  ASSERT_EQ(batch.requests.size(), 1u);
  ASSERT_TRUE(batch.requests[0].error);
  EXPECT_EQ(batch.requests[0].error->reason(), ErrorReason::InvalidParams);
  EXPECT_NE(std::string(batch.requests[0].error->what()).find("\"server.auth\" cannot be batched"),
            std::string::npos)
      << batch.requests[0].error->what();
}

TEST(AdminParams, Register) {
  const auto params = parse_as<AdminRegisterParams>(
      Method::AdminRegister,
      json::parse(R"({"token":"s3cret","mesh":"bunny","mesh_file":"meshes/bunny.obj",
                      "graph_file":"graphs/bunny.geoprox",
                      "build":{"samples":1300,"neighbors":22,"sampling":"exact"}})"));
  EXPECT_EQ(params.token, "s3cret");
  EXPECT_EQ(params.mesh, "bunny");
  EXPECT_EQ(params.mesh_file, "meshes/bunny.obj");
  EXPECT_EQ(params.graph_file, "graphs/bunny.geoprox");
  EXPECT_EQ(params.build, (BuildOptions{1300, 22, SamplingMethod::Exact}));
  EXPECT_FALSE(params.repair);

  const auto repaired = parse_as<AdminRegisterParams>(
      Method::AdminRegister,
      json::parse(R"({"token":"t","mesh":"pig","mesh_file":"meshes/pig.stl","repair":true})"));
  EXPECT_TRUE(repaired.repair);

  const auto minimal = parse_as<AdminRegisterParams>(
      Method::AdminRegister, json::parse(R"({"token":"t","mesh":"b","mesh_file":"b..c.obj"})"));
  EXPECT_FALSE(minimal.graph_file);
  EXPECT_EQ(minimal.build, BuildOptions{});
  EXPECT_EQ(minimal.mesh_file, "b..c.obj") << "'..' inside a name is not a parent directory";

  const Method m = Method::AdminRegister;
  expect_refused(m, json::parse(R"({"mesh":"b","mesh_file":"b.obj"})"), ErrorReason::Unauthorized,
                 "admin methods need params.token");
  expect_refused(m, json::parse(R"({"token":"","mesh":"b","mesh_file":"b.obj"})"),
                 ErrorReason::Unauthorized, "params.token");
  expect_refused(m, json::parse(R"({"token":7,"mesh":"b","mesh_file":"b.obj"})"),
                 ErrorReason::Unauthorized, "params.token");
  for (const char* path : {"../etc/passwd", "meshes/../../x.obj", "a/..", ".."}) {
    expect_refused(m, json{{"token", "t"}, {"mesh", "b"}, {"mesh_file", path}},
                   ErrorReason::PathNotAllowed,
                   std::string("params.mesh_file \"") + path + "\" contains a '..' component");
  }
  expect_refused(m, json{{"token", "t"}, {"mesh", "b"}, {"mesh_file", ""}},
                 ErrorReason::PathNotAllowed, "params.mesh_file \"\" is empty");
  expect_refused(m, json{{"token", "t"}, {"mesh", "b"}, {"mesh_file", std::string("a\0b", 3)}},
                 ErrorReason::PathNotAllowed, "params.mesh_file \"a\\x00b\" contains a NUL byte");
  expect_refused(m, json{{"token", "t"}, {"mesh", "b"}, {"mesh_file", "..\\x.obj"}},
                 ErrorReason::PathNotAllowed, "contains a backslash");
  expect_refused(
      m,
      json{{"token", "t"}, {"mesh", "b"}, {"mesh_file", "b.obj"}, {"graph_file", "../b.geoprox"}},
      ErrorReason::PathNotAllowed, "params.graph_file");
  expect_refused(m, json::parse(R"({"token":"t","mesh":"b","mesh_file":"b.obj",
                                    "build":{"sampling":"fast"}})"),
                 ErrorReason::InvalidParams,
                 "params.build.sampling must be \"fmm\", \"exact\" or \"auto\", not \"fast\"");
  expect_refused(m, json::parse(R"({"token":"t","mesh":"b","mesh_file":"b.obj",
                                    "build":{"samples":0}})"),
                 ErrorReason::InvalidParams,
                 "params.build.samples must be an integer from 1 to 4294967295, not 0");
  expect_refused(m, json::parse(R"({"token":"t","mesh":"b","mesh_file":"b.obj",
                                    "build":{"radius":2}})"),
                 ErrorReason::InvalidParams,
                 "params.build: unknown member \"radius\" (expected samples, neighbors, sampling)");
  expect_refused(m, json::parse(R"({"token":"t","mesh":"b","mesh_file":"b.obj","repair":"yes"})"),
                 ErrorReason::InvalidParams, "params.repair must be true or false, not a string");
  expect_refused(m, json::parse(R"({"token":"t","mesh":"b","mesh_file":"b.obj",
                                    "build":{"repair":true}})"),
                 ErrorReason::InvalidParams, "params.build: unknown member \"repair\"");
  expect_refused(m, json::parse(R"({"token":"t","mesh":"b c","mesh_file":"b.obj"})"),
                 ErrorReason::InvalidParams, "is not a mesh id");
}

TEST(AdminParams, RebuildUnregisterReload) {
  const auto rebuild = parse_as<AdminRebuildParams>(
      Method::AdminRebuild, json::parse(R"({"token":"t","mesh":"b","build":{"neighbors":30}})"));
  EXPECT_EQ(rebuild.mesh, "b");
  EXPECT_EQ(rebuild.build.neighbors, 30u);
  EXPECT_FALSE(rebuild.build.samples);

  EXPECT_EQ(parse_as<AdminUnregisterParams>(Method::AdminUnregister,
                                            json::parse(R"({"token":"t","mesh":"b"})"))
                .mesh,
            "b");
  expect_refused(Method::AdminUnregister, json::parse(R"({"token":"t"})"),
                 ErrorReason::InvalidParams, "params.mesh is missing");
  expect_refused(Method::AdminUnregister, json::parse(R"({"mesh":"b"})"), ErrorReason::Unauthorized,
                 "params.token");

  EXPECT_FALSE(
      parse_as<AdminReloadParams>(Method::AdminReload, json::parse(R"({"token":"t"})")).mesh);
  EXPECT_EQ(
      parse_as<AdminReloadParams>(Method::AdminReload, json::parse(R"({"token":"t","mesh":"b"})"))
          .mesh,
      "b");
  expect_refused(Method::AdminReload, json::object(), ErrorReason::Unauthorized, "params.token");
}

TEST(ParamsJson, WhatClientsSendReadsBackTheSame) {
  const std::vector<std::pair<Method, std::string>> canonical = {
      {Method::GeodesicDistance,
       R"({"exact":true,"mesh":"spot","source":{"vertex":0},"target":{"bary":[0.2,0.3,0.5],"face":5}})"},
      {Method::GeodesicPath,
       R"({"mesh":"spot","source":{"sample":1},"target":{"edge":2,"t":0.5}})"},
      {Method::GeodesicField, R"({"encoding":"json","mesh":"spot","source":{"vertex":0}})"},
      {Method::GeodesicField,
       R"({"cutoff":0.5,"encoding":"f32le-base64","mesh":"spot","sources":[{"vertex":0},{"position":[1.0,2.0,3.0]}]})"},
      {Method::GeodesicMatrix,
       R"({"mesh":"spot","sources":[{"vertex":0}],"targets":[{"vertex":1},{"vertex":2}]})"},
      {Method::Batch,
       R"({"requests":[{"method":"mesh.info","params":{"mesh":"spot","timeout_ms":20}},{"method":"server.health","params":{}}]})"},
      {Method::MeshList, "{}"},
      {Method::MeshInfo, R"({"mesh":"spot"})"},
      {Method::ServerInfo, "{}"},
      {Method::ServerHealth, "{}"},
      {Method::ServerMetrics, "{}"},
      {Method::ServerAuth, R"({"token":"t"})"},
      {Method::AdminRegister,
       R"({"build":{"neighbors":22,"sampling":"auto","samples":100},"graph_file":"g/b.geoprox","mesh":"b","mesh_file":"m/b.obj","token":"t"})"},
      {Method::AdminRegister, R"({"mesh":"b","mesh_file":"m/b.obj","repair":true,"token":"t"})"},
      {Method::AdminRebuild, R"({"build":{"sampling":"fmm"},"mesh":"b","token":"t"})"},
      {Method::AdminUnregister, R"({"mesh":"b","token":"t"})"},
      {Method::AdminReload, R"({"mesh":"b","token":"t"})"},
      {Method::AdminReload, R"({"token":"t"})"},
      {Method::GeodesicExpmap, R"({"exact":true,"mesh":"spot","radius":0.5,"source":{"vertex":0}})"},
      {Method::GeodesicSpline,
       R"({"control":[{"vertex":0},{"vertex":1},{"vertex":2},{"vertex":3}],"mesh":"spot","samples":100,"type":"bspline"})"},
  };
  std::set<Method> covered;
  for (const auto& [method, text] : canonical) {
    const json params = json::parse(text);
    EXPECT_EQ(json(parse_params(method, params, {})), params) << text;
    covered.insert(method);
  }
  EXPECT_EQ(covered.size(), all_methods().size());
}

// ---- results ----

TEST(Results, Distance) {
  const DistanceResult result{"spot",
                              "f95506b621abc471",
                              0.28976291167503254,
                              WirePoint::vertex(0),
                              WirePoint::face(100, {0.2, 0.3, 0.5}),
                              true};
  EXPECT_EQ(json(result).dump(), R"({"distance":0.28976291167503254,"exact":true,"mesh":"spot",)"
                                 R"("mesh_version":"f95506b621abc471","source":{"vertex":0},)"
                                 R"("target":{"bary":[0.2,0.3,0.5],"face":100}})");
  DistanceResult unreachable = result;
  unreachable.distance = kInf;
  try {
    json out = unreachable;
    FAIL() << "serialized " << out.dump();
  } catch (const ProtocolError& error) {
    EXPECT_EQ(error.reason(), ErrorReason::Internal);
    EXPECT_NE(std::string(error.what()).find("Unreachable error"), std::string::npos);
  }
}

TEST(Results, Path) {
  PathResult result{"spot",
                    "v1",
                    1.5,
                    WirePoint::vertex(0),
                    WirePoint::vertex(7),
                    false,
                    {{3, {1, 0, 0}, {0.5, 1, 2}, std::nullopt}, {4, {0, 0.25, 0.75}, {1, 1, 1}, std::nullopt}}};
  EXPECT_EQ(json(result), json::parse(R"({"mesh":"spot","mesh_version":"v1","distance":1.5,
      "source":{"vertex":0},"target":{"vertex":7},"exact":false,
      "points":[{"face":3,"bary":[1.0,0.0,0.0],"position":[0.5,1.0,2.0]},
                {"face":4,"bary":[0.0,0.25,0.75],"position":[1.0,1.0,1.0]}]})"));
  result.distance = std::nan("");
  EXPECT_THROW(json{result}, ProtocolError);
}

TEST(Results, FieldAsJson) {
  FieldResult result{"spot", "v1", FieldEncoding::Json, 0.5, {0, 0.25, kInf, 0.5}, {}};
  EXPECT_EQ(json(result), json::parse(R"({"mesh":"spot","mesh_version":"v1","encoding":"json",
      "vertices":4,"reached":3,"cutoff":0.5,"distances":[0.0,0.25,null,0.5]})"));
  result.nearest_source = {0, 1, FieldResult::kNotReached, 1};
  result.cutoff.reset();
  EXPECT_EQ(json(result), json::parse(R"({"mesh":"spot","mesh_version":"v1","encoding":"json",
      "vertices":4,"reached":3,"cutoff":null,"distances":[0.0,0.25,null,0.5],
      "nearest_source":[0,1,null,1]})"));
  result.nearest_source.pop_back();
  EXPECT_THROW(json{result}, ProtocolError);
}

TEST(Results, FieldAsBase64) {
  const std::vector<double> distances = {0, 0.1, kInf, 1e-3, 12.5};
  FieldResult result{"spot",       "v1",      FieldEncoding::F32leBase64,
                     std::nullopt, distances, {0, 2, FieldResult::kNotReached, 1, 0}};
  const json out = result;
  EXPECT_EQ(out["encoding"], "f32le-base64");
  EXPECT_EQ(out["vertices"], 5);
  EXPECT_EQ(out["reached"], 4);
  const std::vector<float> decoded = decode_f32le_base64(out["distances"].get<std::string>());
  ASSERT_EQ(decoded.size(), distances.size());
  for (std::size_t i = 0; i < distances.size(); ++i) {
    EXPECT_EQ(decoded[i], static_cast<float>(distances[i])) << i;
  }
  EXPECT_EQ(decode_u32le_base64(out["nearest_source"].get<std::string>()),
            (std::vector<std::uint32_t>{0, 2, 0xFFFFFFFF, 1, 0}));
}

TEST(Results, FieldFastPathWritesTheSameBytes) {
  std::vector<double> distances;
  for (int i = 0; i < 1001; ++i) distances.push_back(i % 7 == 3 ? kInf : 0.001 * i + 1.0 / 3);
  std::vector<std::uint32_t> nearest;
  for (int i = 0; i < 1001; ++i) nearest.push_back(i % 7 == 3 ? FieldResult::kNotReached : i % 3);
  for (FieldEncoding encoding :
       {FieldEncoding::F32leBase64, FieldEncoding::F64leBase64, FieldEncoding::Json}) {
    for (bool several_sources : {false, true}) {
      for (std::optional<double> cutoff : {std::optional<double>(), std::optional<double>(0.75)}) {
        const FieldResult result{
            "m\"x\u00e9", "v\n1",    encoding,
            cutoff,       distances, several_sources ? nearest : std::vector<std::uint32_t>{}};
        const RequestId id = RequestId::string("f-1");
        const std::string fast = serialize_field_result(id, result);
        EXPECT_EQ(fast, serialize_result(id, json(result)))
            << encoding_name(encoding) << " several " << several_sources;
        EXPECT_EQ(fast.find('\n'), fast.size() - 1);
      }
    }
  }
  FieldResult bad{"m", "v", FieldEncoding::F32leBase64, std::nullopt, {1, 2}, {0}};
  EXPECT_THROW(serialize_field_result(RequestId(), bad), ProtocolError);
}

TEST(Results, FieldAsF64Base64IsTheJsonNumbersBitForBit) {
  const std::vector<double> distances = {0, 0.1, kInf, 1.0 / 3.0, 12.5, 5e-324};
  FieldResult result{"spot",       "v1",      FieldEncoding::F64leBase64,
                     std::nullopt, distances, {0, 2, FieldResult::kNotReached, 1, 0, 1}};
  const json out = json::parse(field_result_object(result));
  EXPECT_EQ(out["encoding"], "f64le-base64");
  EXPECT_EQ(out["vertices"], 6);
  EXPECT_EQ(out["reached"], 5);
  result.encoding = FieldEncoding::Json;
  const json as_json = json::parse(field_result_object(result));
  const std::vector<double> decoded = decode_f64le_base64(out["distances"].get<std::string>());
  ASSERT_EQ(decoded.size(), distances.size());
  for (std::size_t i = 0; i < distances.size(); ++i) {
    if (as_json["distances"][i].is_null()) {
      EXPECT_EQ(decoded[i], kInf) << i;  // not reached: null in JSON, +inf here
    } else {
      EXPECT_EQ(std::bit_cast<std::uint64_t>(decoded[i]),
                std::bit_cast<std::uint64_t>(as_json["distances"][i].get<double>()))
          << i;
    }
  }
  EXPECT_EQ(decode_u32le_base64(out["nearest_source"].get<std::string>()),
            (std::vector<std::uint32_t>{0, 2, 0xFFFFFFFF, 1, 0, 1}));
}

TEST(Results, MatrixAsF64Base64IsRowMajorWithInfWhereUnreachable) {
  MatrixResult result{"spot", "v1", 2, 3, {0, 0.1, 2.0 / 3.0, 3, kInf, 5}};
  result.encoding = FieldEncoding::F64leBase64;
  const json out = json::parse(dump_one_line(json(result)));
  EXPECT_EQ(out["encoding"], "f64le-base64");
  EXPECT_EQ(out["sources"], 2);
  EXPECT_EQ(out["targets"], 3);
  EXPECT_EQ(out["unreachable"], 1);
  result.encoding = FieldEncoding::Json;
  const json as_json = json::parse(dump_one_line(json(result)));
  EXPECT_FALSE(as_json.contains("encoding"));  // JSON replies stay as they were
  const std::vector<double> decoded = decode_f64le_base64(out["distances"].get<std::string>());
  ASSERT_EQ(decoded.size(), 6u);
  for (std::size_t s = 0; s < 2; ++s) {
    for (std::size_t t = 0; t < 3; ++t) {
      const json& number = as_json["distances"][s][t];
      const double value = decoded[s * 3 + t];
      if (number.is_null()) {
        EXPECT_EQ(value, kInf);
      } else {
        EXPECT_EQ(std::bit_cast<std::uint64_t>(value),
                  std::bit_cast<std::uint64_t>(number.get<double>()));
      }
    }
  }
}

TEST(Results, MatrixKeepsUnreachablePairsExplicit) {
  MatrixResult result{"spot", "v1", 2, 3, {0, 1, 2, 3, kInf, 5}};
  EXPECT_EQ(json(result), json::parse(R"({"mesh":"spot","mesh_version":"v1","sources":2,
      "targets":3,"unreachable":1,"distances":[[0.0,1.0,2.0],[3.0,null,5.0]]})"));
  result.distances.pop_back();
  EXPECT_THROW(json{result}, ProtocolError);
}

TEST(Results, MeshListAndInfo) {
  MeshSummary ready{"spot", "f95506b621abc471", MeshState::Ready, 1.0, std::nullopt, 2930, 5856,
                    1300,   std::nullopt};
  MeshSummary building{"bunny", std::nullopt, MeshState::Building, 0.42,        "local solves",
                       34834,   69451,        std::nullopt,        std::nullopt};
  MeshSummary failed{"broken", std::nullopt, MeshState::Failed,
                     0,        std::nullopt, 0,
                     0,        std::nullopt, "broken.obj: non-manifold edge 12 [NonManifoldEdge]"};
  EXPECT_EQ(json(MeshListResult{{ready, building, failed}}), json::parse(R"({"meshes":[
      {"id":"spot","mesh_version":"f95506b621abc471","state":"ready","progress":1.0,
       "phase":null,"vertices":2930,"faces":5856,"samples":1300,"error":null},
      {"id":"bunny","mesh_version":null,"state":"building","progress":0.42,
       "phase":"local solves","vertices":34834,"faces":69451,"samples":null,"error":null},
      {"id":"broken","mesh_version":null,"state":"failed","progress":0.0,"phase":null,
       "vertices":0,"faces":0,"samples":null,
       "error":"broken.obj: non-manifold edge 12 [NonManifoldEdge]"}]})"));

  MeshInfoResult info{ready,
                      8784,
                      30268,
                      "meshes/spot.obj",
                      "graphs/spot.geoprox",
                      BuildOptions{1300, 22, SamplingMethod::Fmm},
                      0.070697,
                      0.248016,
                      std::nullopt,
                      std::nullopt,
                      std::nullopt};
  EXPECT_EQ(json(info), json::parse(R"({"mesh":"spot","mesh_version":"f95506b621abc471",
      "state":"ready","progress":1.0,"phase":null,"vertices":2930,"faces":5856,"samples":1300,
      "error":null,"edges":8784,"graph_edges":30268,"mesh_file":"meshes/spot.obj",
      "graph_file":"graphs/spot.geoprox","build":{"samples":1300,"neighbors":22,
      "sampling":"fmm"},"covering_radius":0.070697,"link_radius":0.248016,"polygons":null,
      "repair":null,"refined":null})"));
  EXPECT_EQ(json(ready)["mesh"], "spot") << "admin.register/rebuild answer a summary with mesh";

  // A mesh loaded with repair, from a file with polygons: both facts, every count by name.
  info.polygons = 5000;
  info.repair = MeshRepairCounts{2930, 5857, 2935, 5856, 0, 1, 2, 3, 4, 5};
  const json repaired = info;
  EXPECT_EQ(repaired["polygons"], 5000);
  EXPECT_EQ(repaired["repair"], json::parse(R"({"vertices_in":2930,"faces_in":5857,
      "vertices_out":2935,"faces_out":5856,"degenerate_faces_dropped":0,
      "duplicate_faces_dropped":1,"edges_cut":2,"faces_flipped":3,"vertices_split":4,
      "vertices_added":5})"));
  // A graph over a refinement of the mesh: its counts and edge limit.
  info.refined = MeshRefinement{16130, 32256, 0.346921};
  EXPECT_EQ(json(info)["refined"],
            json::parse(R"({"vertices":16130,"faces":32256,"max_edge_length":0.346921})"));
}

TEST(Results, ServerInfoHealthMetrics) {
  Limits limits;
  limits.max_batch_requests = 10;
  const json info = ServerInfoResult{"0.1.0", limits, false};
  EXPECT_EQ(info["protocol_version"], 1);
  EXPECT_EQ(info["server_version"], "0.1.0");
  EXPECT_EQ(info["limits"], json(limits));
  EXPECT_EQ(info["limits"]["max_batch_requests"], 10);
  EXPECT_EQ(info["encodings"], json::parse(R"(["json","f32le-base64","f64le-base64"])"));
  EXPECT_EQ(info["methods"].size(), all_methods().size());
  EXPECT_EQ(info["methods"][0], "geodesic.distance");
  EXPECT_EQ(info["admin_enabled"], false);

  EXPECT_EQ(json(HealthResult{HealthStatus::Ok, 2, 3, 12.5, 4}),
            json::parse(R"({"status":"ok","ready":true,"meshes_ready":2,"meshes_total":3,
                            "uptime_seconds":12.5,"in_flight":4,"auth_required":false})"));
  EXPECT_EQ(json(HealthResult{HealthStatus::Ok, 2, 3, 12.5, 4, true})["auth_required"], true);
  EXPECT_EQ(json(ServerAuthResult{}), json::parse(R"({"authenticated":true})"));
  EXPECT_EQ(json(HealthResult{HealthStatus::Draining, 3, 3, 1, 0})["ready"], false);
  EXPECT_EQ(json(HealthResult{HealthStatus::Starting, 0, 3, 1, 0})["status"], "starting");
  EXPECT_EQ(json(MetricsResult{"geoprox_requests_total 3\n"}),
            json::parse(R"({"format":"prometheus-text-0.0.4",
                            "text":"geoprox_requests_total 3\n"})"));
}

TEST(Results, AdminAndBatch) {
  EXPECT_EQ(json(AdminUnregisterResult{"b"}), json::parse(R"({"mesh":"b","unregistered":true})"));
  AdminReloadResult reload{
      {{"spot", true, "abc", std::nullopt},
       {"bunny", false, "old", ProtocolError(ErrorReason::BadMeshFile, "checksum mismatch")}}};
  EXPECT_EQ(json(reload), json::parse(R"({"meshes":[
      {"mesh":"spot","reloaded":true,"mesh_version":"abc","error":null},
      {"mesh":"bunny","reloaded":false,"mesh_version":"old","error":{"code":-32005,
       "message":"checksum mismatch","data":{"reason":"BadMeshFile","retryable":false}}}]})"));

  BatchResult batch;
  batch.results.emplace_back(json{{"distance", 1.0}});
  batch.results.emplace_back(
      ProtocolError(ErrorReason::FaceOutOfRange, "face 9999 is out of range"));
  EXPECT_EQ(json(batch), json::parse(R"({"results":[{"result":{"distance":1.0}},
      {"error":{"code":-32602,"message":"face 9999 is out of range",
                "data":{"reason":"FaceOutOfRange","retryable":false}}}]})"));
}

}  // namespace
}  // namespace geoprox::protocol
