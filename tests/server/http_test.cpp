// The HTTP API over real sockets (docs/http.md): resource paths answer what the TCP methods
// answer, binary arrays equal the JSON ones, every bad input gets its status, keep-alive and
// pipelining, slow senders, the bearer token, CORS, gzip, HEAD, metrics by transport, drain;
// the web viewer's files at "/" (types, cache headers, nothing from outside their directory).
#include <zlib.h>

#include <cmath>
#include <cstring>

#include "tests/server/server_test_support.h"

namespace geoprox::server::testing {
namespace {

/// A port nobody listens on now (the kernel's pick), for a server that needs a fixed one.
std::uint16_t free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  socklen_t len = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  ::close(fd);
  return ntohs(addr.sin_port);
}

struct HttpResponse {
  int status = 0;
  std::map<std::string, std::string> headers;  ///< names lower-cased
  std::string body;

  std::string header(const std::string& name) const {
    const auto it = headers.find(name);
    return it == headers.end() ? "" : it->second;
  }
  json json_body() const { return json::parse(body); }
};

std::string lower(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

/// An HTTP/1.1 client on one connection (keep-alive), reading Content-Length responses.
class HttpClient {
 public:
  explicit HttpClient(std::uint16_t port) : client_(port) {}

  bool send_raw(std::string_view bytes) { return client_.send_raw(bytes); }

  void send(const std::string& method, const std::string& target, const std::string& body = "",
            const std::vector<std::string>& headers = {}) {
    std::string request = method + " " + target + " HTTP/1.1\r\nHost: localhost\r\n";
    for (const std::string& h : headers) request += h + "\r\n";
    if (!body.empty() || method == "POST") {
      bool typed = false;
      for (const std::string& h : headers) typed = typed || lower(h).starts_with("content-type");
      if (!typed) request += "Content-Type: application/json\r\n";
      request += "Content-Length: " + std::to_string(body.size()) + "\r\n";
    }
    request += "\r\n" + body;
    ASSERT_TRUE(client_.send_raw(request));
  }

  /// The next response; `head`: a response to HEAD (no body whatever Content-Length says).
  HttpResponse read(bool head = false) {
    HttpResponse r;
    const auto status_line = client_.read_line();
    if (!status_line) throw std::runtime_error("no response");
    r.status = std::stoi(status_line->substr(9, 3));
    for (;;) {
      auto line = client_.read_line();
      if (!line) throw std::runtime_error("headers cut");
      if (!line->empty() && line->back() == '\r') line->pop_back();
      if (line->empty()) break;
      const auto colon = line->find(':');
      r.headers[lower(line->substr(0, colon))] = line->substr(colon + 2);
    }
    const std::string length_header = r.header("content-length");
    const std::size_t length = head || length_header.empty() ? 0 : std::stoul(length_header);
    r.body = client_.read_bytes(length);
    return r;
  }

  HttpResponse request(const std::string& method, const std::string& target,
                       const std::string& body = "", const std::vector<std::string>& headers = {}) {
    send(method, target, body, headers);
    return read(method == "HEAD");
  }
  bool closed_by_peer() { return client_.closed_by_peer(); }

 private:
  Client client_;
};

double as_distance(const json& value) {
  return value.is_null() ? std::numeric_limits<double>::quiet_NaN() : value.get<double>();
}

template <typename T>
std::vector<T> decode_le(const std::string& bytes) {
  std::vector<T> out(bytes.size() / sizeof(T));
  std::memcpy(out.data(), bytes.data(), out.size() * sizeof(T));  // the test host is little-endian
  return out;
}

std::string gunzip(const std::string& data) {
  z_stream stream{};
  EXPECT_EQ(inflateInit2(&stream, 15 + 16), Z_OK);
  std::string out(data.size() * 20 + 1024, '\0');
  stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  stream.avail_in = static_cast<uInt>(data.size());
  stream.next_out = reinterpret_cast<Bytef*>(out.data());
  stream.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(inflate(&stream, Z_FINISH), Z_STREAM_END);
  out.resize(stream.total_out);
  inflateEnd(&stream);
  return out;
}

Config http_config(const TestData& data) {
  Config config = spot_config(data);
  config.http_port = free_port();
  config.admin_port = free_port();
  config.http_static_dir = fs::path();  // no viewer, whatever the source tree holds
  return config;
}

class HttpTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = new TestData();
    Config config = http_config(*data_);
    config.http_cors_origins = {"https://viewer.example"};
    config.server_limits.http_request_timeout_ms = 400;
    server_ = new RunningServer(config);
  }
  static void TearDownTestSuite() {
    delete server_;
    delete data_;
  }
  static std::uint16_t http_port() { return server_->server->http_port(); }
  static TestData* data_;
  static RunningServer* server_;
};
TestData* HttpTest::data_ = nullptr;
RunningServer* HttpTest::server_ = nullptr;

