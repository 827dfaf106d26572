// JSON-RPC envelope: every error class with its code and reason, id echo, reply lines.
#include "protocol/json_rpc.h"

#include <gtest/gtest.h>

#include <string>

namespace geoprox::protocol {
namespace {

using nlohmann::json;

Envelope expect_envelope(std::string_view line) {
  auto parsed = parse_envelope(line);
  if (auto* error = std::get_if<EnvelopeError>(&parsed)) {
    ADD_FAILURE() << "unexpected error for " << line << ": " << error->error.what();
    return {};
  }
  return std::get<Envelope>(parsed);
}

/// Expects `line` refused with `reason`, the reply carrying id `id_text`, and the message
/// containing `fragment`.
void expect_refused(std::string_view line, ErrorReason reason, int code, std::string_view id_text,
                    std::string_view fragment, std::size_t max_depth = kDefaultMaxNestingDepth) {
  SCOPED_TRACE(std::string(line.substr(0, 200)));
  auto parsed = parse_envelope(line, max_depth);
  ASSERT_TRUE(std::holds_alternative<EnvelopeError>(parsed)) << "accepted";
  const EnvelopeError& error = std::get<EnvelopeError>(parsed);
  EXPECT_EQ(error.error.reason(), reason) << error.error.what();
  EXPECT_EQ(error.error.code(), code);
  EXPECT_EQ(error.id.json_text(), id_text);
  EXPECT_NE(std::string(error.error.what()).find(fragment), std::string::npos)
      << "message '" << error.error.what() << "' lacks '" << fragment << "'";
  // The reply is one well-formed line whatever the input bytes were.
  const std::string reply = serialize_error(error.id, error.error);
  EXPECT_EQ(reply.find('\n'), reply.size() - 1);
  const Reply read = parse_reply(reply);
  ASSERT_TRUE(read.error);
  EXPECT_EQ(read.error->code, code);
  EXPECT_EQ(read.error->reason, reason_name(reason));
}

TEST(Envelope, ParsesAFullRequest) {
  const Envelope envelope = expect_envelope(
      R"({"jsonrpc":"2.0","id":7,"method":"geodesic.distance","params":{"mesh":"spot"}})");
  ASSERT_TRUE(envelope.id);
  EXPECT_EQ(envelope.id->json_text(), "7");
  EXPECT_FALSE(envelope.is_notification());
  EXPECT_EQ(envelope.method, "geodesic.distance");
  EXPECT_EQ(envelope.params, json({{"mesh", "spot"}}));
}

TEST(Envelope, ParamsDefaultToAnEmptyObjectAndNoIdIsANotification) {
  const Envelope envelope = expect_envelope(R"({"jsonrpc":"2.0","method":"server.health"})");
  EXPECT_TRUE(envelope.is_notification());
  EXPECT_EQ(envelope.params, json::object());
}

TEST(Envelope, EchoesIdsExactly) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"0", "0"},
      {"-12", "-12"},
      {"18446744073709551615", "18446744073709551615"},
      {"-9223372036854775808", "-9223372036854775808"},
      {"123456789012345678901234567890", "123456789012345678901234567890"},
      {"1.50", "1.50"},
      {"1e2", "1e2"},
      {"-0.0", "-0.0"},
      {"2.5E-3", "2.5E-3"},
      {R"("abc")", R"("abc")"},
      {R"("")", R"("")"},
      {R"("é \" \\ \n")", R"("é \" \\ \n")"},
      {R"("\u00e9")", "\"\xC3\xA9\""},  // same JSON string, written without the escape
      {"null", "null"},
  };
  for (const auto& [sent, echoed] : cases) {
    const std::string line = R"({"jsonrpc":"2.0","method":"m","id":)" + sent + "}";
    const Envelope envelope = expect_envelope(line);
    ASSERT_TRUE(envelope.id) << sent;
    EXPECT_EQ(envelope.id->json_text(), echoed) << sent;
    const std::string reply = serialize_result(*envelope.id, json::object());
    EXPECT_EQ(reply, R"({"jsonrpc":"2.0","id":)" + echoed + R"(,"result":{}})" + "\n");
    // The echoed id is the same JSON value as the one sent.
    EXPECT_EQ(json::parse(reply)["id"], json::parse(line)["id"]) << sent;
  }
  EXPECT_TRUE(expect_envelope(R"({"jsonrpc":"2.0","method":"m","id":null})").id->is_null());
  // A number beyond the range of a double is refused by the JSON parser, as everywhere.
  expect_refused(R"({"jsonrpc":"2.0","method":"m","id":1e400})", ErrorReason::ParseError, -32700,
                 "null", "number overflow parsing '1e400'");
}

