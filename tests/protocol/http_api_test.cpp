// The HTTP mapping without sockets (protocol/http_api.h): routes, query strings, statuses,
// content negotiation and the binary encodings.
#include "protocol/http_api.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

namespace geoprox::protocol {
namespace {

using nlohmann::json;

TEST(HttpRoute, PathsNameTheirResource) {
  EXPECT_EQ(route_http_path("/v1/rpc").kind, HttpRoute::Kind::Rpc);
  EXPECT_EQ(route_http_path("/v1/meshes").kind, HttpRoute::Kind::MeshList);
  const HttpRoute info = route_http_path("/v1/meshes/spot.v2");
  EXPECT_EQ(info.kind, HttpRoute::Kind::MeshInfo);
  EXPECT_EQ(info.mesh, "spot.v2");
  const HttpRoute field = route_http_path("/v1/meshes/lucy/field");
  EXPECT_EQ(field.kind, HttpRoute::Kind::Query);
  EXPECT_EQ(field.method, Method::GeodesicField);
  EXPECT_EQ(route_http_path("/v1/meshes/lucy/spline").method, Method::GeodesicSpline);
  EXPECT_EQ(route_http_path("/v1/meshes/lucy/geometry").kind, HttpRoute::Kind::Geometry);
  for (const char* unknown : {"/v1", "/v1/", "/v1/meshes/", "/v1/meshes/lucy/",
                              "/v1/meshes/lucy/x", "/v1/meshes/lucy/field/more",
                              "/v1/meshes/-bad/field", "/v1/meshes/a%20b", "/v1/rpc/"}) {
    EXPECT_EQ(route_http_path(unknown).kind, HttpRoute::Kind::Unknown) << unknown;
  }
  // Outside /v1/: the web viewer's files.
  for (const char* file : {"/", "/index.html", "/assets/index-1a2b.js", "/V1/rpc", "/v1x"}) {
    EXPECT_EQ(route_http_path(file).kind, HttpRoute::Kind::Static) << file;
  }
}

TEST(HttpStatic, FilePathsStayInsideTheDirectory) {
  EXPECT_EQ(static_file_path("/"), "index.html");
  EXPECT_EQ(static_file_path("/assets/index-1a2b.js"), "assets/index-1a2b.js");
  EXPECT_EQ(static_file_path("/sub/"), "sub/index.html");
  EXPECT_EQ(static_file_path("/a%20b.png"), "a b.png");
  EXPECT_EQ(static_file_path("/a+b.js"), "a+b.js");  // '+' is a space only in query strings
  for (const char* refused :
       {"", "index.html", "/..", "/../x", "/a/../b", "/./a", "/a/.", "/%2e%2e/x", "/.%2E/x",
        "/a%2fb", "/a%2Fb", "/a%5cb", "/a\\b", "//x", "/a//b", "/a%00b", "/a%0d%0ab", "/a%7f",
        "/%", "/%4", "/%zz"}) {
    try {
      (void)static_file_path(refused);
      ADD_FAILURE() << "accepted " << refused;
    } catch (const ProtocolError& e) {
      EXPECT_EQ(e.reason(), ErrorReason::InvalidRequest) << refused;
    }
  }
  try {
    (void)static_file_path("/assets/.env");
    ADD_FAILURE() << "accepted a hidden file";
  } catch (const ProtocolError& e) {
    EXPECT_EQ(e.reason(), ErrorReason::NotFound);
  }
}

TEST(HttpStatic, ContentTypesAndCacheControl) {
  EXPECT_EQ(static_content_type("index.html"), "text/html; charset=utf-8");
  EXPECT_EQ(static_content_type("assets/index-1a2b.js"), "text/javascript; charset=utf-8");
  EXPECT_EQ(static_content_type("assets/INDEX.CSS"), "text/css; charset=utf-8");
  EXPECT_EQ(static_content_type("a.png"), "image/png");
  EXPECT_EQ(static_content_type("a.svg"), "image/svg+xml");
  EXPECT_EQ(static_content_type("a.json"), "application/json");
  EXPECT_EQ(static_content_type("a.js.map"), "application/json");
  EXPECT_EQ(static_content_type("a.wasm"), "application/wasm");
  EXPECT_EQ(static_content_type("favicon.ico"), "image/x-icon");
  EXPECT_EQ(static_content_type("v1.2/noext"), "application/octet-stream");
  EXPECT_EQ(static_content_type("a.tar.gz"), "application/octet-stream");
  EXPECT_EQ(static_cache_control("index.html"), "no-cache");
  EXPECT_EQ(static_cache_control("assets/index-1a2b.js"), "public, max-age=31536000, immutable");
  EXPECT_EQ(static_cache_control("sub/assets/x.js"), "no-cache");
}

TEST(HttpQuery, QueryStringsBecomeTypedParams) {
  const auto query = parse_query_string(
      "source=p%3A0.1%2C0.2%2C0.3&exact=true&cutoff=1.5e-1"
      "&sources=v:1&sources=v:2&type=bspline&samples=40&&x=a+b");
  ASSERT_EQ(query.size(), 8u);
  EXPECT_EQ(query[0].second, "p:0.1,0.2,0.3");
  EXPECT_EQ(query[7].second, "a b");
  const json params = query_params_object("spot", query);
  EXPECT_EQ(params["mesh"], "spot");
  EXPECT_EQ(params["source"], "p:0.1,0.2,0.3");
  EXPECT_EQ(params["exact"], true);
  EXPECT_EQ(params["cutoff"], 0.15);
  EXPECT_EQ(params["sources"], json::array({"v:1", "v:2"}));
  EXPECT_EQ(params["samples"], 40);
  EXPECT_TRUE(params["samples"].is_number_integer());
  EXPECT_EQ(params["type"], "bspline");
  EXPECT_EQ(params["x"], "a b");  // kept, so that parse_params refuses it by name

  const auto refused = [](std::string_view text) {
    try {
      query_params_object("spot", parse_query_string(text));
    } catch (const ProtocolError& e) {
      EXPECT_EQ(e.reason(), ErrorReason::InvalidParams);
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refused("cutoff=far").find("cutoff"), std::string::npos);
  EXPECT_NE(refused("exact=yes").find("exact"), std::string::npos);
  EXPECT_NE(refused("source=v:0&source=v:1").find("more than once"), std::string::npos);
  EXPECT_NE(refused("mesh=other").find("path"), std::string::npos);
  EXPECT_NE(refused("source=%G0").find("hex"), std::string::npos);
  EXPECT_NE(refused("source=%4").find("hex"), std::string::npos);
}

TEST(HttpStatus, EveryReasonHasAClientOrServerErrorStatus) {
  for (const ErrorReasonInfo& info : error_reasons()) {
    const unsigned status = http_status(info.reason);
    EXPECT_GE(status, 400u) << info.name;
    EXPECT_LT(status, 600u) << info.name;
    // A retryable reason gets a status that balancers and clients retry (429, 503, 504).
    if (info.retryable && info.reason != ErrorReason::Internal) {
      EXPECT_TRUE(status == 429 || status >= 503) << info.name << " " << status;
    }
    if (status < 500) {
      EXPECT_EQ(info.retryable, status == 429) << info.name;
    }
  }
  EXPECT_EQ(http_status(ErrorReason::BadPoint), 400u);
  EXPECT_EQ(http_status(ErrorReason::Unauthorized, false), 401u);
  EXPECT_EQ(http_status(ErrorReason::Unauthorized, true), 403u);
  EXPECT_EQ(http_status(ErrorReason::UnknownMesh), 404u);
  EXPECT_EQ(http_status(ErrorReason::TooLarge), 413u);
  EXPECT_EQ(http_status(ErrorReason::Overloaded), 429u);
  EXPECT_EQ(http_status(ErrorReason::MeshNotReady), 503u);
  EXPECT_EQ(http_status(ErrorReason::DeadlineExceeded), 504u);
}

TEST(HttpNegotiation, AcceptPicksTheFormatByQualityAndSpecificity) {
  EXPECT_EQ(negotiate_format("", true), HttpFormat::Json);
  EXPECT_EQ(negotiate_format("*/*", true), HttpFormat::Json);
  EXPECT_EQ(negotiate_format("application/octet-stream", true), HttpFormat::OctetStream);
  EXPECT_EQ(negotiate_format("application/x-npy, */*;q=0.1", true), HttpFormat::Npy);
  EXPECT_EQ(negotiate_format("application/json;q=0.5, application/x-npy", true), HttpFormat::Npy);
  EXPECT_EQ(negotiate_format("application/*;q=0.2, application/json;q=0", true),
            HttpFormat::OctetStream);
  EXPECT_EQ(negotiate_format("Application/JSON", false), HttpFormat::Json);
  EXPECT_EQ(negotiate_format("application/octet-stream", false), std::nullopt);
  EXPECT_EQ(negotiate_format("image/png", true), std::nullopt);
  EXPECT_EQ(negotiate_format("application/json;q=abc", true), std::nullopt);
  EXPECT_TRUE(accepts_gzip("deflate, gzip;q=0.5"));
  EXPECT_TRUE(accepts_gzip("GZIP"));
  EXPECT_FALSE(accepts_gzip("gzip;q=0, br"));
  EXPECT_FALSE(accepts_gzip(""));
}

TEST(HttpArrays, LittleEndianValuesAndNumpyFiles) {
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<double> values = {0.5, inf, -1.25, std::nan("")};
  const BinaryArray wide = float_array(values, {2, 2}, Dtype::Float64);
  ASSERT_EQ(wide.bytes.size(), 32u);
  double back[4];
  std::memcpy(back, wide.bytes.data(), 32);
  EXPECT_EQ(back[0], 0.5);
  EXPECT_TRUE(std::isnan(back[1]));  // not reached: NaN on the wire
  EXPECT_EQ(back[2], -1.25);
  EXPECT_TRUE(std::isnan(back[3]));
  EXPECT_EQ(static_cast<unsigned char>(wide.bytes[7]), 0x3F);  // 0.5 = 0x3FE0...: little-endian
  const BinaryArray narrow = float_array(values, {4}, Dtype::Float32);
  ASSERT_EQ(narrow.bytes.size(), 16u);
  float f;
  std::memcpy(&f, narrow.bytes.data() + 8, 4);
  EXPECT_EQ(f, -1.25f);
  EXPECT_EQ(shape_header({4}), "4");
  EXPECT_EQ(shape_header({2, 2}), "2,2");

  const std::string npy = encode_npy(uint32_array(std::vector<std::uint32_t>{1, 2, 3}, {3}));
  ASSERT_EQ(npy.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  const std::size_t header =
      static_cast<unsigned char>(npy[8]) + 256u * static_cast<unsigned char>(npy[9]);
  EXPECT_EQ((10 + header) % 64, 0u);
  EXPECT_EQ(npy.substr(10, header),
            std::string("{'descr': '<u4', 'fortran_order': False, 'shape': (3,), }") +
                std::string(header - 58, ' ') + "\n");
  EXPECT_EQ(npy.size(), 10 + header + 12);
  const std::string matrix = encode_npy(float_array(values, {2, 2}, Dtype::Float64));
  EXPECT_NE(matrix.find("'descr': '<f8', 'fortran_order': False, 'shape': (2, 2), }"),
            std::string::npos);
}

TEST(HttpErrors, ErrorBodiesCarryTheJsonRpcErrorObject) {
  const json body = json::parse(
      http_error_body(ProtocolError(ErrorReason::Overloaded, "busy").set_retry_after_ms(250)));
  EXPECT_EQ(body["error"]["code"], -32030);
  EXPECT_EQ(body["error"]["message"], "busy");
  EXPECT_EQ(body["error"]["data"]["reason"], "Overloaded");
  EXPECT_EQ(body["error"]["data"]["retry_after_ms"], 250);
}

}  // namespace
}  // namespace geoprox::protocol