TEST_F(HttpTest, ResourcePathsAnswerWhatTheTcpMethodsAnswer) {
  Client tcp(server_->port());
  HttpClient http(http_port());
  const json distance = tcp.result(
      "geodesic.distance", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "f:100:0.2:0.3:0.5"}});
  HttpResponse get =
      http.request("GET", "/v1/meshes/spot/distance?source=v%3A0&target=f:100:0.2:0.3:0.5");
  ASSERT_EQ(get.status, 200) << get.body;
  EXPECT_EQ(get.header("content-type"), "application/json");
  EXPECT_EQ(get.json_body(), distance);
  HttpResponse post = http.request("POST", "/v1/meshes/spot/distance",
                                   R"({"source":"v:0","target":"f:100:0.2:0.3:0.5"})");
  ASSERT_EQ(post.status, 200) << post.body;
  EXPECT_EQ(post.json_body(), distance);
  EXPECT_EQ(post.json_body()["distance"].get<double>(), distance["distance"].get<double>());

  const json path =
      tcp.result("geodesic.path", {{"mesh", "spot"}, {"source", "v:0"}, {"target", "v:500"}});
  EXPECT_EQ(http.request("GET", "/v1/meshes/spot/path?source=v:0&target=v:500").json_body(), path);
  const json matrix = tcp.result(
      "geodesic.matrix",
      {{"mesh", "spot"}, {"sources", {"v:0", "v:7"}}, {"targets", {"v:9", "v:700", "v:1200"}}});
  EXPECT_EQ(http.request("GET",
                         "/v1/meshes/spot/matrix?sources=v:0&sources=v:7&targets=v:9&"
                         "targets=v:700&targets=v:1200")
                .json_body(),
            matrix);
  const json field =
      tcp.result("geodesic.field", {{"mesh", "spot"}, {"source", "v:3"}, {"cutoff", 0.5}});
  EXPECT_EQ(http.request("GET", "/v1/meshes/spot/field?source=v:3&cutoff=0.5").json_body(), field);
  const json expmap =
      tcp.result("geodesic.expmap", {{"mesh", "spot"}, {"source", "v:3"}, {"radius", 0.1}});
  EXPECT_EQ(http.request("POST", "/v1/meshes/spot/expmap", R"({"source":"v:3","radius":0.1})")
                .json_body(),
            expmap);
  EXPECT_EQ(http.request("GET", "/v1/meshes").json_body(), tcp.result("mesh.list"));
  EXPECT_EQ(http.request("GET", "/v1/meshes/spot").json_body(),
            tcp.result("mesh.info", {{"mesh", "spot"}}));
}