TEST(Envelope, IdsOfABadTypeAreInvalidRequestsAnsweredWithNull) {
  expect_refused(R"({"jsonrpc":"2.0","method":"m","id":true})", ErrorReason::InvalidRequest, -32600,
                 "null", "member \"id\" must be a number, a string or null, not a boolean");
  expect_refused(R"({"jsonrpc":"2.0","method":"m","id":{"a":1}})", ErrorReason::InvalidRequest,
                 -32600, "null", "not an object");
  expect_refused(R"({"jsonrpc":"2.0","method":"m","id":[1]})", ErrorReason::InvalidRequest, -32600,
                 "null", "not an array");
}

TEST(Envelope, MalformedJsonIsAParseError) {
  expect_refused(R"({"jsonrpc":"2.0","method":)", ErrorReason::ParseError, -32700, "null",
                 "invalid JSON at byte");
  expect_refused("{\"jsonrpc\":\"2.0\"} trailing", ErrorReason::ParseError, -32700, "null",
                 "expected end of input");
  expect_refused("{'jsonrpc':'2.0'}", ErrorReason::ParseError, -32700, "null", "invalid JSON");
  expect_refused(R"({"jsonrpc":"2.0","method":"m","params":{"x":NaN}})", ErrorReason::ParseError,
                 -32700, "null", "invalid JSON");
  expect_refused(R"({"jsonrpc":"2.0","method":"m","params":{"x":Infinity}})",
                 ErrorReason::ParseError, -32700, "null", "invalid JSON");
  expect_refused(R"({"jsonrpc":"2.0","method":"m","params":{"x":1e400}})", ErrorReason::ParseError,
                 -32700, "null", "number overflow");
  expect_refused(R"({"jsonrpc":"2.0","method":"m","params":{"x":"\ud800"}})",
                 ErrorReason::ParseError, -32700, "null", "surrogate");
  expect_refused("", ErrorReason::ParseError, -32700, "null", "unexpected end of input");
}

TEST(Envelope, InvalidUtf8IsAParseErrorNamingTheByte) {
  // Inside a string, outside a string, overlong "/", a UTF-16 surrogate encoded in UTF-8, a
  // truncated sequence at the end of the line.
  expect_refused("{\"jsonrpc\":\"2.0\",\"method\":\"m\xFF\"}", ErrorReason::ParseError, -32700,
                 "null", "not valid UTF-8 (byte 28)");
  expect_refused("{\"jsonrpc\":\"2.0\"\xC3}", ErrorReason::ParseError, -32700, "null",
                 "not valid UTF-8 (byte 16)");
  expect_refused("{\"method\":\"\xC0\xAF\"}", ErrorReason::ParseError, -32700, "null",
                 "not valid UTF-8 (byte 11)");
  expect_refused("{\"method\":\"\xED\xA0\x80\"}", ErrorReason::ParseError, -32700, "null",
                 "not valid UTF-8 (byte 11)");
  expect_refused("{\"method\":\"\xE2\x82", ErrorReason::ParseError, -32700, "null",
                 "not valid UTF-8 (byte 11)");
}

TEST(Envelope, ParseErrorsEchoAnIdReadBeforeTheFailure) {
  expect_refused(R"({"jsonrpc":"2.0","id":41,"method":"m","params":{)", ErrorReason::ParseError,
                 -32700, "41", "invalid JSON");
  expect_refused(R"({"id":"req-9","params":[1,2,)", ErrorReason::ParseError, -32700, R"("req-9")",
                 "invalid JSON");
  // An id nested below the top level is not the request's id.
  expect_refused(R"({"params":{"id":3},"method":)", ErrorReason::ParseError, -32700, "null",
                 "invalid JSON");
}

