// Points: every object and string form, their canonical output, and every refusal with its reason.
#include "protocol/points.h"

#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "protocol/errors.h"

namespace geoprox::protocol {
namespace {

using nlohmann::json;

WirePoint parsed(const json& value) { return parse_point(value, "params.source"); }

void expect_refused(const json& value, ErrorReason reason, std::string_view fragment) {
  SCOPED_TRACE(value.dump());
  try {
    const WirePoint point = parse_point(value, "params.source");
    ADD_FAILURE() << "accepted as " << to_text(point);
  } catch (const ProtocolError& error) {
    EXPECT_EQ(error.reason(), reason) << error.what();
    EXPECT_EQ(error.code(), -32602) << "bad points are invalid params";
    EXPECT_NE(std::string(error.what()).find(fragment), std::string::npos)
        << "message '" << error.what() << "' lacks '" << fragment << "'";
    EXPECT_TRUE(std::string(error.what()).starts_with("params.source")) << error.what();
  }
}

TEST(Points, ObjectForms) {
  EXPECT_EQ(parsed(json::parse(R"({"vertex": 12})")), WirePoint::vertex(12));
  EXPECT_EQ(parsed(json::parse(R"({"edge": 7, "t": 0.25})")), WirePoint::edge(7, 0.25));
  EXPECT_EQ(parsed(json::parse(R"({"edge": 7, "t": 0})")), WirePoint::edge(7, 0));
  EXPECT_EQ(parsed(json::parse(R"({"edge": 7, "t": 1})")), WirePoint::edge(7, 1));
  EXPECT_EQ(parsed(json::parse(R"({"face": 5, "bary": [0.2, 0.3, 0.5]})")),
            WirePoint::face(5, {0.2, 0.3, 0.5}));
  EXPECT_EQ(parsed(json::parse(R"({"face": 5, "bary": [1, 0, 0]})")),
            WirePoint::face(5, {1, 0, 0}));
  EXPECT_EQ(parsed(json::parse(R"({"sample": 3})")), WirePoint::sample(3));
  EXPECT_EQ(parsed(json::parse(R"({"position": [0.5, -1e-3, 2]})")),
            WirePoint::at_position({0.5, -1e-3, 2}));
  EXPECT_EQ(parsed(json::parse(R"({"vertex": 4294967295})")), WirePoint::vertex(4294967295u));
}

TEST(Points, StringForms) {
  EXPECT_EQ(parsed("v:12"), WirePoint::vertex(12));
  EXPECT_EQ(parsed("e:7:0.25"), WirePoint::edge(7, 0.25));
  EXPECT_EQ(parsed("e:7:1"), WirePoint::edge(7, 1));
  EXPECT_EQ(parsed("e:7:2.5e-1"), WirePoint::edge(7, 0.25));
  EXPECT_EQ(parsed("f:5:0.2:0.3:0.5"), WirePoint::face(5, {0.2, 0.3, 0.5}));
  EXPECT_EQ(parsed("s:3"), WirePoint::sample(3));
  EXPECT_EQ(parsed("p:0.5,-0.001,2"), WirePoint::at_position({0.5, -0.001, 2}));
  EXPECT_EQ(parsed("v:0"), WirePoint::vertex(0));
  EXPECT_EQ(parse_point_text("f:1:1e-400:0.5:0.5"), WirePoint::face(1, {0, 0.5, 0.5}))
      << "underflow reads as 0";
}

TEST(Points, BarycentricTolerances) {
  // Negative down to -1e-12 and a sum off by up to 1e-12 are rounding noise, kept as sent; a
  // sum off by up to 1e-5 covers barycentrics rounded to six decimals, divided by their sum.
  EXPECT_EQ(parsed(json::parse(R"({"face": 0, "bary": [-1e-12, 0.5, 0.500000000001]})")).bary,
            (std::array<double, 3>{-1e-12, 0.5, 0.500000000001}));
  const WirePoint rounded = parsed("f:839813:0.576910:0.407899:0.015192");  // sums to 1.000001
  EXPECT_EQ(rounded.id, 839813u);
  EXPECT_NEAR(rounded.bary[0], 0.576910 / 1.000001, 1e-15);
  EXPECT_NEAR(rounded.bary[0] + rounded.bary[1] + rounded.bary[2], 1, 1e-15);
  // Divided once: written back and parsed again, the same point.
  EXPECT_EQ(parsed(to_text(rounded)), rounded);
  EXPECT_NO_THROW(parsed(json::parse(R"({"face": 0, "bary": [0.3, 0.3, 0.40000999]})")));
  EXPECT_NO_THROW(parsed("f:0:0.3:0.3:0.39999001"));
  expect_refused(json::parse(R"({"face": 0, "bary": [-2e-12, 0.5, 0.500000000002]})"),
                 ErrorReason::BadBarycentric,
                 "barycentric coordinate -2e-12 must be finite and "
                 "non-negative");
  expect_refused(json::parse(R"({"face": 0, "bary": [0.3, 0.3, 0.40002]})"),
                 ErrorReason::BadBarycentric, "sum to 1.00002, not 1 (tolerance 1e-5)");
  expect_refused("f:0:0.2:0.3:0.6", ErrorReason::BadBarycentric, "sum to 1.1, not 1");
  expect_refused("f:0:-0.5:0.5:1", ErrorReason::BadBarycentric, "-0.5");
}

TEST(Points, CanonicalObjectAndTextRoundTripExactly) {
  const double third = 1.0 / 3.0;
  const std::vector<WirePoint> points = {
      WirePoint::vertex(12),
      WirePoint::edge(7, 0.1),
      WirePoint::face(5, {third, third, 1 - 2 * third}),
      WirePoint::sample(3),
      WirePoint::at_position({0.1, -2.5e-300, 1e300}),
  };
  for (const WirePoint& point : points) {
    const json object = point;
    EXPECT_EQ(parsed(object), point) << object.dump();
    EXPECT_EQ(parsed(json::parse(object.dump())), point) << "through text: " << object.dump();
    EXPECT_EQ(parse_point_text(to_text(point)), point) << to_text(point);
  }
  EXPECT_EQ(json(WirePoint::edge(7, 0.25)).dump(), R"({"edge":7,"t":0.25})");
  EXPECT_EQ(json(WirePoint::face(5, {0.2, 0.3, 0.5})).dump(), R"({"bary":[0.2,0.3,0.5],"face":5})");
  EXPECT_EQ(json(WirePoint::vertex(12)).dump(), R"({"vertex":12})");
  EXPECT_EQ(json(WirePoint::sample(3)).dump(), R"({"sample":3})");
  EXPECT_EQ(json(WirePoint::at_position({1, 2, 3})).dump(), R"({"position":[1.0,2.0,3.0]})");
  EXPECT_EQ(to_text(WirePoint::edge(7, 0.25)), "e:7:0.25");
  EXPECT_EQ(to_text(WirePoint::face(5, {0.5, 0.25, 0.25})), "f:5:0.5:0.25:0.25");
  EXPECT_EQ(to_text(WirePoint::at_position({1, -2, 0.5})), "p:1,-2,0.5");
  EXPECT_EQ(to_text(WirePoint::sample(9)), "s:9");
  EXPECT_EQ(to_text(WirePoint::vertex(4294967295u)), "v:4294967295");
}

TEST(Points, MalformedObjectsAreBadPoints) {
  expect_refused(json::object(), ErrorReason::BadPoint, "names no point kind");
  expect_refused(json::parse(R"({"id": 3})"), ErrorReason::BadPoint, "names no point kind");
  expect_refused(json::parse(R"({"vertex": 1, "face": 2})"), ErrorReason::BadPoint,
                 "has both \"vertex\" and \"face\"");
  expect_refused(json::parse(R"({"vertex": 1, "t": 0.5})"), ErrorReason::BadPoint,
                 "params.source: unknown member \"t\" (expected vertex)");
  expect_refused(json::parse(R"({"vertex": -1})"), ErrorReason::BadPoint,
                 "params.source.vertex must be a non-negative integer id, not -1");
  expect_refused(json::parse(R"({"vertex": 1.5})"), ErrorReason::BadPoint,
                 "non-negative integer id, not 1.5");
  expect_refused(json::parse(R"({"vertex": 2.0})"), ErrorReason::BadPoint,
                 "non-negative integer id, not 2.0");
  expect_refused(json::parse(R"({"vertex": "12"})"), ErrorReason::BadPoint,
                 "non-negative integer id, not \"12\"");
  expect_refused(json::parse(R"({"edge": 7})"), ErrorReason::BadPoint,
                 "params.source.t is missing");
  expect_refused(json::parse(R"({"edge": 7, "t": "0.5"})"), ErrorReason::BadPoint,
                 "params.source.t must be a number, not a string");
  expect_refused(json::parse(R"({"edge": null, "t": 0.5})"), ErrorReason::BadPoint,
                 "params.source.edge must be a non-negative integer id, not null");
  expect_refused(json::parse(R"({"face": 5})"), ErrorReason::BadPoint,
                 "params.source.bary is missing");
  expect_refused(json::parse(R"({"face": 5, "bary": [0.5, 0.5]})"), ErrorReason::BadPoint,
                 "params.source.bary must be an array of 3 numbers");
  expect_refused(json::parse(R"({"face": 5, "bary": {"a": 1}})"), ErrorReason::BadPoint,
                 "array of 3 numbers");
  expect_refused(json::parse(R"({"face": 5, "bary": [0.5, "0.5", 0]})"), ErrorReason::BadPoint,
                 "params.source.bary[1] must be a number, not a string");
  expect_refused(json::parse(R"({"position": [1, 2]})"), ErrorReason::BadPoint,
                 "params.source.position must be an array of 3 numbers (x, y, z)");
  expect_refused(json::parse(R"({"position": [1, 2, null]})"), ErrorReason::BadPoint,
                 "params.source.position[2] must be a number, not null");
  expect_refused(json::parse(R"({"sample": true})"), ErrorReason::BadPoint,
                 "params.source.sample must be a non-negative integer id, not true");
  expect_refused(12, ErrorReason::BadPoint, "params.source must be a point, not a number");
  expect_refused(json::parse("[1, 2, 3]"), ErrorReason::BadPoint, "not an array");
  expect_refused(nullptr, ErrorReason::BadPoint, "not null");
}

TEST(Points, IdsBeyond32BitsAreOutOfRangeForTheirKind) {
  expect_refused(json::parse(R"({"vertex": 4294967296})"), ErrorReason::VertexOutOfRange,
                 "params.source.vertex 4294967296 is out of range (ids are below 2^32)");
  expect_refused(json::parse(R"({"edge": 99999999999, "t": 0})"), ErrorReason::EdgeOutOfRange,
                 "99999999999 is out of range");
  expect_refused(json::parse(R"({"face": 4294967296, "bary": [1, 0, 0]})"),
                 ErrorReason::FaceOutOfRange, "out of range");
  expect_refused(json::parse(R"({"sample": 18446744073709551615})"), ErrorReason::SampleOutOfRange,
                 "out of range");
  expect_refused("v:4294967296", ErrorReason::VertexOutOfRange, "4294967296 is out of range");
  expect_refused("f:99999999999999999999999:1:0:0", ErrorReason::FaceOutOfRange, "out of range");
  expect_refused("e:4294967296:0.5", ErrorReason::EdgeOutOfRange, "out of range");
  expect_refused("s:4294967296", ErrorReason::SampleOutOfRange, "out of range");
}

TEST(Points, EdgeParameterOutsideZeroToOne) {
  expect_refused(json::parse(R"({"edge": 7, "t": 1.5})"), ErrorReason::BadEdgeParameter,
                 "edge parameter t = 1.5 must be a finite number in [0, 1]");
  expect_refused(json::parse(R"({"edge": 7, "t": -0.01})"), ErrorReason::BadEdgeParameter,
                 "t = -0.01");
  expect_refused("e:7:1.0000001", ErrorReason::BadEdgeParameter, "t = 1.0000001");
  expect_refused("e:7:nan", ErrorReason::BadEdgeParameter, "t = nan");
  expect_refused("e:7:inf", ErrorReason::BadEdgeParameter, "t = inf");
  expect_refused("e:7:1e999", ErrorReason::BadEdgeParameter, "t = inf");
}

TEST(Points, NonFiniteNumbersAreRefused) {
  // JSON text cannot carry them (the parser refuses 1e400), but documents built in code can.
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  expect_refused(json{{"face", 1}, {"bary", {nan, 0.5, 0.5}}}, ErrorReason::BadBarycentric,
                 "barycentric coordinate nan");
  expect_refused(json{{"face", 1}, {"bary", {inf, 0, 0}}}, ErrorReason::BadBarycentric,
                 "barycentric coordinate inf");
  expect_refused(json{{"edge", 1}, {"t", nan}}, ErrorReason::BadEdgeParameter, "t = nan");
  expect_refused(json{{"position", {0, -inf, 0}}}, ErrorReason::BadPoint,
                 "position coordinate -inf is not finite");
  expect_refused("p:1,1e309,0", ErrorReason::BadPoint, "position coordinate inf is not finite");
  expect_refused("p:nan,0,0", ErrorReason::BadPoint, "nan is not finite");
  expect_refused("f:1:1e308:1e308:1e308", ErrorReason::BadBarycentric, "sum to inf");
}

TEST(Points, MalformedStringsAreBadPoints) {
  expect_refused("", ErrorReason::BadPoint, "unknown kind ''");
  expect_refused("x:1", ErrorReason::BadPoint, "unknown kind 'x'");
  expect_refused("V:1", ErrorReason::BadPoint, "unknown kind 'V'");
  expect_refused("vertex:1", ErrorReason::BadPoint, "unknown kind 'vertex'");
  expect_refused("v", ErrorReason::BadPoint, "kind 'v' takes 1 field after it, not 0");
  expect_refused("v:1:2", ErrorReason::BadPoint, "kind 'v' takes 1 field after it, not 2");
  expect_refused("e:7", ErrorReason::BadPoint, "kind 'e' takes 2 fields after it, not 1");
  expect_refused("f:5:0.2:0.3", ErrorReason::BadPoint, "kind 'f' takes 4 fields");
  expect_refused("s:", ErrorReason::BadPoint, "'' is not a non-negative integer id");
  expect_refused("v:-1", ErrorReason::BadPoint, "'-1' is not a non-negative integer id");
  expect_refused("v:+1", ErrorReason::BadPoint, "'+1' is not a non-negative integer id");
  expect_refused("v: 1", ErrorReason::BadPoint, "' 1' is not a non-negative integer id");
  expect_refused("v:1.0", ErrorReason::BadPoint, "'1.0' is not a non-negative integer id");
  expect_refused("v:0x10", ErrorReason::BadPoint, "'0x10' is not a non-negative integer id");
  expect_refused("e:7:", ErrorReason::BadPoint, "'' is not a number");
  expect_refused("e:7:half", ErrorReason::BadPoint, "'half' is not a number");
  expect_refused("e:7:0.5x", ErrorReason::BadPoint, "'0.5x' is not a number");
  expect_refused("e:7: 0.5", ErrorReason::BadPoint, "' 0.5' is not a number");
  expect_refused("f:5:0.2:0.3:0,5", ErrorReason::BadPoint, "'0,5' is not a number");
  expect_refused("p:1,2", ErrorReason::BadPoint,
                 "a position has 3 comma-separated coordinates, "
                 "not 2");
  expect_refused("p:1,2,3,4", ErrorReason::BadPoint, "not 4");
  expect_refused("p:1;2;3", ErrorReason::BadPoint, "not 1");
  expect_refused("p:1,,3", ErrorReason::BadPoint, "'' is not a number");
  // The message lists the forms, so the client learns the syntax from the error.
  expect_refused("q:1", ErrorReason::BadPoint, "\"v:ID\", \"e:ID:T\"");
}

TEST(Points, LongGarbageIsExcerptedInMessages) {
  const std::string garbage = "v:" + std::string(100000, '9') + "x";
  try {
    parse_point_text(garbage, "params.target");
    FAIL() << "accepted";
  } catch (const ProtocolError& error) {
    EXPECT_EQ(error.reason(), ErrorReason::BadPoint);
    EXPECT_LT(std::string(error.what()).size(), 600u) << error.what();
    EXPECT_TRUE(std::string(error.what()).starts_with("params.target: bad point \"v:999"));
  }
}

}  // namespace
}  // namespace geoprox::protocol