TEST_F(HttpTest, BinaryArraysEqualTheJsonOnes) {
  HttpClient http(http_port());
  const json field =
      http.request("GET", "/v1/meshes/spot/field?sources=v:3&sources=v:2000&cutoff=0.3")
          .json_body();
  const std::size_t n = field["distances"].size();
  ASSERT_EQ(n, 2930u);
  const HttpResponse raw =
      http.request("GET", "/v1/meshes/spot/field?sources=v:3&sources=v:2000&cutoff=0.3", "",
                   {"Accept: application/octet-stream"});
  ASSERT_EQ(raw.status, 200) << raw.body;
  EXPECT_EQ(raw.header("content-type"), "application/octet-stream");
  EXPECT_EQ(raw.header("x-geoprox-dtype"), "float64");
  EXPECT_EQ(raw.header("x-geoprox-shape"), "2930");
  EXPECT_EQ(raw.header("x-geoprox-mesh-version"), field["mesh_version"].get<std::string>());
  const std::vector<double> values = decode_le<double>(raw.body);
  ASSERT_EQ(values.size(), n);
  std::size_t unreached = 0;
  for (std::size_t v = 0; v < n; ++v) {
    const double expected = as_distance(field["distances"][v]);
    if (std::isnan(expected)) {
      EXPECT_TRUE(std::isnan(values[v])) << v;
      ++unreached;
    } else {
      EXPECT_EQ(values[v], expected) << v;  // to the bit
    }
  }
  EXPECT_GT(unreached, 0u);  // the cutoff leaves some vertices out: they are NaN
  const HttpResponse nearest = http.request(
      "GET", "/v1/meshes/spot/field?sources=v:3&sources=v:2000&cutoff=0.3&array=nearest_source", "",
      {"Accept: application/octet-stream"});
  EXPECT_EQ(nearest.header("x-geoprox-dtype"), "uint32");
  const std::vector<std::uint32_t> owners = decode_le<std::uint32_t>(nearest.body);
  ASSERT_EQ(owners.size(), n);
  for (std::size_t v = 0; v < n; ++v) {
    const json& k = field["nearest_source"][v];
    EXPECT_EQ(owners[v], k.is_null() ? 0xFFFFFFFFu : k.get<std::uint32_t>()) << v;
  }

  // float32 in a .npy file, for a matrix: numpy's header, then the values rounded to float.
  const std::string matrix_target =
      "/v1/meshes/spot/matrix?sources=v:0&sources=v:7&targets=v:9&targets=v:700&targets=v:1200";
  const json matrix = http.request("GET", matrix_target).json_body();
  const HttpResponse npy =
      http.request("GET", matrix_target + "&dtype=float32", "", {"Accept: application/x-npy"});
  ASSERT_EQ(npy.status, 200) << npy.body;
  EXPECT_EQ(npy.header("x-geoprox-shape"), "2,3");
  ASSERT_EQ(npy.body.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  const std::size_t header_length =
      static_cast<unsigned char>(npy.body[8]) + 256u * static_cast<unsigned char>(npy.body[9]);
  EXPECT_EQ((10 + header_length) % 64, 0u);
  const std::string dict = npy.body.substr(10, header_length);
  EXPECT_NE(dict.find("'descr': '<f4'"), std::string::npos) << dict;
  EXPECT_NE(dict.find("'shape': (2, 3)"), std::string::npos) << dict;
  const std::vector<float> cells = decode_le<float>(npy.body.substr(10 + header_length));
  ASSERT_EQ(cells.size(), 6u);
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(cells[i], static_cast<float>(matrix["distances"][i / 3][i % 3].get<double>()));
  }

  const json geometry = http.request("GET", "/v1/meshes/spot/geometry").json_body();
  EXPECT_EQ(geometry["vertices"], 2930);
  EXPECT_EQ(geometry["faces"], 5856);
  const HttpResponse triangles = http.request("GET", "/v1/meshes/spot/geometry?array=triangles", "",
                                              {"Accept: application/octet-stream"});
  EXPECT_EQ(triangles.header("x-geoprox-shape"), "5856,3");
  const std::vector<std::uint32_t> ids = decode_le<std::uint32_t>(triangles.body);
  ASSERT_EQ(ids.size(), 3 * 5856u);
  for (std::size_t i = 0; i < ids.size(); i += 997) EXPECT_EQ(ids[i], geometry["triangles"][i]);
  const HttpResponse positions =
      http.request("GET", "/v1/meshes/spot/geometry", "", {"Accept: application/octet-stream"});
  const std::vector<double> xyz = decode_le<double>(positions.body);
  ASSERT_EQ(xyz.size(), 3 * 2930u);
  for (std::size_t i = 0; i < xyz.size(); i += 101) EXPECT_EQ(xyz[i], geometry["positions"][i]);
}

TEST_F(HttpTest, RpcTakesJsonRpcRequests) {
  HttpClient http(http_port());
  HttpResponse ok = http.request(
      "POST", "/v1/rpc",
      R"({"jsonrpc":"2.0","id":"a","method":"geodesic.distance","params":{"mesh":"spot","source":"v:0","target":"v:100"}})");
  ASSERT_EQ(ok.status, 200) << ok.body;
  EXPECT_EQ(ok.json_body()["id"], "a");
  EXPECT_GT(ok.json_body()["result"]["distance"].get<double>(), 0);
  HttpResponse unknown = http.request(
      "POST", "/v1/rpc",
      R"({"jsonrpc":"2.0","id":2,"method":"geodesic.distance","params":{"mesh":"nope","source":"v:0","target":"v:1"}})");
  EXPECT_EQ(unknown.status, 404);
  EXPECT_EQ(unknown.json_body()["error"]["data"]["reason"], "UnknownMesh");
  EXPECT_EQ(unknown.json_body()["id"], 2);
  HttpResponse notification =
      http.request("POST", "/v1/rpc", R"({"jsonrpc":"2.0","method":"server.health"})");
  EXPECT_EQ(notification.status, 204);
  EXPECT_TRUE(notification.body.empty());
  EXPECT_EQ(notification.header("content-length"), "");  // RFC 9110: none on a 204
  EXPECT_EQ(http.request("POST", "/v1/rpc", "{nope").json_body()["error"]["data"]["reason"],
            "ParseError");

  // Batch arrays, as JSON-RPC 2.0 says: an array of replies, none for notifications.
  HttpResponse batch = http.request(
      "POST", "/v1/rpc",
      R"([{"jsonrpc":"2.0","id":1,"method":"geodesic.distance","params":{"mesh":"spot","source":"v:0","target":"v:100"}},)"
      R"({"jsonrpc":"2.0","method":"geodesic.distance","params":{"mesh":"spot","source":"v:0","target":"v:5"}},)"
      R"(7,{"jsonrpc":"2.0","id":"m","method":"mesh.list"}])");
  ASSERT_EQ(batch.status, 200) << batch.body;
  const json replies = batch.json_body();
  ASSERT_TRUE(replies.is_array());
  ASSERT_EQ(replies.size(), 3u);
  EXPECT_EQ(replies[0]["id"], 1);
  EXPECT_EQ(replies[0]["result"]["distance"], ok.json_body()["result"]["distance"]);
  EXPECT_EQ(replies[1]["error"]["data"]["reason"], "InvalidRequest");
  EXPECT_TRUE(replies[1]["id"].is_null());
  EXPECT_EQ(replies[2]["id"], "m");
  EXPECT_EQ(
      http.request("POST", "/v1/rpc", R"([{"jsonrpc":"2.0","method":"server.health"}])").status,
      204);
  HttpResponse empty = http.request("POST", "/v1/rpc", "[]");
  EXPECT_EQ(empty.status, 400);
  EXPECT_EQ(empty.json_body()["error"]["data"]["reason"], "InvalidRequest");
}