TEST(Envelope, NestingDeeperThanTheLimitIsTooLarge) {
  const auto nested = [](std::size_t depth) {
    // The request object is level 1, params level 2, then arrays.
    return R"({"jsonrpc":"2.0","id":5,"method":"m","params":{"x":)" + std::string(depth - 2, '[') +
           std::string(depth - 2, ']') + "}}";
  };
  EXPECT_EQ(expect_envelope(nested(64)).method, "m");
  expect_refused(nested(65), ErrorReason::TooLarge, -32020, "5",
                 "nested deeper than the limit of 64 levels");
  expect_refused(nested(10), ErrorReason::TooLarge, -32020, "5", "limit of 9 levels", 9);
  // A million unclosed brackets: refused at level 65, no recursion anywhere.
  const std::string bomb = R"({"id":6,"params":)" + std::string(1'000'000, '[');
  expect_refused(bomb, ErrorReason::TooLarge, -32020, "6", "limit of 64 levels");
  expect_refused(std::string(1'000'000, '{'), ErrorReason::ParseError, -32700, "null",
                 "invalid JSON");
  expect_refused(std::string(1'000'000, '['), ErrorReason::TooLarge, -32020, "null",
                 "limit of 64 levels");
}

TEST(Envelope, JsonThatIsNotARequestIsAnInvalidRequest) {
  // A batch array is not one request (parse_message reads those).
  expect_refused(R"([{"jsonrpc":"2.0","id":1,"method":"m"}])", ErrorReason::InvalidRequest, -32600,
                 "null", "expected one request object, not a batch array");
  expect_refused("[]", ErrorReason::InvalidRequest, -32600, "null", "not a batch array");
  expect_refused("42", ErrorReason::InvalidRequest, -32600, "null",
                 "a request must be a JSON object, not a number");
  expect_refused(R"("geodesic.distance")", ErrorReason::InvalidRequest, -32600, "null",
                 "not a string");
  expect_refused("null", ErrorReason::InvalidRequest, -32600, "null", "not null");
  expect_refused(R"({"id":1,"method":"m"})", ErrorReason::InvalidRequest, -32600, "1",
                 "missing member \"jsonrpc\"");
  expect_refused(R"({"jsonrpc":"1.0","id":1,"method":"m"})", ErrorReason::InvalidRequest, -32600,
                 "1", "member \"jsonrpc\" must be \"2.0\", not \"1.0\"");
  expect_refused(R"({"jsonrpc":2.0,"id":1,"method":"m"})", ErrorReason::InvalidRequest, -32600, "1",
                 "must be \"2.0\", not 2.0");
  expect_refused(R"({"jsonrpc":"2.0","id":1})", ErrorReason::InvalidRequest, -32600, "1",
                 "missing member \"method\"");
  expect_refused(R"({"jsonrpc":"2.0","id":1,"method":5})", ErrorReason::InvalidRequest, -32600, "1",
                 "member \"method\" must be a string, not a number");
  expect_refused(R"({"jsonrpc":"2.0","id":1,"method":""})", ErrorReason::InvalidRequest, -32600,
                 "1", "member \"method\" must not be empty");
  expect_refused(R"({"jsonrpc":"2.0","id":1,"method":"m","params":[1,2]})",
                 ErrorReason::InvalidRequest, -32600, "1",
                 "member \"params\" must be an object (named parameters), not an array");
  expect_refused(R"({"jsonrpc":"2.0","id":1,"method":"m","params":null})",
                 ErrorReason::InvalidRequest, -32600, "1", "not null");
  expect_refused(R"({"jsonrpc":"2.0","id":1,"method":"m","params":"x"})",
                 ErrorReason::InvalidRequest, -32600, "1", "not a string");
  expect_refused(R"({"jsonrpc":"2.0","id":"a","method":"m","deadline":5})",
                 ErrorReason::InvalidRequest, -32600, R"("a")",
                 "unknown member \"deadline\" (a request has jsonrpc, id, method, params)");
}

TEST(Message, ABatchArrayIsParsedElementByElement) {
  auto parsed = parse_message(
      R"([{"jsonrpc":"2.0","id":1.50,"method":"a"},)"
      R"({"jsonrpc":"2.0","method":"b","params":{"x":1}},7,)"
      R"({"jsonrpc":"2.0","id":"s","method":"c","extra":0},)"
      R"({"jsonrpc":"2.0","id":2.5E-3,"method":"d"}])");
  ASSERT_TRUE(std::holds_alternative<EnvelopeBatch>(parsed));
  const auto& elements = std::get<EnvelopeBatch>(parsed).elements;
  ASSERT_EQ(elements.size(), 5u);
  // Fractional ids of elements are echoed as sent, like the id of a single request.
  EXPECT_EQ(std::get<Envelope>(elements[0]).id->json_text(), "1.50");
  EXPECT_EQ(std::get<Envelope>(elements[0]).method, "a");
  EXPECT_TRUE(std::get<Envelope>(elements[1]).is_notification());
  EXPECT_EQ(std::get<Envelope>(elements[1]).params, json({{"x", 1}}));
  const auto& not_an_object = std::get<EnvelopeError>(elements[2]);
  EXPECT_EQ(not_an_object.id.json_text(), "null");
  EXPECT_EQ(not_an_object.error.reason(), ErrorReason::InvalidRequest);
  EXPECT_STREQ(not_an_object.error.what(), "a request must be a JSON object, not a number");
  const auto& unknown_member = std::get<EnvelopeError>(elements[3]);
  EXPECT_EQ(unknown_member.id.json_text(), "\"s\"");
  EXPECT_NE(std::string(unknown_member.error.what()).find("unknown member \"extra\""),
            std::string::npos);
  EXPECT_EQ(std::get<Envelope>(elements[4]).id->json_text(), "2.5E-3");
}

