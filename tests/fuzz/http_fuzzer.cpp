// libFuzzer target: the HTTP request path as an HTTP session runs it on bytes from a socket:
// Beast's request parser under the server's limits, then HttpHandler (server/http_handler.h):
// routing, the query token, content negotiation, query strings and JSON bodies into params,
// JSON-RPC over /v1/rpc, and the response it builds (its work run inline). The registry is empty
// (no mesh), so queries end in UnknownMesh once their params are read.
//
// Input: one control byte, then the byte stream of a connection.
//  - byte 0: bit 0 set: the server has a query token ("t0ken"); bits 1-7: the size of the
//    chunks the stream is fed in (1 to 128 bytes: reads split anywhere).
//
// Findings: any crash, sanitizer report or hang, and broken promises: every response has a
// status from 100 to 599, a Content-Length equal to its body (HEAD: the body is empty; 204:
// neither), a JSON content type only on bodies that parse as JSON, and an error object with a
// reason on every JSON error response.
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/http.hpp>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>
#include <variant>

#include "server/config.h"
#include "server/http_handler.h"
#include "server/metrics.h"
#include "server/registry.h"
#include "server/service.h"

namespace {

namespace http = boost::beast::http;
using namespace geoprox::server;

void check(bool condition, const char* what, const HttpResponse& response) {
  if (condition) return;
  std::fprintf(stderr, "http_fuzzer: %s (status %u, body %.200s)\n", what,
               response.result_int(), response.body().c_str());
  std::abort();
}

/// The server's pieces without sockets: an empty registry, two handlers (open, with a token).
struct Harness {
  Harness() {
    config.port = 0;
    config.admin_port = 0;
    config.http_port = 0;
    config.http_cors_origins = {"https://viewer.example"};
    config.http_static_dir = std::filesystem::path();  // no viewer: its paths still parsed
    config.limits.max_line_bytes = 4096;  // the body limit: reachable by short inputs
    config.server_limits.http_max_header_bytes = 1024;
    tokened = config;
    tokened.query_token = "t0ken";
    RegistryOptions options;
    options.data_dir = "/nonexistent";
    options.graph_dir = "/nonexistent";
    registry = std::make_unique<Registry>(options);
    open_service = std::make_unique<Service>(config, *registry, metrics, state);
    token_service = std::make_unique<Service>(tokened, *registry, metrics, state);
    open_handler = std::make_unique<HttpHandler>(config, *open_service);
    token_handler = std::make_unique<HttpHandler>(tokened, *token_service);
  }
  Config config;
  Config tokened;
  Metrics metrics;
  ServerState state;
  std::unique_ptr<Registry> registry;
  std::unique_ptr<Service> open_service;
  std::unique_ptr<Service> token_service;
  std::unique_ptr<HttpHandler> open_handler;
  std::unique_ptr<HttpHandler> token_handler;
};

void check_response(const HttpRequest& request, const HttpResponse& response) {
  const unsigned status = response.result_int();
  check(status >= 100 && status <= 599, "status out of range", response);
  const auto length = response.find(http::field::content_length);
  if (status == 204) {
    check(length == response.end() && response.body().empty(), "a 204 with a body", response);
    return;
  }
  check(length != response.end(), "no Content-Length", response);
  if (request.method() == http::verb::head) {
    check(response.body().empty(), "a body for HEAD", response);
    return;
  }
  check(std::string(length->value()) == std::to_string(response.body().size()),
        "Content-Length differs from the body", response);
  const auto type = response.find(http::field::content_type);
  const bool gzipped = response.find(http::field::content_encoding) != response.end();
  if (type != response.end() && type->value() == "application/json" && !gzipped) {
    const nlohmann::json body = nlohmann::json::parse(response.body(), nullptr, false);
    check(!body.is_discarded(), "a JSON response that does not parse", response);
    if (status >= 400) {
      const nlohmann::json& error = body.contains("error") ? body["error"] : body;
      check(error.is_object() && error.contains("data") && error["data"].contains("reason"),
            "an error response without a reason", response);
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Harness harness;
  if (size < 1) return 0;
  const bool with_token = (data[0] & 1) != 0;
  const std::size_t chunk = 1 + (data[0] >> 1);
  const HttpHandler& handler = with_token ? *harness.token_handler : *harness.open_handler;
  const Config& config = with_token ? harness.tokened : harness.config;
  const std::string_view stream(reinterpret_cast<const char*>(data + 1), size - 1);

  boost::beast::flat_buffer buffer;
  std::size_t fed = 0;
  for (;;) {
    http::request_parser<http::string_body> parser;
    parser.header_limit(static_cast<std::uint32_t>(config.server_limits.http_max_header_bytes));
    parser.body_limit(config.limits.max_line_bytes);
    boost::beast::error_code ec;
    // Feed the parser as a socket would: what is buffered, then `chunk` more bytes at a time.
    while (!parser.is_done()) {
      if (buffer.size() > 0) {
        const std::size_t used = parser.put(buffer.data(), ec);
        buffer.consume(used);
        if (ec == http::error::need_more) {
          ec = {};
        } else if (ec) {
          break;
        } else if (used > 0) {
          continue;
        }
      }
      if (fed == stream.size()) {
        if (!parser.got_some()) return 0;  // the connection ended between requests
        parser.put_eof(ec);
        break;
      }
      const std::size_t n = std::min(chunk, stream.size() - fed);
      auto space = buffer.prepare(n);
      std::memcpy(space.data(), stream.data() + fed, n);
      buffer.commit(n);
      fed += n;
    }
    if (ec || !parser.is_done()) return 0;  // the session answers 400/413/431 and closes
    const HttpRequest request = parser.release();
    std::variant<HttpReply, HttpWork> handled = handler.handle(request);
    HttpReply reply;
    if (auto* immediate = std::get_if<HttpReply>(&handled)) {
      reply = std::move(*immediate);
    } else {
      RequestContext context;
      reply = std::get<HttpWork>(handled).run(context);
    }
    check_response(request, reply.response);
    if (!reply.response.keep_alive()) return 0;
  }
}