TEST_F(HttpTest, EveryBadRequestGetsItsStatusAndTheConnectionKeepsWorking) {
  HttpClient http(http_port());
  struct Case {
    std::string method, target, body;
    std::vector<std::string> headers;
    int status;
    std::string reason;
  };
  const std::vector<Case> cases = {
      {"GET",
       "/v1/meshes/spot/distance?source=v:0&target=v:99999",
       "",
       {},
       400,
       "VertexOutOfRange"},
      {"GET",
       "/v1/meshes/spot/distance?source=v:0&target=f:1:0.5:0.6:0.1",
       "",
       {},
       400,
       "BadBarycentric"},
      {"GET", "/v1/meshes/spot/distance?source=v:0&target=p:nan,0,0", "", {}, 400, "BadPoint"},
      {"GET",
       "/v1/meshes/spot/distance?source=v:0&target=v:1&bogus=1",
       "",
       {},
       400,
       "InvalidParams"},
      {"GET",
       "/v1/meshes/spot/distance?source=v:0&source=v:1&target=v:1",
       "",
       {},
       400,
       "InvalidParams"},
      {"GET", "/v1/meshes/spot/field?source=v:0&cutoff=far", "", {}, 400, "InvalidParams"},
      {"GET", "/v1/meshes/spot/distance?source=v%ZZ", "", {}, 400, "InvalidParams"},
      {"POST",
       "/v1/meshes/spot/distance",
       R"({"mesh":"spot","source":"v:0","target":"v:1"})",
       {},
       400,
       "InvalidParams"},
      {"POST",
       "/v1/meshes/spot/distance",
       R"({"source":"v:0","source":"v:1"})",
       {},
       400,
       "InvalidRequest"},
      {"POST", "/v1/meshes/spot/distance", "[1]", {}, 400, "InvalidParams"},
      {"GET", "/v1/meshes/nope/distance?source=v:0&target=v:1", "", {}, 404, "UnknownMesh"},
      {"GET", "/v1/meshes/nope", "", {}, 404, "UnknownMesh"},
      {"GET", "/v2/things", "", {}, 404, "NotFound"},
      {"GET", "/v1/meshes/bad%20id/distance", "", {}, 404, "NotFound"},
      {"DELETE", "/v1/meshes/spot", "", {}, 405, "InvalidRequest"},
      {"GET", "/v1/rpc", "", {}, 405, "InvalidRequest"},
      {"GET",
       "/v1/meshes/spot/distance?source=v:0&target=v:1",
       "",
       {"Accept: image/png"},
       406,
       "InvalidRequest"},
      {"GET",
       "/v1/meshes/spot/distance?source=v:0&target=v:1",
       "",
       {"Accept: application/octet-stream"},
       406,
       "InvalidRequest"},
      {"POST",
       "/v1/meshes/spot/distance",
       R"({"source":"v:0","target":"v:1"})",
       {"Content-Type: application/x-www-form-urlencoded"},
       415,
       "InvalidRequest"},
      {"GET",
       "/v1/meshes/spot/field?source=v:0&array=colors",
       "",
       {"Accept: application/octet-stream"},
       400,
       "InvalidParams"},
      {"GET", "/v1/meshes/spot/field?source=v:0&dtype=int8", "", {}, 400, "InvalidParams"},
      {"GET",
       "/v1/meshes/spot/field?source=v:0&array=nearest_source",
       "",
       {"Accept: application/octet-stream"},
       400,
       "InvalidParams"},
  };
  for (const Case& c : cases) {
    const HttpResponse r = http.request(c.method, c.target, c.body, c.headers);
    EXPECT_EQ(r.status, c.status) << c.method << " " << c.target << ": " << r.body;
    EXPECT_EQ(r.json_body()["error"]["data"]["reason"], c.reason) << c.target << ": " << r.body;
  }
  EXPECT_EQ(http.request("DELETE", "/v1/meshes/spot").header("allow"), "GET, HEAD, OPTIONS");
  EXPECT_EQ(http.request("GET", "/v1/meshes/spot/distance?source=v:0&target=v:1").status, 200);
}

