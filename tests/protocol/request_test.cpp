// decode_request: from one line to a call or to the reply that refuses it, end to end.
#include "protocol/request.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace geoprox::protocol {
namespace {

using nlohmann::json;

Call expect_call(std::string_view line, const Limits& limits = {}) {
  auto decoded = decode_request(line, limits);
  if (auto* rejection = std::get_if<Rejection>(&decoded)) {
    ADD_FAILURE() << "refused " << line << ": " << rejection->error.what();
    throw std::runtime_error("refused");
  }
  return std::get<Call>(std::move(decoded));
}

Rejection expect_rejection(std::string_view line, const Limits& limits = {}) {
  auto decoded = decode_request(line, limits);
  if (!std::holds_alternative<Rejection>(decoded)) {
    ADD_FAILURE() << "accepted " << line;
    throw std::runtime_error("accepted");
  }
  return std::get<Rejection>(std::move(decoded));
}

/// The reply line of a refused request, read back.
ReplyError reply_error(const Rejection& rejection, std::string_view id_text) {
  const std::optional<std::string> line = rejection.reply_line();
  if (!line) {
    ADD_FAILURE() << "no reply line";
    return {};
  }
  EXPECT_EQ(line->find('\n'), line->size() - 1) << *line;
  const Reply reply = parse_reply(*line);
  EXPECT_EQ(reply.id.json_text(), id_text) << *line;
  EXPECT_FALSE(reply.result);
  return reply.error.value_or(ReplyError{});
}

TEST(DecodeRequest, ACall) {
  const Call call = expect_call(
      R"({"jsonrpc":"2.0","id":"r1","method":"geodesic.distance",)"
      R"("params":{"mesh":"spot","source":"v:0","target":{"edge":7,"t":0.25},"timeout_ms":300}})");
  EXPECT_EQ(call.id, RequestId::string("r1"));
  EXPECT_FALSE(call.is_notification());
  EXPECT_EQ(call.method(), Method::GeodesicDistance);
  EXPECT_EQ(call.method_name, "geodesic.distance");
  EXPECT_EQ(call.timeout_ms, 300);
  const auto& params = std::get<DistanceParams>(call.params);
  EXPECT_EQ(params.target, WirePoint::edge(7, 0.25));
}

TEST(DecodeRequest, NotificationsAreCarriedOutButNeverAnswered) {
  const Call call = expect_call(R"({"jsonrpc":"2.0","method":"server.health"})");
  EXPECT_TRUE(call.is_notification());
  EXPECT_EQ(call.method(), Method::ServerHealth);

  const Rejection unknown = expect_rejection(R"({"jsonrpc":"2.0","method":"nope"})");
  EXPECT_EQ(unknown.error.reason(), ErrorReason::UnknownMethod);
  EXPECT_FALSE(unknown.reply_line());
  const Rejection bad_params =
      expect_rejection(R"({"jsonrpc":"2.0","method":"mesh.info","params":{}})");
  EXPECT_EQ(bad_params.error.reason(), ErrorReason::InvalidParams);
  EXPECT_FALSE(bad_params.reply_line());
}

TEST(DecodeRequest, UnknownMethod) {
  const Rejection rejection =
      expect_rejection(R"({"jsonrpc":"2.0","id":4,"method":"geodesic.distances"})");
  const ReplyError error = reply_error(rejection, "4");
  EXPECT_EQ(error.code, -32601);
  EXPECT_EQ(error.reason, "UnknownMethod");
  EXPECT_FALSE(error.retryable);
  EXPECT_EQ(error.message, "unknown method \"geodesic.distances\" (server.info lists the methods)");
  EXPECT_EQ(rejection.method_name, "geodesic.distances");
}

TEST(DecodeRequest, InvalidParamsAndBadPoints) {
  const ReplyError missing = reply_error(
      expect_rejection(
          R"({"jsonrpc":"2.0","id":5,"method":"geodesic.path","params":{"mesh":"spot","source":"v:1"}})"),
      "5");
  EXPECT_EQ(missing.code, -32602);
  EXPECT_EQ(missing.reason, "InvalidParams");
  EXPECT_EQ(missing.message, "params.target is missing");

  const ReplyError bary = reply_error(
      expect_rejection(
          R"({"jsonrpc":"2.0","id":6,"method":"geodesic.distance","params":{"mesh":"spot",)"
          R"("source":"v:1","target":{"face":5,"bary":[0.2,0.3,0.6]}}})"),
      "6");
  EXPECT_EQ(bary.code, -32602);
  EXPECT_EQ(bary.reason, "BadBarycentric");
  EXPECT_EQ(bary.message,
            "params.target: barycentric coordinates sum to 1.1, not 1 (tolerance 1e-5)");
}

TEST(DecodeRequest, EnvelopeErrorsAreAnsweredEvenWithoutAnId) {
  const ReplyError parse = reply_error(expect_rejection("{\"jsonrpc\":"), "null");
  EXPECT_EQ(parse.code, -32700);
  EXPECT_EQ(parse.reason, "ParseError");

  const ReplyError invalid = reply_error(expect_rejection(R"({"method":"server.health"})"), "null");
  EXPECT_EQ(invalid.code, -32600);
  EXPECT_EQ(invalid.reason, "InvalidRequest");
  EXPECT_EQ(invalid.message, "missing member \"jsonrpc\" (must be \"2.0\")");
}

TEST(DecodeRequest, LimitsComeFromTheLimitsStruct) {
  Limits limits;
  limits.max_nesting_depth = 3;
  EXPECT_EQ(
      expect_call(R"({"jsonrpc":"2.0","id":1,"method":"mesh.info","params":{"mesh":"a"}})", limits)
          .method(),
      Method::MeshInfo);
  const ReplyError deep = reply_error(
      expect_rejection(
          R"({"jsonrpc":"2.0","id":1,"method":"geodesic.distance","params":{"source":{"bary":[]}}})",
          limits),
      "1");
  EXPECT_EQ(deep.code, -32020);
  EXPECT_EQ(deep.reason, "TooLarge");
  EXPECT_EQ(deep.message, "JSON nested deeper than the limit of 3 levels");

  limits = {};
  limits.max_points_per_request = 3;
  const ReplyError many = reply_error(
      expect_rejection(R"({"jsonrpc":"2.0","id":2,"method":"geodesic.matrix","params":{"mesh":"a",)"
                       R"("sources":["v:0","v:1"],"targets":["v:2","v:3"]}})",
                       limits),
      "2");
  EXPECT_EQ(many.reason, "TooLarge");
  EXPECT_EQ(many.message,
            "params.sources + params.targets: 4 points exceed the limit of 3 points per request");
}

TEST(DecodeRequest, ABatchAndItsReply) {
  const Call call = expect_call(
      R"({"jsonrpc":"2.0","id":9,"method":"batch","params":{"requests":[)"
      R"({"method":"geodesic.distance","params":{"mesh":"spot","source":"v:0","target":"v:1"}},)"
      R"({"method":"geodesic.distance","params":{"mesh":"spot","source":"v:0","target":"f:9999:1:0:0"}},)"
      R"({"method":"geodesic.distance","params":{"mesh":"spot","source":"v:0","target":"v:x"}}]}})");
  const auto& batch = std::get<BatchParams>(call.params);
  ASSERT_EQ(batch.requests.size(), 3u);

  // What a server does: answer valid entries, keep the errors of the others, in order.
  BatchResult result;
  for (const BatchEntry& entry : batch.requests) {
    if (entry.error) {
      result.results.emplace_back(*entry.error);
    } else if (std::get<DistanceParams>(*entry.params).target.id == 9999) {
      result.results.emplace_back(ProtocolError(ErrorReason::FaceOutOfRange,
                                                "face 9999 is out of range (mesh has 5856 faces)"));
    } else {
      result.results.emplace_back(json(
          DistanceResult{"spot", "v1", 0.5, WirePoint::vertex(0), WirePoint::vertex(1), false}));
    }
  }
  const std::string line = serialize_result(*call.id, result);
  EXPECT_EQ(line.find('\n'), line.size() - 1);
  const Reply reply = parse_reply(line);
  EXPECT_EQ(reply.id.json_text(), "9");
  const json& results = (*reply.result)["results"];
  ASSERT_EQ(results.size(), 3u);
  EXPECT_EQ(results[0]["result"]["distance"], 0.5);
  EXPECT_EQ(results[1]["error"]["data"]["reason"], "FaceOutOfRange");
  EXPECT_EQ(results[2]["error"]["code"], -32602);
  EXPECT_EQ(results[2]["error"]["data"]["reason"], "BadPoint");
}

TEST(DecodeRequest, EveryRefusalLineIsOneLineWhateverTheInput) {
  const std::vector<std::string> lines = {
      "\xFF\xFE",
      std::string("{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"a\\u0000b\"}"),
      std::string("{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"a\\nb\"}"),
      R"({"jsonrpc":"2.0","id":1,"method":"mesh.info","params":{"mesh":"a\nb"}})",
      std::string(5000, '['),
  };
  for (const std::string& line : lines) {
    const Rejection rejection = expect_rejection(line);
    const std::optional<std::string> reply = rejection.reply_line();
    ASSERT_TRUE(reply);
    EXPECT_EQ(reply->find('\n'), reply->size() - 1) << *reply;
    EXPECT_NO_THROW(parse_reply(*reply)) << *reply;
    EXPECT_EQ(std::string(rejection.error.what()).find('\n'), std::string::npos)
        << rejection.error.what();
  }
}

// ---- decode_message: single requests and batch arrays ----

BatchCall expect_batch(std::string_view text, const Limits& limits = {}) {
  auto decoded = decode_message(text, limits);
  if (auto* batch = std::get_if<BatchCall>(&decoded)) return std::move(*batch);
  ADD_FAILURE() << "not a batch: " << text;
  throw std::runtime_error("not a batch");
}

/// The reply line refusing `text` as a whole, read back.
ReplyError whole_refusal(std::string_view text, const Limits& limits = {}) {
  auto decoded = decode_message(text, limits);
  if (auto* rejection = std::get_if<Rejection>(&decoded)) return reply_error(*rejection, "null");
  ADD_FAILURE() << "not refused as a whole: " << text;
  return {};
}

std::string distance(std::string_view id, std::string_view target) {
  std::string request = R"({"jsonrpc":"2.0",)";
  if (!id.empty()) request += R"("id":)" + std::string(id) + ",";
  return request + R"("method":"geodesic.distance","params":{"mesh":"spot","source":"v:0",)" +
         R"("target":")" + std::string(target) + R"("}})";
}

TEST(DecodeMessage, ASingleRequestDecodesAsDecodeRequestDecodesIt) {
  const std::string line = distance("3", "v:1");
  auto decoded = decode_message(line);
  ASSERT_TRUE(std::holds_alternative<Call>(decoded));
  EXPECT_EQ(std::get<Call>(decoded).id, RequestId::number(3));
  EXPECT_EQ(std::get<DistanceParams>(std::get<Call>(decoded).params).target, WirePoint::vertex(1));
  auto refused = decode_message(distance("4", "v:x"));
  ASSERT_TRUE(std::holds_alternative<Rejection>(refused));
  EXPECT_EQ(*std::get<Rejection>(refused).reply_line(),
            *std::get<Rejection>(decode_request(distance("4", "v:x"))).reply_line());
  // decode_request still takes one request object only.
  EXPECT_EQ(expect_rejection("[" + line + "]").error.reason(), ErrorReason::InvalidRequest);
}

TEST(DecodeMessage, MixedValidAndInvalidElementsEachKeepTheirIds) {
  const BatchCall batch = expect_batch(
      "[" + distance("1", "v:1") + "," + distance(R"("two")", "v:x") + ",1," +
      R"({"jsonrpc":"2.0","id":4,"method":"nope"},)" + distance("", "v:2") + "," +
      R"({"jsonrpc":"2.0","id":5.0,"method":"server.health"}])");
  ASSERT_EQ(batch.elements.size(), 6u);
  const Call& first = std::get<Call>(batch.elements[0]);
  EXPECT_EQ(first.id, RequestId::number(1));
  EXPECT_EQ(std::get<DistanceParams>(first.params).target, WirePoint::vertex(1));
  const ReplyError bad_point = reply_error(std::get<Rejection>(batch.elements[1]), "\"two\"");
  EXPECT_EQ(bad_point.reason, "BadPoint");
  const ReplyError not_a_request = reply_error(std::get<Rejection>(batch.elements[2]), "null");
  EXPECT_EQ(not_a_request.reason, "InvalidRequest");
  EXPECT_EQ(not_a_request.message, "a request must be a JSON object, not a number");
  EXPECT_EQ(reply_error(std::get<Rejection>(batch.elements[3]), "4").reason, "UnknownMethod");
  EXPECT_TRUE(std::get<Call>(batch.elements[4]).is_notification());
  EXPECT_EQ(std::get<Call>(batch.elements[5]).id->json_text(), "5.0");

  // The reply: what each element is owed, in order, on one line.
  std::vector<std::string> replies;
  replies.push_back(serialize_result(*first.id, json{{"distance", 0.5}}));
  for (std::size_t i = 1; i < 4; ++i) {
    replies.push_back(*std::get<Rejection>(batch.elements[i]).reply_line());
  }
  const std::string line = serialize_batch_reply(replies);
  ASSERT_EQ(line.find('\n'), line.size() - 1) << line;
  const json parsed = json::parse(line);
  ASSERT_EQ(parsed.size(), 4u);
  EXPECT_EQ(parsed[0]["id"], 1);
  EXPECT_EQ(parsed[0]["result"]["distance"], 0.5);
  EXPECT_EQ(parsed[1]["id"], "two");
  EXPECT_TRUE(parsed[2]["id"].is_null());
  EXPECT_EQ(parsed[3]["error"]["code"], -32601);
}

TEST(DecodeMessage, AllNotificationsOweNothing) {
  const BatchCall batch = expect_batch(
      "[" + distance("", "v:1") + R"(,{"jsonrpc":"2.0","method":"server.health"},)" +
      R"({"jsonrpc":"2.0","method":"nope"}])");
  ASSERT_EQ(batch.elements.size(), 3u);
  EXPECT_TRUE(std::get<Call>(batch.elements[0]).is_notification());
  EXPECT_TRUE(std::get<Call>(batch.elements[1]).is_notification());
  EXPECT_FALSE(std::get<Rejection>(batch.elements[2]).reply_line());
  EXPECT_EQ(serialize_batch_reply({}), "");
  EXPECT_EQ(serialize_batch_reply({"{\"a\":1}\n", "{\"b\":2}"}), "[{\"a\":1},{\"b\":2}]\n");
}

TEST(DecodeMessage, EmptyArrayIsOneInvalidRequest) {
  const ReplyError empty = whole_refusal("[]");
  EXPECT_EQ(empty.code, -32600);
  EXPECT_EQ(empty.reason, "InvalidRequest");
  EXPECT_EQ(empty.message, "empty batch array: a batch array needs at least one request");
  EXPECT_EQ(whole_refusal("[1,2").reason, "ParseError");
}

TEST(DecodeMessage, TooManyElementsOrPointsAreOneTooLarge) {
  Limits limits;
  limits.max_batch_requests = 3;
  const std::string health = R"({"jsonrpc":"2.0","id":1,"method":"server.health"})";
  EXPECT_EQ(expect_batch("[" + health + "," + health + "," + health + "]", limits).elements.size(),
            3u);
  const ReplyError many =
      whole_refusal("[" + health + "," + health + "," + health + ",1]", limits);
  EXPECT_EQ(many.code, -32020);
  EXPECT_EQ(many.reason, "TooLarge");
  EXPECT_EQ(many.message, "batch array: 4 requests exceed max_batch_requests = 3");

  // Points: every call counts, notifications and the entries of a `batch` call included.
  limits = {};
  limits.max_points_per_request = 6;
  const std::string batch_method =
      R"({"jsonrpc":"2.0","id":9,"method":"batch","params":{"requests":[)"
      R"({"method":"geodesic.distance","params":{"mesh":"spot","source":"v:0","target":"v:1"}}]}})";
  EXPECT_EQ(expect_batch("[" + distance("1", "v:1") + "," + distance("", "v:2") + "," +
                             batch_method + "]",
                         limits)
                .elements.size(),
            3u);
  const ReplyError points = whole_refusal(
      "[" + distance("1", "v:1") + "," + distance("", "v:2") + "," + batch_method + "," +
          distance("2", "v:3") + "]",
      limits);
  EXPECT_EQ(points.reason, "TooLarge");
  EXPECT_EQ(points.message,
            "batch array: 8 points exceed the limit of 6 points per request (a batch array "
            "counts all its requests)");
  // Elements that are refused name no points.
  EXPECT_EQ(expect_batch("[" + distance("1", "v:1") + "," + distance("2", "v:x") + "," +
                             distance("3", "v:x") + "," + distance("4", "v:2") + "]",
                         limits)
                .elements.size(),
            4u);
}

TEST(DecodeMessage, TheArrayCountsAsANestingLevel) {
  Limits limits;
  limits.max_nesting_depth = 4;
  // A string point: params are level 3 in an array.
  EXPECT_EQ(expect_batch("[" + distance("1", "v:1") + "]", limits).elements.size(), 1u);
  const std::string object_point =
      R"([{"jsonrpc":"2.0","id":1,"method":"geodesic.distance","params":{"mesh":"spot",)"
      R"("source":"v:0","target":{"face":1,"bary":[1,0,0]}}}])";
  const ReplyError deep = whole_refusal(object_point, limits);
  EXPECT_EQ(deep.reason, "TooLarge");
  EXPECT_EQ(deep.message, "JSON nested deeper than the limit of 4 levels");
  // The same request alone is one level less deep: within the limit.
  EXPECT_EQ(expect_call(object_point.substr(1, object_point.size() - 2), limits).method(),
            Method::GeodesicDistance);
  limits.max_nesting_depth = 5;
  EXPECT_EQ(expect_batch(object_point, limits).elements.size(), 1u);
  EXPECT_EQ(std::get<Call>(expect_batch(object_point, limits).elements[0]).id,
            RequestId::number(1));
}

}  // namespace
}  // namespace geoprox::protocol