TEST(Message, ASingleObjectIsParsedAsByParseEnvelope) {
  auto parsed = parse_message(R"({"jsonrpc":"2.0","id":1.50,"method":"m"})");
  ASSERT_TRUE(std::holds_alternative<Envelope>(parsed));
  EXPECT_EQ(std::get<Envelope>(parsed).id->json_text(), "1.50");
  auto refused = parse_message(R"({"jsonrpc":"2.0","id":3})");
  ASSERT_TRUE(std::holds_alternative<EnvelopeError>(refused));
  EXPECT_EQ(std::get<EnvelopeError>(refused).id.json_text(), "3");
  EXPECT_STREQ(std::get<EnvelopeError>(refused).error.what(), "missing member \"method\"");
}

TEST(Message, EmptyBrokenOrTooDeepArraysAreOneError) {
  const auto error_of = [](std::string_view text, std::size_t depth = kDefaultMaxNestingDepth) {
    auto parsed = parse_message(text, depth);
    if (auto* error = std::get_if<EnvelopeError>(&parsed)) return *error;
    ADD_FAILURE() << "not refused: " << text;
    return EnvelopeError{RequestId(), ProtocolError(ErrorReason::Internal, "not refused")};
  };
  const EnvelopeError empty = error_of(" [ ] ");
  EXPECT_EQ(empty.error.reason(), ErrorReason::InvalidRequest);
  EXPECT_EQ(empty.id.json_text(), "null");
  EXPECT_STREQ(empty.error.what(), "empty batch array: a batch array needs at least one request");
  const EnvelopeError broken = error_of(R"([{"jsonrpc":"2.0","id":1,"method":"m"},)");
  EXPECT_EQ(broken.error.reason(), ErrorReason::ParseError);
  EXPECT_EQ(broken.id.json_text(), "null");
  // The array is level 1: params of an element are level 3.
  const std::string element = R"({"jsonrpc":"2.0","id":1,"method":"m","params":{}})";
  EXPECT_TRUE(std::holds_alternative<EnvelopeBatch>(parse_message("[" + element + "]", 3)));
  const EnvelopeError deep = error_of("[" + element + "]", 2);
  EXPECT_EQ(deep.error.reason(), ErrorReason::TooLarge);
  EXPECT_STREQ(deep.error.what(), "JSON nested deeper than the limit of 2 levels");
  EXPECT_EQ(error_of("[" + element + "," + element + "," + element + ",[[[]]]]", 3).error.reason(),
            ErrorReason::TooLarge);
}

TEST(Envelope, DuplicateKeysAreRefusedAnywhere) {
  expect_refused(R"({"jsonrpc":"2.0","id":1,"id":2,"method":"m"})", ErrorReason::InvalidRequest,
                 -32600, "1", "duplicate key \"id\"");
  expect_refused(R"({"jsonrpc":"2.0","id":3,"method":"m","params":{"a":1,"a":2}})",
                 ErrorReason::InvalidRequest, -32600, "3", "duplicate key \"a\"");
}

TEST(Replies, ResultLineHasTheMembersInOrderOnOneLine) {
  const std::string line =
      serialize_result(RequestId::number(3), json{{"text", "two\nlines"}, {"n", 1.5}});
  EXPECT_EQ(line,
            "{\"jsonrpc\":\"2.0\",\"id\":3,\"result\":{\"n\":1.5,\"text\":\"two\\nlines\"}}\n");
}