TEST_F(HttpTest, MalformedOversizedAndSlowRequestsAreAnsweredAndClosed) {
  const auto status_of = [](const std::string& reply) { return reply.substr(0, 12); };
  const auto exchange = [&](const std::string& bytes) {
    Client c(http_port());
    c.send_raw(bytes);
    std::string all;
    while (auto line = c.read_line(5s)) all += *line + "\n";
    EXPECT_TRUE(c.eof()) << bytes.substr(0, 40);  // closed after the error
    return all;
  };
  EXPECT_EQ(status_of(exchange("GARBAGE\r\n\r\n")), "HTTP/1.1 400");
  EXPECT_EQ(status_of(exchange("GET / HTTP/1.1\r\nX: " + std::string(20000, 'a') + "\r\n\r\n")),
            "HTTP/1.1 431");
  EXPECT_EQ(status_of(exchange("POST /v1/rpc HTTP/1.1\r\nContent-Length: 5000000\r\n\r\n")),
            "HTTP/1.1 413");
  // A header that never ends: 408 once http_request_timeout_ms (400 ms here) has passed.
  Client slow(http_port());
  slow.send_raw("GET /v1/meshes HTTP/1.1\r\nHost: x\r\n");
  const auto line = slow.read_line(5s);
  ASSERT_TRUE(line);
  EXPECT_EQ(status_of(*line), "HTTP/1.1 408");
  EXPECT_TRUE(slow.closed_by_peer());
  // Others were served all along.
  HttpClient http(http_port());
  EXPECT_EQ(http.request("GET", "/v1/meshes").status, 200);
}

TEST_F(HttpTest, KeepAlivePipeliningChunkedBodiesHttp10AndHead) {
  HttpClient http(http_port());
  std::string three;
  for (int i = 1; i <= 3; ++i) {
    three += "GET /v1/meshes/spot/distance?source=v:0&target=v:" + std::to_string(100 * i) +
             " HTTP/1.1\r\nHost: x\r\n\r\n";
  }
  ASSERT_TRUE(http.send_raw(three));
  for (int i = 1; i <= 3; ++i) {
    const HttpResponse r = http.read();
    ASSERT_EQ(r.status, 200);
    EXPECT_EQ(r.json_body()["target"]["vertex"], 100 * i);  // in order
  }
  ASSERT_TRUE(
      http.send_raw("POST /v1/rpc HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n"
                    "5\r\n{\"jso\r\n34\r\nnrpc\":\"2.0\",\"id\":7,\"method\":\"mesh.list\","
                    "\"params\":{}}\r\n0\r\n\r\n"));
  const HttpResponse chunked = http.read();
  ASSERT_EQ(chunked.status, 200) << chunked.body;
  EXPECT_EQ(chunked.json_body()["id"], 7);
  const HttpResponse head = http.request("HEAD", "/v1/meshes/spot/geometry");
  EXPECT_EQ(head.status, 200);
  EXPECT_GT(std::stoul(head.header("content-length")), 100000u);
  EXPECT_EQ(http.request("GET", "/v1/meshes").status, 200);  // still in step after HEAD

  Client old(http_port());
  old.send_raw("GET /healthz HTTP/1.0\r\n\r\n");
  EXPECT_EQ(old.read_line()->substr(0, 12), "HTTP/1.0 200");
  EXPECT_TRUE(old.closed_by_peer());
}

