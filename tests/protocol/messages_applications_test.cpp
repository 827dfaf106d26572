// Tests of the application methods of protocol/messages (issue 7): geodesic.expmap and
// geodesic.spline params, validation and results.
#include <gtest/gtest.h>

#include "protocol/errors.h"
#include "protocol/messages.h"
#include "tests/protocol/messages_test_support.h"

namespace geoprox::protocol {
namespace {

using nlohmann::json;
using test_support::expect_refused;

TEST(ApplicationMethods, ExpmapParams) {
  const Params parsed = parse_params(
      Method::GeodesicExpmap, json::parse(R"({"mesh":"spot","source":"f:3:0.2:0.3:0.5","radius":0.25})"), {});
  ASSERT_EQ(method_of(parsed), Method::GeodesicExpmap);
  const ExpmapParams& p = std::get<ExpmapParams>(parsed);
  EXPECT_EQ(p.mesh, "spot");
  EXPECT_EQ(p.source, WirePoint::face(3, {0.2, 0.3, 0.5}));
  EXPECT_EQ(p.radius, 0.25);
  EXPECT_FALSE(p.exact);
  expect_refused(Method::GeodesicExpmap, json::parse(R"({"mesh":"spot","source":"v:0"})"),
                 ErrorReason::InvalidParams, "params.radius");
  expect_refused(Method::GeodesicExpmap, json::parse(R"({"mesh":"spot","source":"v:0","radius":0})"),
                 ErrorReason::InvalidParams, "params.radius");
  expect_refused(Method::GeodesicExpmap, json::parse(R"({"mesh":"spot","source":"v:0","radius":"1"})"),
                 ErrorReason::InvalidParams, "params.radius");
  expect_refused(Method::GeodesicExpmap, json::parse(R"({"mesh":"spot","source":"x:0","radius":1})"),
                 ErrorReason::BadPoint, "params.source");
  expect_refused(Method::GeodesicExpmap,
                 json::parse(R"({"mesh":"spot","source":"v:0","radius":1,"radios":2})"),
                 ErrorReason::InvalidParams, "radios");
}

TEST(ApplicationMethods, SplineParams) {
  const Params parsed = parse_params(
      Method::GeodesicSpline,
      json::parse(R"({"mesh":"spot","control":["v:0","v:1","v:2","v:3","v:4"],"type":"bspline","samples":7,"exact":true})"),
      {});
  const SplineParams& p = std::get<SplineParams>(parsed);
  EXPECT_EQ(p.control.size(), 5u);
  EXPECT_EQ(p.type, SplineKind::BSpline);
  EXPECT_EQ(p.samples, 7u);
  EXPECT_TRUE(p.exact);
  const SplineParams defaults = std::get<SplineParams>(parse_params(
      Method::GeodesicSpline, json::parse(R"({"mesh":"spot","control":["v:0","v:1","v:2","v:3"]})"), {}));
  EXPECT_EQ(defaults.type, SplineKind::Bezier);
  EXPECT_EQ(defaults.samples, 100u);
  EXPECT_FALSE(defaults.exact);

  expect_refused(Method::GeodesicSpline,
                 json::parse(R"({"mesh":"spot","control":["v:0","v:1","v:2","v:3","v:4"]})"),
                 ErrorReason::InvalidParams, "needs 3k + 1 points");
  expect_refused(Method::GeodesicSpline,
                 json::parse(R"({"mesh":"spot","control":["v:0","v:1","v:2"],"type":"bspline"})"),
                 ErrorReason::InvalidParams, "needs at least 4 points");
  expect_refused(Method::GeodesicSpline,
                 json::parse(R"({"mesh":"spot","control":["v:0","v:1","v:2","v:3"],"type":"nurbs"})"),
                 ErrorReason::InvalidParams, "params.type");
  expect_refused(Method::GeodesicSpline,
                 json::parse(R"({"mesh":"spot","control":["v:0","v:1","v:2","v:3"],"samples":1})"),
                 ErrorReason::InvalidParams, "params.samples");
  Limits small;
  small.max_points_per_request = 50;
  expect_refused(Method::GeodesicSpline,
                 json::parse(R"({"mesh":"spot","control":["v:0","v:1","v:2","v:3"],"samples":51})"),
                 ErrorReason::InvalidParams, "params.samples", small);
  // Without "samples", a server with a smaller limit than the default asks for that many, and
  // the request written back (what a client sends) is valid under the same limit.
  const json default_under_small = json::parse(R"({"mesh":"spot","control":["v:0","v:1","v:2","v:3"]})");
  const SplineParams clamped =
      std::get<SplineParams>(parse_params(Method::GeodesicSpline, default_under_small, small));
  EXPECT_EQ(clamped.samples, 50u);
  EXPECT_EQ(std::get<SplineParams>(parse_params(Method::GeodesicSpline,
                                                json(Params(clamped)), small)).samples,
            50u);
  json many = json::array();
  for (int i = 0; i < 52; ++i) many.push_back("v:" + std::to_string(i));
  expect_refused(Method::GeodesicSpline, json{{"mesh", "spot"}, {"control", many}},
                 ErrorReason::TooLarge, "params.control", small);
}

TEST(ApplicationMethods, Results) {
  ExpmapResult expmap;
  expmap.mesh = "spot";
  expmap.mesh_version = "v1";
  expmap.source = WirePoint::vertex(0);
  expmap.radius = 0.5;
  expmap.vertices = {0, 4};
  expmap.u = {0.0, 0.25};
  expmap.v = {0.0, -0.5};
  EXPECT_EQ(json(expmap).dump(),
            R"({"count":2,"exact":false,"mesh":"spot","mesh_version":"v1","radius":0.5,)"
            R"("source":{"vertex":0},"u":[0.0,0.25],"v":[0.0,-0.5],"vertices":[0,4]})");
  expmap.v.pop_back();
  EXPECT_THROW(json(expmap).dump(), ProtocolError);

  SplineResult spline;
  spline.mesh = "spot";
  spline.mesh_version = "v1";
  spline.type = SplineKind::BSpline;
  spline.points = {{3, {1, 0, 0}, {1, 2, 3}, std::nullopt}};
  spline.control_polygon = {
      {{3, {1, 0, 0}, {1, 2, 3}, std::nullopt}, {4, {0, 1, 0}, {2, 2, 3}, 17}}};
  EXPECT_EQ(json(spline).dump(),
            R"({"control_polygon":[[{"bary":[1.0,0.0,0.0],"face":3,"position":[1.0,2.0,3.0]},)"
            R"({"bary":[0.0,1.0,0.0],"face":4,"polygon":17,"position":[2.0,2.0,3.0]}]],)"
            R"("exact":false,)"
            R"("mesh":"spot","mesh_version":"v1","points":[{"bary":[1.0,0.0,0.0],"face":3,)"
            R"("position":[1.0,2.0,3.0]}],"type":"bspline"})");
}

}  // namespace
}  // namespace geoprox::protocol