TEST(Replies, ErrorLineCarriesCodeMessageAndData) {
  ProtocolError error(ErrorReason::Overloaded, "queue full");
  error.set_retry_after_ms(40);
  EXPECT_EQ(serialize_error(RequestId::string("q1"), error),
            "{\"jsonrpc\":\"2.0\",\"id\":\"q1\",\"error\":{\"code\":-32030,\"data\":{"
            "\"reason\":\"Overloaded\",\"retry_after_ms\":40,\"retryable\":true},\"message\":"
            "\"queue full\"}}\n");
  EXPECT_EQ(serialize_error(RequestId(), ProtocolError(ErrorReason::ParseError, "bad")),
            "{\"jsonrpc\":\"2.0\",\"id\":null,\"error\":{\"code\":-32700,\"data\":{\"reason\":"
            "\"ParseError\",\"retryable\":false},\"message\":\"bad\"}}\n");
}

TEST(Replies, InvalidUtf8InAMessageIsReplacedNotFatal) {
  const std::string line =
      serialize_error(RequestId::number(1), ProtocolError(ErrorReason::Internal, "bad \xFF byte"));
  EXPECT_NE(line.find("bad \xEF\xBF\xBD byte"), std::string::npos) << line;
  EXPECT_EQ(line.find('\n'), line.size() - 1);
}

TEST(Replies, ParseReplyReadsBackResultsAndErrors) {
  const Reply result = parse_reply(serialize_result(RequestId::string("x"), json{{"a", 1}}));
  EXPECT_EQ(result.id, RequestId::string("x"));
  ASSERT_TRUE(result.result);
  EXPECT_EQ(*result.result, json({{"a", 1}}));
  EXPECT_FALSE(result.error);

  ProtocolError error(ErrorReason::MeshNotReady, "mesh \"bunny\" is building (42%)");
  error.set_retry_after_ms(500);
  const Reply failed = parse_reply(serialize_error(RequestId::number(9), error));
  EXPECT_EQ(failed.id.json_text(), "9");
  EXPECT_FALSE(failed.result);
  ASSERT_TRUE(failed.error);
  EXPECT_EQ(failed.error->code, -32002);
  EXPECT_EQ(failed.error->message, "mesh \"bunny\" is building (42%)");
  EXPECT_EQ(failed.error->reason, "MeshNotReady");
  EXPECT_TRUE(failed.error->retryable);
  EXPECT_EQ(failed.error->retry_after_ms, 500);

  EXPECT_EQ(parse_reply(R"({"jsonrpc":"2.0","id":1.50,"result":null})").id.json_text(), "1.50");
}

TEST(Replies, ParseReplyRefusesWhatIsNotAReply) {
  const auto refused = [](std::string_view line, ErrorReason reason) {
    try {
      parse_reply(line);
      ADD_FAILURE() << "accepted " << line;
    } catch (const ProtocolError& error) {
      EXPECT_EQ(error.reason(), reason) << line << ": " << error.what();
    }
  };
  refused("{", ErrorReason::ParseError);
  refused("[]", ErrorReason::InvalidRequest);
  refused(R"({"jsonrpc":"2.0","result":1})", ErrorReason::InvalidRequest);
  refused(R"({"jsonrpc":"2.0","id":1})", ErrorReason::InvalidRequest);
  refused(R"({"jsonrpc":"2.0","id":1,"result":1,"error":{}})", ErrorReason::InvalidRequest);
  refused(R"({"jsonrpc":"2.0","id":1,"error":{"code":"x","message":"m"}})",
          ErrorReason::InvalidRequest);
  refused(R"({"jsonrpc":"1.0","id":1,"result":1})", ErrorReason::InvalidRequest);
}

TEST(Requests, SerializeRequestWritesOneParsableLine) {
  const std::string line =
      serialize_request(RequestId::number(12), "mesh.info", json{{"mesh", "spot"}});
  EXPECT_EQ(line,
            "{\"jsonrpc\":\"2.0\",\"id\":12,\"method\":\"mesh.info\",\"params\":{\"mesh\":"
            "\"spot\"}}\n");
  const Envelope envelope = expect_envelope(std::string_view(line).substr(0, line.size() - 1));
  EXPECT_EQ(envelope.method, "mesh.info");
  EXPECT_EQ(envelope.id->json_text(), "12");

  const std::string notification = serialize_request(std::nullopt, "server.health");
  EXPECT_EQ(notification, "{\"jsonrpc\":\"2.0\",\"method\":\"server.health\",\"params\":{}}\n");
  EXPECT_TRUE(expect_envelope(notification).is_notification());
}

}  // namespace
}  // namespace geoprox::protocol