TEST_F(HttpTest, CorsForConfiguredOriginsOnlyAndGzipWhenAccepted) {
  HttpClient http(http_port());
  const HttpResponse allowed =
      http.request("GET", "/v1/meshes", "", {"Origin: https://viewer.example"});
  EXPECT_EQ(allowed.header("access-control-allow-origin"), "https://viewer.example");
  EXPECT_NE(allowed.header("access-control-expose-headers").find("X-Geoprox-Shape"),
            std::string::npos);
  EXPECT_EQ(http.request("GET", "/v1/meshes", "", {"Origin: https://evil.example"})
                .header("access-control-allow-origin"),
            "");
  const HttpResponse preflight =
      http.request("OPTIONS", "/v1/meshes/spot/field", "",
                   {"Origin: https://viewer.example", "Access-Control-Request-Method: POST"});
  EXPECT_EQ(preflight.status, 204);
  EXPECT_EQ(preflight.header("access-control-allow-methods"), "GET, HEAD, POST, OPTIONS");
  EXPECT_NE(preflight.header("access-control-allow-headers").find("Authorization"),
            std::string::npos);

  const HttpResponse plain = http.request("GET", "/v1/meshes/spot/field?source=v:3");
  const HttpResponse gzipped =
      http.request("GET", "/v1/meshes/spot/field?source=v:3", "", {"Accept-Encoding: gzip"});
  EXPECT_EQ(gzipped.header("content-encoding"), "gzip");
  EXPECT_LT(gzipped.body.size(), plain.body.size());
  EXPECT_EQ(gunzip(gzipped.body), plain.body);
  // Binary float arrays are sent as they are (gzip gains little on them); uint32 ones gzipped.
  const HttpResponse floats =
      http.request("GET", "/v1/meshes/spot/field?source=v:3&dtype=float32", "",
                   {"Accept-Encoding: gzip", "Accept: application/octet-stream"});
  ASSERT_EQ(floats.status, 200);
  EXPECT_EQ(floats.header("content-encoding"), "");
  EXPECT_EQ(floats.body.size(), 4 * 2930u);
  const HttpResponse nearest =
      http.request("GET", "/v1/meshes/spot/field?sources=v:3&sources=v:900&array=nearest_source",
                   "", {"Accept-Encoding: gzip", "Accept: application/octet-stream"});
  ASSERT_EQ(nearest.status, 200) << nearest.body;
  EXPECT_EQ(nearest.header("content-encoding"), "gzip");
  EXPECT_EQ(gunzip(nearest.body).size(), 4 * 2930u);
  EXPECT_EQ(http.request("GET", "/v1/meshes", "", {"Accept-Encoding: gzip;q=0"})
                .header("content-encoding"),
            "");
}

TEST_F(HttpTest, RequestsAreCountedByTransport) {
  HttpClient http(http_port());
  ASSERT_EQ(http.request("GET", "/v1/meshes/spot/distance?source=v:0&target=v:1").status, 200);
  ASSERT_EQ(http.request("GET", "/v1/meshes/nope/distance?source=v:0&target=v:1").status, 404);
  HttpClient admin(server_->server->admin_port());
  const std::string metrics = admin.request("GET", "/metrics").body;
  EXPECT_NE(metrics.find("geoprox_requests_total{transport=\"http\",method=\"geodesic.distance\","
                         "outcome=\"ok\"}"),
            std::string::npos)
      << metrics;
  EXPECT_NE(metrics.find("geoprox_requests_total{transport=\"http\",method=\"geodesic.distance\","
                         "outcome=\"UnknownMesh\"}"),
            std::string::npos);
  EXPECT_NE(metrics.find("geoprox_request_duration_seconds_count{transport=\"http\","
                         "method=\"geodesic.distance\"}"),
            std::string::npos);
}

TEST(HttpAccess, TheQueryTokenIsABearerTokenAndTheHealthChecksStayOpen) {
  TestData data;
  Config config = http_config(data);
  config.query_token = "s3cret";
  RunningServer server(config);
  HttpClient http(server.server->http_port());
  const std::string target = "/v1/meshes/spot/distance?source=v:0&target=v:1";
  const HttpResponse none = http.request("GET", target);
  EXPECT_EQ(none.status, 401);
  EXPECT_EQ(none.header("www-authenticate"), "Bearer");
  EXPECT_EQ(none.json_body()["error"]["data"]["reason"], "Unauthorized");
  EXPECT_EQ(http.request("GET", target, "", {"Authorization: Bearer wrong"}).status, 403);
  EXPECT_EQ(http.request("GET", target, "", {"Authorization: Bearer s3cret"}).status, 200);
  EXPECT_EQ(http.request("POST", "/v1/rpc",
                         R"({"jsonrpc":"2.0","id":1,"method":"mesh.list","params":{}})")
                .status,
            401);
  EXPECT_EQ(http.request("GET", "/readyz").status, 200);
  EXPECT_EQ(http.request("GET", "/healthz").status, 200);
  // Past the query token, a wrong admin token is forbidden, not unauthenticated.
  const HttpResponse admin =
      http.request("POST", "/v1/rpc",
                   R"({"jsonrpc":"2.0","id":1,"method":"admin.reload","params":{"token":"x"}})",
                   {"Authorization: Bearer s3cret"});
  EXPECT_EQ(admin.status, 403);
  EXPECT_EQ(admin.json_body()["error"]["data"]["reason"], "Unauthorized");
}

TEST(HttpLifecycle, DrainAnswersTheRequestBeingReadAndClosesIdleConnections) {
  TestData data;
  Config config = http_config(data);
  RunningServer server(config);
  HttpClient idle(server.server->http_port());
  ASSERT_EQ(idle.request("GET", "/v1/meshes").status, 200);
  // A request whose body is still on its way when the drain starts.
  const std::string body = R"({"source":"v:0","target":"v:9"})";
  HttpClient reading(server.server->http_port());
  ASSERT_TRUE(
      reading.send_raw("POST /v1/meshes/spot/distance HTTP/1.1\r\nHost: x\r\n"
                       "Content-Type: application/json\r\nContent-Length: " +
                       std::to_string(body.size()) + "\r\n\r\n" + body.substr(0, 5)));
  std::this_thread::sleep_for(100ms);
  server.server->shutdown();
  EXPECT_TRUE(idle.closed_by_peer());  // nothing was owed to it
  ASSERT_TRUE(reading.send_raw(body.substr(5)));
  const HttpResponse answered = reading.read();
  EXPECT_EQ(answered.status, 503) << answered.body;
  EXPECT_EQ(answered.json_body()["error"]["data"]["reason"], "ShuttingDown");
  EXPECT_EQ(answered.header("connection"), "close");
  EXPECT_TRUE(reading.closed_by_peer());
  server.server->wait();
}

/// A server with a query token serving a viewer directory that tries every way out: a secret
/// file beside it, symbolic links to it and to its directory.
class StaticFilesTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = new TestData();
    const fs::path web = web_dir();
    fs::create_directories(web / "assets");
    fs::create_directories(web / "sub");
    write_text(web / "index.html", "<!doctype html><title>viewer</title>\n");
    write_text(web / "sub/index.html", "<p>sub</p>\n");
    std::string script = "// the viewer's bundle\n";
    for (int i = 0; script.size() < 4096; ++i) {
      script += "console.log(" + std::to_string(i * 7919 % 10007) + ");\n";
    }
    write_text(web / "assets/index-3f2a1b.js", script);
    write_text(web / "assets/index-9c8d7e.css", "body { margin: 0 }\n");
    write_text(web / "icon.png", std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16));
    write_text(web / "module.wasm", std::string("\0asm\1\0\0\0", 8));
    write_text(web / "data.bin", "raw");
    write_text(web / ".hidden", "hidden");
    write_text(web / "large.json", std::string(kMaxOutput + 1, ' '));
    write_text(data_->dir.path() / "secret.txt", "SECRET outside the viewer");
    fs::create_symlink(data_->dir.path() / "secret.txt", web / "linked-out.html");
    fs::create_symlink(data_->dir.path(), web / "dir-out");
    fs::create_symlink("index.html", web / "linked-in.html");
    Config config = http_config(*data_);
    config.http_static_dir = web;
    config.query_token = "static-test-token";
    config.limits.max_output_bytes = kMaxOutput;
    server_ = new RunningServer(config);
  }
  static void TearDownTestSuite() {
    delete server_;
    delete data_;
  }
  static fs::path web_dir() { return data_->dir.path() / "web"; }
  static std::uint16_t http_port() { return server_->server->http_port(); }
  static std::string file(const std::string& relative) {
    std::ifstream in(web_dir() / relative, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  static constexpr std::size_t kMaxOutput = 256 * 1024;
  static TestData* data_;
  static RunningServer* server_;
};
TestData* StaticFilesTest::data_ = nullptr;
RunningServer* StaticFilesTest::server_ = nullptr;

TEST_F(StaticFilesTest, FilesComeWithTheirTypeAndCacheHeadersWithoutTheToken) {
  HttpClient http(http_port());
  for (const char* target : {"/", "/index.html", "/?mesh=spot&source=v:0"}) {
    const HttpResponse index = http.request("GET", target);
    ASSERT_EQ(index.status, 200) << target << ": " << index.body;
    EXPECT_EQ(index.body, file("index.html"));
    EXPECT_EQ(index.header("content-type"), "text/html; charset=utf-8");
    EXPECT_EQ(index.header("cache-control"), "no-cache");
    EXPECT_EQ(index.header("x-content-type-options"), "nosniff");
  }
  EXPECT_EQ(http.request("GET", "/sub/").body, file("sub/index.html"));
  EXPECT_EQ(http.request("GET", "/linked-in.html").body, file("index.html"));

  const HttpResponse script = http.request("GET", "/assets/index-3f2a1b.js");
  ASSERT_EQ(script.status, 200);
  EXPECT_EQ(script.body, file("assets/index-3f2a1b.js"));
  EXPECT_EQ(script.header("content-type"), "text/javascript; charset=utf-8");
  EXPECT_EQ(script.header("cache-control"), "public, max-age=31536000, immutable");
  const struct {
    const char* file;
    const char* type;
  } typed[] = {{"assets/index-9c8d7e.css", "text/css; charset=utf-8"},
               {"icon.png", "image/png"},
               {"module.wasm", "application/wasm"},
               {"data.bin", "application/octet-stream"}};
  for (const auto& t : typed) {
    const HttpResponse r = http.request("GET", std::string("/") + t.file);
    ASSERT_EQ(r.status, 200) << t.file;
    EXPECT_EQ(r.header("content-type"), t.type) << t.file;
    EXPECT_EQ(r.body, file(t.file)) << t.file;  // binary bytes (NULs) intact
  }

  const HttpResponse head = http.request("HEAD", "/assets/index-3f2a1b.js");
  EXPECT_EQ(head.status, 200);
  EXPECT_EQ(head.header("content-length"), std::to_string(script.body.size()));
  EXPECT_TRUE(head.body.empty());
  const HttpResponse gzipped =
      http.request("GET", "/assets/index-3f2a1b.js", "", {"Accept-Encoding: gzip"});
  EXPECT_EQ(gzipped.header("content-encoding"), "gzip");
  EXPECT_EQ(gunzip(gzipped.body), script.body);

  // The API still wants the token; the files never do.
  EXPECT_EQ(http.request("GET", "/v1/meshes").status, 401);
  EXPECT_EQ(http.request("GET", "/v1/meshes", "", {"Authorization: Bearer static-test-token"})
                .status,
            200);
  const HttpResponse api_unknown = http.request("GET", "/v1/nope");
  EXPECT_EQ(api_unknown.status, 404);
  EXPECT_EQ(api_unknown.json_body()["error"]["data"]["reason"], "NotFound");
}

TEST_F(StaticFilesTest, OnlyGetAndHead) {
  HttpClient http(http_port());
  for (const char* method : {"POST", "PUT", "DELETE", "OPTIONS"}) {
    const HttpResponse r = http.request(method, "/index.html", method == std::string("POST")
                                                                   ? "{}"
                                                                   : "");
    EXPECT_EQ(r.status, 405) << method;
    EXPECT_EQ(r.header("allow"), "GET, HEAD") << method;
  }
  EXPECT_EQ(http.request("GET", "/").status, 200);  // the connection still works
}

TEST_F(StaticFilesTest, NothingFromOutsideTheDirectory) {
  HttpClient http(http_port());
  const struct {
    const char* target;
    int status;
  } refused[] = {
      {"/../secret.txt", 400},
      {"/assets/../../secret.txt", 400},
      {"/assets/../index.html", 400},
      {"/./index.html", 400},
      {"/%2e%2e/secret.txt", 400},
      {"/%2E%2E/secret.txt", 400},
      {"/.%2e/secret.txt", 400},
      {"/assets%2f..%2f..%2fsecret.txt", 400},
      {"/%2fetc%2fpasswd", 400},
      {"/..%5csecret.txt", 400},
      {"/..\\secret.txt", 400},
      {"/assets\\index-3f2a1b.js", 400},
      {"/index.html%00.png", 400},
      {"/index.html%0a", 400},
      {"/bad%zzescape", 400},
      {"//etc/passwd", 400},
      {"/etc/passwd", 404},
      {"/linked-out.html", 404},
      {"/dir-out/secret.txt", 404},
      {"/.hidden", 404},
      {"/%2ehidden", 404},
      {"/assets", 404},  // a directory is not a file
      {"/missing.js", 404},
      {"/large.json", 413},  // beyond max_output_bytes: refused, not read
  };
  for (const auto& r : refused) {
    const HttpResponse response = http.request("GET", r.target);
    EXPECT_EQ(response.status, r.status) << r.target << ": " << response.body;
    EXPECT_EQ(response.body.find("SECRET"), std::string::npos) << r.target;
    EXPECT_EQ(response.header("content-type"), "application/json") << r.target;
  }
  EXPECT_EQ(http.request("GET", "/").status, 200);
}

TEST(StaticFilesConfig, OffWhenEmptyAndAMissingDirectoryIsAConfigError) {
  TestData data;
  Config config = http_config(data);
  RunningServer server(config);
  HttpClient http(server.server->http_port());
  const HttpResponse off = http.request("GET", "/");
  EXPECT_EQ(off.status, 404);
  EXPECT_NE(off.body.find("serves no web viewer"), std::string::npos) << off.body;

  Config missing = http_config(data);
  missing.http_static_dir = data.dir.path() / "no-such-dir";
  EXPECT_THROW(Server{missing}, ConfigError);

  const Config parsed = parse_config(json::parse(R"({"http_static_dir": "web"})"), "/srv/geo",
                                     "test.json");
  EXPECT_EQ(parsed.http_static_dir, fs::path("/srv/geo/web"));
  EXPECT_EQ(parse_config(json::parse(R"({"http_static_dir": ""})"), "/srv", "t.json")
                .http_static_dir,
            fs::path());
  EXPECT_FALSE(parse_config(json::object(), "/srv", "t.json").http_static_dir.has_value());
}

}  // namespace
}  // namespace geoprox::server::testing
