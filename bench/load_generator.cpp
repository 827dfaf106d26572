// Load generator for geoproxd (issue 5 §6, issue 8 §2, issue 40): N connections speaking the
// TCP protocol (or, with --http, the HTTP API), each keeping up to `depth` requests in flight
// (pipelining), a mix of methods on random surface points plus an optional fraction of bad
// requests, for a fixed duration. Every request is accounted for: each one sent must get exactly
// one reply (a bad request: its expected error reason), within a drain period after the run.
// Reports throughput, latency percentiles (p50/p99/p999/max, from the moment a request is queued
// for writing to the moment its reply is read), errors by reason and, with --daemon-pid, the
// daemon's resident memory.
//
//   load_generator [--host 127.0.0.1] [--port 7878] [--mesh spot] [--connections 16]
//                  [--depth 8] [--duration 10] [--warmup 1] [--rate 0] [--arrivals even]
//                  [--mix distance=1,path=0,field=0,matrix=0,exact=0] [--points face|vertex]
//                  [--encoding f32le-base64|json] [--matrix-size 4] [--seed 1]
//                  [--bad 0] [--drain 10] [--allow-errors REASON,...]
//                  [--daemon-pid PID] [--rss-every 0] [--json FILE]
//   load_generator --http [--port 7880] [--depth 1] [the same options]
//   load_generator --in-process MESH GRAPH [--threads 2] [--duration 10] [--points face|vertex]
//
// --http: each connection is a keep-alive HTTP/1.1 connection to the daemon's HTTP port (--port
// defaults to 7880) and each request a `POST /v1/meshes/{mesh}/distance|path|field|matrix` whose
// body is the TCP method's params without "mesh" (exact=1 in the mix: distance with "exact":
// true); the mesh's shape comes from `GET /v1/meshes/{mesh}`. --depth defaults to 1 there;
// above 1 the connection pipelines: requests written back to back, responses matched to them in
// order. Responses are read with Boost.Beast (Content-Length or chunked bodies). A 2xx status
// is a result; any other an error whose reason is the body's error.data.reason ("HTTP 503" when
// the body has none), counted and tolerated (--allow-errors) as over TCP. A response with
// `Connection: close` makes the connection reconnect and resend what was still unanswered
// (counted as reconnects and resent, not as failures; the resent requests keep their first
// send time), as does a server closing an idle keep-alive connection; a connection closed
// with requests in flight, without that header, counts as dropped.
//
// --rate R (requests/s over all connections) paces the requests (open loop; a request whose
// slot comes while `depth` are in flight is counted as "late" and sent when a slot frees);
// 0 runs closed loop, as fast as the server answers. With a rate, --arrivals even (default):
// each connection sends every N/R s, the connections' slots spread evenly over that interval
// (one request every 1/R s in all); --arrivals poisson: each connection's gaps are exponential
// with mean N/R s, so the sum is a Poisson process of rate R (bursts included, as from many
// independent clients). --in-process runs the same random point-to-point distances on
// GeodesicQuery directly, one scratch per thread: the reference rate the daemon is compared
// with; it also prints the latencies of an ideal server at half that rate (Poisson arrivals, one
// FIFO queue, the measured service times, no overhead), the floor for the daemon's. Run the
// daemon with log_level "warn" (or "info") while measuring: per-request lines are debug.
//
// --bad F (0 to 1): that fraction of the requests of each connection are bad, spread evenly
// (every 1/F-th request) and cycling through these kinds, each with the reply it must get:
//   malformed-json     the request cut short (id first)        ParseError, its id
//   unknown-method     geodesic.distances                      UnknownMethod
//   unknown-mesh       mesh "no-such-mesh"                     UnknownMesh
//   face-out-of-range  a face id >= the face count             FaceOutOfRange
//   bary-off-simplex   barycentrics summing to 1.1             BadBarycentric
//   nan-coordinate     {"position": [NaN, 0, 0]} (not JSON)    ParseError, its id
//   wrong-type         {"face": "7", ...}                      BadPoint
//   missing-id         no "id" and no "jsonrpc"                InvalidRequest, id null
//   notification       a valid envelope without id (unknown mesh): no reply at all
// The point kinds corrupt the first point of the request's method (distance, path, field or
// matrix, as picked by --mix). A null-id reply is matched to the connection's oldest missing-id
// request; one more null-id reply than those (e.g. an answered notification) is unexpected.
// Over HTTP the kinds are the ones that exist there, each with its status too (the status and
// the reason must both match):
//   malformed-json     the body cut short                      400 ParseError
//   unknown-method     POST .../distances (no such resource)   404 NotFound
//   unknown-mesh       POST /v1/meshes/no-such-mesh/...        404 UnknownMesh
//   face-out-of-range, bary-off-simplex, wrong-type            400, as over TCP
//   nan-coordinate     as over TCP                             400 ParseError
//   mesh-in-body       the body names the mesh too             400 InvalidParams
//
// Exit status 0 only when: every request got exactly one reply (none lost after --drain
// seconds, no reply with an unknown or repeated id, no unreadable line), no good request failed
// (errors whose reason is listed by --allow-errors are reported but tolerated), every bad
// request got its expected reason, no connection was closed by the server, and the daemon of
// --daemon-pid is still alive at the end; 1 otherwise, 2 on bad arguments. Overloaded is not
// tolerated by default: in closed loop at most connections x depth requests are in flight, and
// with the defaults (64 x 8 = 512 < max_queue 1024, depth 8 < max_inflight_per_connection 64)
// the compute queue cannot fill, so Overloaded there would be a bug. Pass --allow-errors
// Overloaded when deliberately driving the daemon past its limits.
//
// --daemon-pid PID samples VmRSS of /proc/PID/status when the warmup ends ("start"), every
// --rss-every seconds if > 0, and after the drain ("end"); reports start, end and max. --json
// FILE writes the summary (counts, latencies, errors, memory, pass/fail and why) as one JSON
// object.
#include <utility>  // before Boost.Asio 1.74: its awaitable.hpp uses std::exchange

#include <boost/asio.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/http.hpp>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string_view>
#include <random>
#include <set>
#include <span>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "bench/bench_support.h"
#include "core/query/geodesic_query.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/graph/loaded_graph.h"
#include "protocol/json_rpc.h"

namespace {

namespace asio = boost::asio;
namespace http = boost::beast::http;
using asio::ip::tcp;
using nlohmann::json;
using Clock = std::chrono::steady_clock;
using geoprox::bench::write_atomically;

struct Options {
  std::string host = "127.0.0.1";
  std::uint16_t port = 7878;
  bool http = false;  ///< the HTTP API (POST /v1/meshes/{mesh}/...) instead of the TCP protocol
  std::string mesh = "spot";
  int connections = 16;
  int depth = 8;
  double duration = 10;  ///< s of measurement, after the warmup
  double warmup = 1;     ///< s of load before measuring
  double rate = 0;       ///< requests/s over all connections; 0: closed loop
  bool poisson = false;  ///< with --rate: Poisson arrivals instead of evenly spaced ones
  std::map<std::string, double> mix = {{"distance", 1}};
  std::string points = "face";
  std::string encoding = "f32le-base64";
  int matrix_size = 4;
  unsigned seed = 1;
  double bad = 0;      ///< fraction of bad requests, 0 to 1
  double drain = 10;   ///< s to wait for outstanding replies after the run
  std::set<std::string> allowed_errors;  ///< reasons tolerated on good requests
  int daemon_pid = 0;    ///< 0: no memory sampling
  double rss_every = 0;  ///< s between memory samples; 0: start and end only
  std::string json_path;
  std::string in_process_mesh, in_process_graph;
  int threads = 2;
};

[[noreturn]] void usage(const std::string& why) {
  std::fprintf(stderr, "load_generator: %s (see the header of bench/load_generator.cpp)\n",
               why.c_str());
  std::exit(2);
}

std::vector<std::string> split(const std::string& text, char separator) {
  std::vector<std::string> items;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t end = std::min(text.find(separator, pos), text.size());
    if (end > pos) items.push_back(text.substr(pos, end - pos));
    pos = end + 1;
  }
  return items;
}

Options parse(int argc, char** argv) {
  Options o;
  bool port_given = false, depth_given = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) usage(a + " needs a value");
      return argv[++i];
    };
    if (a == "--host") o.host = next();
    else if (a == "--port") {
      o.port = static_cast<std::uint16_t>(std::stoi(next()));
      port_given = true;
    }
    else if (a == "--http") o.http = true;
    else if (a == "--mesh") o.mesh = next();
    else if (a == "--connections") o.connections = std::stoi(next());
    else if (a == "--depth") {
      o.depth = std::stoi(next());
      depth_given = true;
    }
    else if (a == "--duration") o.duration = std::stod(next());
    else if (a == "--warmup") o.warmup = std::stod(next());
    else if (a == "--rate") o.rate = std::stod(next());
    else if (a == "--arrivals") {
      const std::string kind = next();
      if (kind != "even" && kind != "poisson") usage("--arrivals must be even or poisson");
      o.poisson = kind == "poisson";
    }
    else if (a == "--points") o.points = next();
    else if (a == "--encoding") o.encoding = next();
    else if (a == "--matrix-size") o.matrix_size = std::stoi(next());
    else if (a == "--seed") o.seed = static_cast<unsigned>(std::stoul(next()));
    else if (a == "--threads") o.threads = std::stoi(next());
    else if (a == "--bad") o.bad = std::stod(next());
    else if (a == "--drain") o.drain = std::stod(next());
    else if (a == "--daemon-pid") o.daemon_pid = std::stoi(next());
    else if (a == "--rss-every") o.rss_every = std::stod(next());
    else if (a == "--json") o.json_path = next();
    else if (a == "--allow-errors") {
      for (const std::string& reason : split(next(), ',')) o.allowed_errors.insert(reason);
    } else if (a == "--in-process") {
      o.in_process_mesh = next();
      o.in_process_graph = next();
    } else if (a == "--mix") {
      o.mix.clear();
      for (const std::string& item : split(next(), ',')) {
        const std::size_t eq = item.find('=');
        if (eq == std::string::npos) usage("--mix wants method=weight,...");
        o.mix[item.substr(0, eq)] = std::stod(item.substr(eq + 1));
      }
    } else {
      usage("unknown argument " + a);
    }
  }
  if (o.connections < 1 || o.depth < 1 || o.duration <= 0 || o.warmup < 0 || o.drain < 0 ||
      o.rss_every < 0 || o.matrix_size < 1) {
    usage("bad numbers");
  }
  if (!(o.bad >= 0 && o.bad <= 1)) usage("--bad wants a fraction in [0, 1]");
  if (o.mix.empty()) usage("--mix is empty");
  if (o.http) {
    if (!port_given) o.port = 7880;
    if (!depth_given) o.depth = 1;
    for (const auto& [method, weight] : o.mix) {
      if (method != "distance" && method != "exact" && method != "path" && method != "field" &&
          method != "matrix") {
        usage("--http: --mix method " + method + " is not one of distance, exact, path, field, "
              "matrix");
      }
    }
  }
  return o;
}

struct MeshShape {
  std::uint64_t vertices = 0, faces = 0;
};

class PointSource {
 public:
  PointSource(MeshShape shape, std::string kind, unsigned seed)
      : shape_(shape), kind_(std::move(kind)), rng_(seed) {}
  json wire() {
    if (kind_ == "vertex") {
      return {{"vertex", std::uniform_int_distribution<std::uint64_t>(0, shape_.vertices - 1)(rng_)}};
    }
    auto [f, b] = face_point();
    return {{"face", f}, {"bary", {b[0], b[1], b[2]}}};
  }
  /// Appends the JSON text of the next point (the same point wire() would give): what the
  /// distance and path requests are made of, without building and dumping a json value.
  void append_wire(std::string& out) {
    char number[32];
    auto append = [&](auto value) {
      out.append(number, std::to_chars(number, number + sizeof number, value).ptr);
    };
    if (kind_ == "vertex") {
      out += R"({"vertex":)";
      append(std::uniform_int_distribution<std::uint64_t>(0, shape_.vertices - 1)(rng_));
      out += '}';
      return;
    }
    auto [f, b] = face_point();
    out += R"({"face":)";
    append(f);
    out += R"(,"bary":[)";
    append(b[0]);
    out += ',';
    append(b[1]);
    out += ',';
    append(b[2]);
    out += "]}";
  }
  std::pair<std::uint32_t, std::array<double, 3>> face_point() {
    std::uniform_real_distribution<double> u(0, 1);
    double a = u(rng_), b = u(rng_);
    if (a + b > 1) {
      a = 1 - a;
      b = 1 - b;
    }
    const auto f = static_cast<std::uint32_t>(
        std::uniform_int_distribution<std::uint64_t>(0, shape_.faces - 1)(rng_));
    return {f, {1 - a - b, a, b}};
  }
  std::uint32_t vertex() {
    return static_cast<std::uint32_t>(
        std::uniform_int_distribution<std::uint64_t>(0, shape_.vertices - 1)(rng_));
  }
  std::mt19937_64& rng() { return rng_; }

 private:
  MeshShape shape_;
  std::string kind_;
  std::mt19937_64 rng_;
};

/// A kind of bad request and the reply it must get (see the header comment).
struct BadKind {
  const char* name;
  const char* reason;  ///< expected data.reason; "" for a notification, which gets no reply
  bool null_id;        ///< answered with id null: the request has no id to echo
  unsigned status;     ///< HTTP: the status it must get; 0 over TCP
};
constexpr BadKind kBadKinds[] = {
    {"malformed-json", "ParseError", false, 0},
    {"unknown-method", "UnknownMethod", false, 0},
    {"unknown-mesh", "UnknownMesh", false, 0},
    {"face-out-of-range", "FaceOutOfRange", false, 0},
    {"bary-off-simplex", "BadBarycentric", false, 0},
    {"nan-coordinate", "ParseError", false, 0},
    {"wrong-type", "BadPoint", false, 0},
    {"missing-id", "InvalidRequest", true, 0},
    {"notification", "", false, 0},
};
/// The HTTP API's kinds: no envelope, so no missing-id or notification; a mesh in the body
/// instead.
constexpr BadKind kHttpBadKinds[] = {
    {"malformed-json", "ParseError", false, 400},
    {"unknown-method", "NotFound", false, 404},
    {"unknown-mesh", "UnknownMesh", false, 404},
    {"face-out-of-range", "FaceOutOfRange", false, 400},
    {"bary-off-simplex", "BadBarycentric", false, 400},
    {"nan-coordinate", "ParseError", false, 400},
    {"wrong-type", "BadPoint", false, 400},
    {"mesh-in-body", "InvalidParams", false, 400},
};

/// What one connection (and, summed, the whole run) observed.
struct Stats {
  std::uint64_t sent = 0;           ///< requests that must be answered
  std::uint64_t notifications = 0;  ///< requests without id: must not be answered
  std::uint64_t answered = 0;       ///< replies matched to a request sent
  std::uint64_t ok = 0;             ///< good requests with a result
  std::uint64_t lost = 0;           ///< sent, no reply by the end of the drain
  std::uint64_t unexpected_replies = 0;  ///< unknown or repeated id, extra null id, unreadable line
  std::uint64_t dropped = 0;        ///< connections closed or reset by the server mid-run
  std::uint64_t reconnects = 0;     ///< HTTP: after Connection: close, or an idle connection closed
  std::uint64_t resent = 0;         ///< HTTP: requests resent after a reconnection
  std::uint64_t late = 0;
  std::uint64_t measured = 0;       ///< replies to requests sent in the measurement window
  std::uint64_t measured_bytes = 0;
  std::map<std::string, std::uint64_t> sent_by_kind;
  std::map<std::string, std::uint64_t> statuses;  ///< HTTP: status code -> responses
  std::map<std::string, std::uint64_t> expected_errors;    ///< reason -> bad requests that got it
  std::map<std::string, std::uint64_t> unexpected_errors;  ///< reason -> good requests that got it
  std::map<std::string, std::uint64_t> allowed_errors;     ///< same, for --allow-errors reasons
  std::map<std::string, std::uint64_t> wrong_replies;  ///< "kind: expected X, got Y" -> count
  std::vector<std::string> samples;                    ///< first few unexpected lines, for the log
  std::vector<double> latencies_ms;
  std::map<std::string, std::vector<double>> latencies_by_kind;

  void merge(const Stats& s) {
    sent += s.sent;
    notifications += s.notifications;
    answered += s.answered;
    ok += s.ok;
    lost += s.lost;
    unexpected_replies += s.unexpected_replies;
    dropped += s.dropped;
    reconnects += s.reconnects;
    resent += s.resent;
    late += s.late;
    measured += s.measured;
    measured_bytes += s.measured_bytes;
    auto add = [](auto& into, const auto& from) {
      for (const auto& [k, v] : from) into[k] += v;
    };
    add(sent_by_kind, s.sent_by_kind);
    add(statuses, s.statuses);
    add(expected_errors, s.expected_errors);
    add(unexpected_errors, s.unexpected_errors);
    add(allowed_errors, s.allowed_errors);
    add(wrong_replies, s.wrong_replies);
    for (const auto& line : s.samples) {
      if (samples.size() < 10) samples.push_back(line);
    }
    latencies_ms.insert(latencies_ms.end(), s.latencies_ms.begin(), s.latencies_ms.end());
    for (const auto& [k, v] : s.latencies_by_kind) {
      auto& into = latencies_by_kind[k];
      into.insert(into.end(), v.begin(), v.end());
    }
  }
  void note(const std::string& what) {
    if (samples.size() < 10) samples.push_back(what);
  }
};

/// A request as queued for writing, and what its reply must be.
struct Outgoing {
  std::string line;
  int kind = 0;  ///< index into the labels: the mix's methods, then the bad kinds
  bool expects_reply = true;
  bool null_id = false;
};

struct Pending {
  Clock::time_point sent;
  int kind;
};

/// HTTP: a request sent and not yet answered, with its text, to resend after a reconnection.
struct HttpPending {
  Pending pending;
  std::string text;
};

/// The error of a non-2xx HTTP response: its body's error object (error.data.reason), or the
/// reason "HTTP <status>" when the body has none.
geoprox::protocol::ReplyError http_reply_error(unsigned status, const std::string& body) {
  geoprox::protocol::ReplyError error;
  error.code = static_cast<int>(status);
  try {
    const json parsed = json::parse(body);
    const json& e = parsed.at("error");
    error.code = e.value("code", error.code);
    error.message = e.value("message", "");
    error.reason = e.at("data").at("reason").get<std::string>();
    return error;
  } catch (const std::exception&) {
    error.reason = "HTTP " + std::to_string(status);
    error.message = body.substr(0, 200);
    return error;
  }
}

class LoadConnection : public std::enable_shared_from_this<LoadConnection> {
 public:
  LoadConnection(asio::io_context& io, const Options& o, MeshShape shape, unsigned seed,
                 std::size_t bad_offset, Clock::time_point measure_from,
                 Clock::time_point stop_at, std::function<void()> on_finished)
      : o_(o), shape_(shape), mesh_json_(json(o.mesh).dump()), socket_(io), timer_(io),
        points_(shape, o.points, seed), arrival_rng_(seed ^ 0x9e3779b97f4a7c15ULL),
        measure_from_(measure_from), stop_at_(stop_at),
        bad_kinds_(o.http ? std::span<const BadKind>(kHttpBadKinds)
                          : std::span<const BadKind>(kBadKinds)),
        bad_count_(bad_offset), on_finished_(std::move(on_finished)) {
    for (const auto& [name, weight] : o.mix) {
      labels_.push_back(name);
      weights_.push_back(weight);
    }
    good_kinds_ = labels_.size();
    for (const BadKind& b : bad_kinds_) labels_.push_back(std::string("bad:") + b.name);
    host_header_ = o.host + ":" + std::to_string(o.port);
    pick_ = std::discrete_distribution<std::size_t>(weights_.begin(), weights_.end());
  }

  /// `phase` in [0, 1): where in the per-connection interval this connection's first even slot
  /// falls, so that N connections at rate R send one request every 1/R s, not N at once.
  void start(const tcp::endpoint& endpoint, double phase) {
    endpoint_ = endpoint;
    socket_.connect(endpoint);
    socket_.set_option(tcp::no_delay(true));
    if (o_.http) {
      http_read();
    } else {
      read();
    }
    if (o_.rate > 0) {
      interval_ = std::chrono::duration<double>(o_.connections / o_.rate);
      next_slot_ = Clock::now();
      if (o_.poisson) {
        next_slot_ += next_gap();
      } else {
        next_slot_ += std::chrono::duration_cast<Clock::duration>(interval_ * phase);
      }
      tick();
    } else {
      for (int i = 0; i < o_.depth; ++i) send_one();
    }
  }

  /// The drain period is over: whatever is still outstanding is lost.
  void abort() { finish(); }

  /// Final counts: requests still pending are lost.
  Stats& stats() {
    stats_.lost = pending_.size() + null_pending_.size() + http_pending_.size();
    return stats_;
  }

 private:
  json good_params(const std::string& method, std::string& wire_method) {
    json params = {{"mesh", o_.mesh}};
    wire_method = method;
    if (method == "distance" || method == "exact") {
      wire_method = "geodesic.distance";
      params["source"] = points_.wire();
      params["target"] = points_.wire();
      if (method == "exact") params["exact"] = true;
    } else if (method == "path") {
      wire_method = "geodesic.path";
      params["source"] = points_.wire();
      params["target"] = points_.wire();
    } else if (method == "field") {
      wire_method = "geodesic.field";
      params["source"] = points_.wire();
      params["encoding"] = o_.encoding;
    } else if (method == "matrix") {
      wire_method = "geodesic.matrix";
      json s = json::array(), t = json::array();
      for (int i = 0; i < o_.matrix_size; ++i) {
        s.push_back(points_.wire());
        t.push_back(points_.wire());
      }
      params["sources"] = s;
      params["targets"] = t;
    } else {
      params = json::object();  // any other method name, e.g. server.health
    }
    return params;
  }

  /// Replaces the first point of a query's params (source, or sources[0]).
  static void set_first_point(json& params, json point) {
    if (params.contains("source")) {
      params["source"] = std::move(point);
    } else if (params.contains("sources")) {
      params["sources"][0] = std::move(point);
    } else {
      params["source"] = std::move(point);  // a non-query method: still a bad request
    }
  }

  bool next_is_bad() {
    if (o_.bad <= 0) return false;
    bad_credit_ += o_.bad;
    if (bad_credit_ < 1) return false;
    bad_credit_ -= 1;
    return true;
  }

  Outgoing make_request() {
    const std::size_t picked = pick_(points_.rng());
    const std::string& method = labels_[picked];
    const bool bad_one = next_is_bad();
    if ((method == "distance" || method == "path") && !bad_one) {
      // The throughput case: written directly (a json value built and dumped per request costs
      // the generator a tenth of what the daemon spends answering it).
      Outgoing out;
      out.kind = static_cast<int>(picked);
      if (o_.http) {
        ++next_id_;
        std::string body = R"({"source":)";
        points_.append_wire(body);
        body += R"(,"target":)";
        points_.append_wire(body);
        body += '}';
        out.line = http_request(o_.mesh, method, body);
        return out;
      }
      out.line = R"({"jsonrpc":"2.0","id":)";
      out.line += std::to_string(next_id_++);
      out.line += method == "distance" ? R"(,"method":"geodesic.distance","params":{"mesh":)"
                                       : R"(,"method":"geodesic.path","params":{"mesh":)";
      out.line += mesh_json_;
      out.line += R"(,"source":)";
      points_.append_wire(out.line);
      out.line += R"(,"target":)";
      points_.append_wire(out.line);
      out.line += "}}\n";
      return out;
    }
    std::string wire_method;
    json params = good_params(method, wire_method);
    const std::uint64_t id = next_id_++;
    Outgoing out;
    if (o_.http) return make_http_request(picked, bad_one, wire_method, std::move(params), id);
    if (!bad_one) {
      out.kind = static_cast<int>(picked);
      out.line = json({{"jsonrpc", "2.0"}, {"id", id}, {"method", wire_method}, {"params", params}})
                     .dump();
      out.line += '\n';
      return out;
    }
    const std::size_t k = bad_count_++ % bad_kinds_.size();
    const BadKind& bad = bad_kinds_[k];
    const std::string name = bad.name;
    out.kind = static_cast<int>(good_kinds_ + k);
    out.null_id = bad.null_id;
    out.expects_reply = *bad.reason != '\0';
    json request = {{"jsonrpc", "2.0"}, {"id", id}, {"method", wire_method}, {"params", params}};
    if (name == "malformed-json") {
      // nlohmann writes members in key order: "id" comes first, so the server reads it before
      // the line breaks off and echoes it.
      const std::string text = request.dump();
      out.line = text.substr(0, text.size() * 2 / 3);
    } else if (name == "unknown-method") {
      request["method"] = "geodesic.distances";
      out.line = request.dump();
    } else if (name == "unknown-mesh") {
      request["params"]["mesh"] = "no-such-mesh";
      out.line = request.dump();
    } else if (name == "face-out-of-range") {
      set_first_point(request["params"],
                      {{"face", shape_.faces + id % 1000}, {"bary", {0.2, 0.3, 0.5}}});
      out.line = request.dump();
    } else if (name == "bary-off-simplex") {
      set_first_point(request["params"], {{"face", 0}, {"bary", {0.2, 0.3, 0.6}}});
      out.line = request.dump();
    } else if (name == "nan-coordinate") {
      set_first_point(request["params"], "@NAN@");
      out.line = request.dump();
      const std::string marker = "\"@NAN@\"";
      out.line.replace(out.line.find(marker), marker.size(), R"({"position":[NaN,0,0]})");
    } else if (name == "wrong-type") {
      set_first_point(request["params"], {{"face", "7"}, {"bary", {0.2, 0.3, 0.5}}});
      out.line = request.dump();
    } else if (name == "missing-id") {
      request.erase("id");
      request.erase("jsonrpc");
      out.line = request.dump();
    } else {  // notification
      request.erase("id");
      request["params"]["mesh"] = "no-such-mesh";
      out.line = request.dump();
    }
    out.line += '\n';
    return out;
  }

  /// A POST of `body` to /v1/meshes/{mesh}/{resource}.
  std::string http_request(const std::string& mesh, std::string_view resource,
                           const std::string& body) const {
    std::string text = "POST /v1/meshes/";
    text += mesh;
    text += '/';
    text += resource;
    text += " HTTP/1.1\r\nHost: ";
    text += host_header_;
    text += "\r\nContent-Type: application/json\r\nContent-Length: ";
    text += std::to_string(body.size());
    text += "\r\n\r\n";
    text += body;
    return text;
  }

  /// make_request() over HTTP, for everything but a good distance or path: `params` is the
  /// method's params object (with "mesh", dropped here), `wire_method` the TCP method name.
  Outgoing make_http_request(std::size_t picked, bool bad_one, const std::string& wire_method,
                             json params, std::uint64_t id) {
    params.erase("mesh");
    std::string resource = wire_method.substr(wire_method.find('.') + 1);  // geodesic.X -> X
    Outgoing out;
    if (!bad_one) {
      out.kind = static_cast<int>(picked);
      out.line = http_request(o_.mesh, resource, params.dump());
      return out;
    }
    const std::size_t k = bad_count_++ % bad_kinds_.size();
    const std::string name = bad_kinds_[k].name;
    out.kind = static_cast<int>(good_kinds_ + k);
    std::string mesh = o_.mesh, body;
    if (name == "malformed-json") {
      body = params.dump();
      body.resize(body.size() * 2 / 3);
    } else if (name == "unknown-method") {
      resource += 's';  // distances, paths, ...: no such resource
    } else if (name == "unknown-mesh") {
      mesh = "no-such-mesh";
    } else if (name == "face-out-of-range") {
      set_first_point(params, {{"face", shape_.faces + id % 1000}, {"bary", {0.2, 0.3, 0.5}}});
    } else if (name == "bary-off-simplex") {
      set_first_point(params, {{"face", 0}, {"bary", {0.2, 0.3, 0.6}}});
    } else if (name == "nan-coordinate") {
      set_first_point(params, "@NAN@");
      body = params.dump();
      const std::string marker = "\"@NAN@\"";
      body.replace(body.find(marker), marker.size(), R"({"position":[NaN,0,0]})");
    } else if (name == "wrong-type") {
      set_first_point(params, {{"face", "7"}, {"bary", {0.2, 0.3, 0.5}}});
    } else {  // mesh-in-body
      params["mesh"] = o_.mesh;
    }
    if (body.empty()) body = params.dump();
    out.line = http_request(mesh, resource, body);
    return out;
  }

  void send_one() {
    // A notification frees no slot (it is never answered): send until one request is in flight.
    while (Clock::now() < stop_at_) {
      Outgoing r = make_request();
      const auto now = Clock::now();
      ++stats_.sent_by_kind[labels_[static_cast<std::size_t>(r.kind)]];
      if (r.expects_reply) {
        ++stats_.sent;
        ++in_flight_;
        if (o_.http) {
          http_pending_.push_back({Pending{now, r.kind}, r.line});
        } else if (r.null_id) {
          null_pending_.push_back({now, r.kind});
        } else {
          pending_.emplace(next_id_ - 1, Pending{now, r.kind});
        }
      } else {
        ++stats_.notifications;
      }
      out_.push_back(std::move(r.line));
      if (r.expects_reply) break;
    }
    flush();
  }

  /// Starts writing what send_one() queued, unless a write is under way (its completion sends
  /// the rest), on_replies() is still gathering requests for one write or the connection is
  /// being made again (its completion writes every request pending).
  void flush() {
    if (!writing_ && !handling_replies_ && !connecting_ && !write_failed_ && !out_.empty()) {
      write();
    }
  }

  void tick() {
    const auto now = Clock::now();
    if (now >= stop_at_) {
      if (in_flight_ == 0) finish();
      return;
    }
    while (next_slot_ <= now) {
      if (in_flight_ < o_.depth) {
        send_one();
      } else {
        ++stats_.late;
        ++owed_;
      }
      next_slot_ +=
          o_.poisson ? next_gap() : std::chrono::duration_cast<Clock::duration>(interval_);
    }
    timer_.expires_at(std::min(next_slot_, stop_at_));
    timer_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
      if (!ec) self->tick();
    });
  }

  /// Time to this connection's next arrival of a Poisson process of rate R / connections (the
  /// sum over the connections is a Poisson process of rate R).
  Clock::duration next_gap() {
    std::exponential_distribution<double> gap_seconds(1.0 / interval_.count());
    const double seconds = gap_seconds(arrival_rng_);
    return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  }

  void write() {
    writing_ = true;
    writing_now_.swap(out_);
    out_.clear();
    buffers_.clear();
    for (const auto& s : writing_now_) buffers_.emplace_back(s.data(), s.size());
    asio::async_write(socket_, buffers_, [self = shared_from_this(), generation = generation_](
                                             boost::system::error_code ec, std::size_t) {
      if (generation != self->generation_) return;  // the socket was closed to reconnect
      self->writing_ = false;
      self->writing_now_.clear();
      if (ec && self->o_.http) {
        // The server may have closed after a response with Connection: close, still unread:
        // the read side tells (a reconnection, or the connection dropped).
        self->write_failed_ = true;
        return;
      }
      if (ec) {
        self->connection_lost("write: " + ec.message());
        return;
      }
      if (!self->out_.empty() && !self->finished_) self->write();
    });
  }

  void read() {
    asio::async_read_until(socket_, buffer_, '\n',
                           [self = shared_from_this()](boost::system::error_code ec, std::size_t n) {
                             if (ec) {
                               self->connection_lost("read: " + ec.message());
                               return;
                             }
                             self->on_replies(n);
                           });
  }

  /// Handles the line read and every further complete line already buffered, then sends the
  /// requests they freed in one write: a syscall costs ~2 us on this kind of VM, and the
  /// generator shares the cores it measures with the daemon.
  void on_replies(std::size_t n) {
    handling_replies_ = true;
    bool more = on_line(n);
    while (more && !finished_) {
      const auto begin = asio::buffers_begin(buffer_.data());
      const auto end = asio::buffers_end(buffer_.data());
      const auto newline = std::find(begin, end, '\n');
      if (newline == end) break;
      more = on_line(static_cast<std::size_t>(newline - begin) + 1);
    }
    handling_replies_ = false;
    if (finished_) return;
    flush();
    if (more) read();
  }

  void connection_lost(const std::string& why) {
    if (finished_) return;  // closed by us
    ++stats_.dropped;
    stats_.note("connection closed by the server (" + why + ") with " +
                std::to_string(in_flight_) + " requests in flight");
    finish();
  }

  void finish() {
    if (finished_) return;
    finished_ = true;
    boost::system::error_code ignored;
    timer_.cancel();
    socket_.close(ignored);
    on_finished_();
  }

  /// `status`: the HTTP status of the response; 0 over TCP.
  void check_reply(const Pending& p, const geoprox::protocol::Reply& reply, Clock::time_point now,
                   std::size_t bytes, unsigned status = 0) {
    ++stats_.answered;
    const std::string& label = labels_[static_cast<std::size_t>(p.kind)];
    if (static_cast<std::size_t>(p.kind) < good_kinds_) {
      if (!reply.error) {
        ++stats_.ok;
      } else if (o_.allowed_errors.count(reply.error->reason) != 0) {
        ++stats_.allowed_errors[reply.error->reason];
      } else {
        ++stats_.unexpected_errors[reply.error->reason];
        stats_.note(label + " failed: " + reply.error->reason + ": " + reply.error->message);
      }
    } else {
      const BadKind& bad = bad_kinds_[static_cast<std::size_t>(p.kind) - good_kinds_];
      const std::string got = reply.error ? reply.error->reason : "a result";
      if (got == bad.reason && status == bad.status) {
        ++stats_.expected_errors[got];
      } else {
        const auto with_status = [](unsigned code, const std::string& text) {
          return code == 0 ? text : std::to_string(code) + " " + text;
        };
        ++stats_.wrong_replies[std::string(bad.name) + ": expected " +
                               with_status(bad.status, bad.reason) + ", got " +
                               with_status(status, got)];
        stats_.note(label + " got " + got + (reply.error ? ": " + reply.error->message : ""));
      }
    }
    if (p.sent >= measure_from_ && p.sent < stop_at_) {
      const double ms = std::chrono::duration<double, std::milli>(now - p.sent).count();
      ++stats_.measured;
      stats_.measured_bytes += bytes;
      stats_.latencies_ms.push_back(ms);
      stats_.latencies_by_kind[label].push_back(ms);
    }
  }

  /// The id of a success reply as the daemon writes it ({"jsonrpc":"2.0","id":N,"result":...),
  /// read without parsing the rest; nullopt for any other line (which is parsed in full).
  static std::optional<std::uint64_t> success_reply_id(std::string_view line) {
    constexpr std::string_view prefix = R"({"jsonrpc":"2.0","id":)";
    if (!line.starts_with(prefix)) return std::nullopt;
    line.remove_prefix(prefix.size());
    std::uint64_t id = 0;
    const auto [end, error] = std::from_chars(line.data(), line.data() + line.size(), id);
    if (error != std::errc() ||
        !std::string_view(end, static_cast<std::size_t>(line.data() + line.size() - end))
             .starts_with(R"(,"result":)")) {
      return std::nullopt;
    }
    return id;
  }

  /// Handles one reply line of n bytes at the front of buffer_; false once the connection is
  /// done reading (finished, or nothing more to wait for).
  bool on_line(std::size_t n) {
    std::string line(asio::buffers_begin(buffer_.data()), asio::buffers_begin(buffer_.data()) + static_cast<std::ptrdiff_t>(n));
    buffer_.consume(n);
    const auto now = Clock::now();
    bool matched = false;
    // A result for a good request needs no more reading (a tenth of the daemon's own cost if
    // parsed in full); everything else, errors and results for bad requests included, is.
    if (const auto id = success_reply_id(line)) {
      const auto it = pending_.find(*id);
      if (it != pending_.end() && static_cast<std::size_t>(it->second.kind) < good_kinds_) {
        static const geoprox::protocol::Reply kSuccess{};
        check_reply(it->second, kSuccess, now, n);
        pending_.erase(it);
        matched = true;
      }
    }
    if (!matched) {
      try {
        const geoprox::protocol::Reply reply = geoprox::protocol::parse_reply(line);
        if (reply.id.is_null()) {
          if (!null_pending_.empty()) {
            const Pending p = null_pending_.front();
            null_pending_.pop_front();
            check_reply(p, reply, now, n);
            matched = true;
          }
        } else {
          const std::string& text = reply.id.json_text();
          const bool digits = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
          auto it = digits ? pending_.find(std::stoull(text)) : pending_.end();
          if (it != pending_.end()) {
            check_reply(it->second, reply, now, n);
            pending_.erase(it);
            matched = true;
          }
        }
      } catch (const std::exception& e) {
        stats_.note(std::string("unreadable reply (") + e.what() + ")");
      }
    }
    if (!matched) {
      ++stats_.unexpected_replies;
      stats_.note("unexpected reply: " + line.substr(0, 300));
    }
    return after_reply(matched, now);
  }

  /// After a reply (matched to a request, or not): the slot it freed is used (closed loop, or a
  /// late slot owed), and the connection finishes once nothing is in flight after the run; false
  /// then.
  bool after_reply(bool matched, Clock::time_point now) {
    if (matched) {
      --in_flight_;
      if (o_.rate <= 0) {
        send_one();
      } else if (owed_ > 0 && now < stop_at_) {
        --owed_;
        send_one();
      }
    }
    if (in_flight_ > 0 || now < stop_at_) return true;
    finish();
    return false;
  }

  /// HTTP: reads the next response with Beast (a Content-Length or chunked body, of any size).
  void http_read() {
    response_.emplace();
    // No limit; not boost::none, which Beast 1.74 compares wrongly with a Content-Length.
    response_->body_limit(std::numeric_limits<std::uint64_t>::max());
    http::async_read(socket_, http_buffer_, *response_,
                     [self = shared_from_this(), generation = generation_](
                         boost::system::error_code ec, std::size_t n) {
                       if (generation != self->generation_) return;  // closed to reconnect
                       if (ec) {
                         self->http_read_failed(ec);
                       } else {
                         self->on_http_response(n);
                       }
                     });
  }

  void http_read_failed(boost::system::error_code ec) {
    if (finished_) return;
    // A keep-alive connection the server closed while idle, with no request pending (as HTTP
    // servers may): made again. With requests pending, the server dropped them.
    if (http_pending_.empty() && Clock::now() < stop_at_ &&
        (ec == http::error::end_of_stream || ec == asio::error::eof ||
         ec == asio::error::connection_reset)) {
      connecting_ = true;
      reconnect(0);
      return;
    }
    connection_lost("read: " + ec.message());
  }

  /// HTTP: one response of n bytes (head and body), for the oldest request pending.
  void on_http_response(std::size_t n) {
    const auto& response = response_->get();
    const auto now = Clock::now();
    const unsigned status = response.result_int();
    ++stats_.statuses[std::to_string(status)];
    bool matched = false;
    if (!http_pending_.empty()) {
      const Pending p = http_pending_.front().pending;
      http_pending_.pop_front();
      geoprox::protocol::Reply reply;
      if (status / 100 != 2) reply.error = http_reply_error(status, response.body());
      check_reply(p, reply, now, n, status);
      matched = true;
    } else {
      ++stats_.unexpected_replies;
      stats_.note("unexpected response (no request pending): " + std::to_string(status) + " " +
                  response.body().substr(0, 300));
    }
    // Connection: close: the requests the reply frees wait for the new connection.
    const bool keep_alive = response.keep_alive();
    const std::size_t unanswered = http_pending_.size();
    if (!keep_alive) connecting_ = true;
    after_reply(matched, now);
    if (finished_) return;
    if (keep_alive) {
      http_read();
    } else {
      reconnect(unanswered);
    }
  }

  /// HTTP: closes the connection and makes it again, then writes every request still pending
  /// (`resent` of them were sent on the old one). connecting_ is set already (flush() waits).
  void reconnect(std::size_t resent) {
    ++stats_.reconnects;
    stats_.resent += resent;
    ++generation_;
    boost::system::error_code ignored;
    socket_.close(ignored);
    writing_ = false;
    write_failed_ = false;
    writing_now_.clear();
    out_.clear();
    http_buffer_.clear();
    socket_.async_connect(endpoint_, [self = shared_from_this(), generation = generation_](
                                         boost::system::error_code ec) {
      if (generation != self->generation_ || self->finished_) return;
      self->connecting_ = false;
      if (ec) {
        self->connection_lost("reconnect: " + ec.message());
        return;
      }
      boost::system::error_code no_delay_error;
      self->socket_.set_option(tcp::no_delay(true), no_delay_error);
      self->out_.clear();
      for (const HttpPending& p : self->http_pending_) self->out_.push_back(p.text);
      self->http_read();
      self->flush();
    });
  }

  const Options& o_;
  MeshShape shape_;
  std::string mesh_json_;  ///< the mesh id as a JSON string
  tcp::socket socket_;
  tcp::endpoint endpoint_;
  asio::steady_timer timer_;
  PointSource points_;
  std::mt19937_64 arrival_rng_;  ///< its own stream: the same points whatever the arrivals
  std::vector<std::string> labels_;
  std::size_t good_kinds_ = 0;
  std::vector<double> weights_;
  std::discrete_distribution<std::size_t> pick_;
  Clock::time_point measure_from_, stop_at_;
  std::span<const BadKind> bad_kinds_;  ///< kBadKinds, or kHttpBadKinds with --http
  std::chrono::duration<double> interval_{0};
  Clock::time_point next_slot_;
  asio::streambuf buffer_;
  std::vector<std::string> out_, writing_now_;
  std::vector<asio::const_buffer> buffers_;
  bool writing_ = false;
  bool handling_replies_ = false;  ///< inside on_replies: send_one() leaves the write to it
  bool finished_ = false;
  bool connecting_ = false;  ///< HTTP: reconnecting, flush() waits for the new connection
  bool write_failed_ = false;  ///< HTTP: no more writes on this connection
  std::uint64_t generation_ = 0;  ///< HTTP: +1 per reconnection; older completions are ignored
  int in_flight_ = 0;
  std::uint64_t owed_ = 0;
  std::uint64_t next_id_ = 1;
  double bad_credit_ = 0;
  std::size_t bad_count_;
  std::unordered_map<std::uint64_t, Pending> pending_;
  std::deque<Pending> null_pending_;
  std::deque<HttpPending> http_pending_;  ///< HTTP: in the order sent, as answered
  std::string host_header_;
  boost::beast::flat_buffer http_buffer_;
  std::optional<http::response_parser<http::string_body>> response_;
  std::function<void()> on_finished_;
  Stats stats_;
};

double percentile(std::vector<double>& v, double p) {
  if (v.empty()) return 0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

json latency_summary(std::vector<double>& v) {
  return {{"count", v.size()},
          {"p50", percentile(v, 0.5)},
          {"p99", percentile(v, 0.99)},
          {"p999", percentile(v, 0.999)},
          {"max", v.empty() ? 0.0 : *std::max_element(v.begin(), v.end())}};
}

/// VmRSS of /proc/PID/status in KiB; nullopt when the process is gone.
std::optional<std::uint64_t> resident_kib(int pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string key;
  while (status >> key) {
    if (key == "VmRSS:") {
      std::uint64_t kib = 0;
      if (status >> kib) return kib;
      return std::nullopt;
    }
    status.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
  }
  return std::nullopt;
}

struct MemorySamples {
  int pid = 0;
  Clock::time_point t0;
  std::vector<std::pair<double, std::uint64_t>> samples;  ///< (s since start, KiB)
  std::optional<std::uint64_t> start, end;
  bool vanished = false;
  std::optional<std::uint64_t> take() {
    const auto kib = resident_kib(pid);
    if (!kib) {
      vanished = true;
      return std::nullopt;
    }
    samples.emplace_back(std::chrono::duration<double>(Clock::now() - t0).count(), *kib);
    return kib;
  }
  std::uint64_t max() const {
    std::uint64_t m = 0;
    for (const auto& s : samples) m = std::max(m, s.second);
    return m;
  }
};

MeshShape query_shape(const Options& o) {
  asio::io_context io;
  tcp::socket s(io);
  s.connect(tcp::endpoint(asio::ip::make_address(o.host), o.port));
  if (o.http) {
    http::request<http::empty_body> request{http::verb::get, "/v1/meshes/" + o.mesh, 11};
    request.set(http::field::host, o.host + ":" + std::to_string(o.port));
    http::write(s, request);
    boost::beast::flat_buffer buffer;
    http::response<http::string_body> response;
    http::read(s, buffer, response);
    json info;
    try {
      info = json::parse(response.body());
    } catch (const std::exception&) {
    }
    if (response.result_int() != 200 || !info.is_object() || info.value("state", "") != "ready") {
      usage("GET /v1/meshes/" + o.mesh + " (wanted 200 and state ready): " +
            std::to_string(response.result_int()) + " " + response.body().substr(0, 300));
    }
    return {info.at("vertices").get<std::uint64_t>(), info.at("faces").get<std::uint64_t>()};
  }
  const std::string request =
      json({{"jsonrpc", "2.0"}, {"id", 0}, {"method", "mesh.info"}, {"params", {{"mesh", o.mesh}}}})
          .dump() +
      "\n";
  asio::write(s, asio::buffer(request));
  asio::streambuf buf;
  asio::read_until(s, buf, '\n');
  std::istream in(&buf);
  std::string line;
  std::getline(in, line);
  const json reply = json::parse(line);
  if (!reply.contains("result") || reply["result"]["state"] != "ready") {
    usage("mesh " + o.mesh + " is not ready: " + line);
  }
  return {reply["result"]["vertices"].get<std::uint64_t>(), reply["result"]["faces"].get<std::uint64_t>()};
}

int run_network(const Options& o) {
  const MeshShape shape = query_shape(o);
  MemorySamples memory;
  memory.pid = o.daemon_pid;
  if (o.daemon_pid > 0 && !resident_kib(o.daemon_pid)) {
    usage("no VmRSS in /proc/" + std::to_string(o.daemon_pid) + "/status");
  }
  asio::io_context io(1);
  const auto start = Clock::now();
  memory.t0 = start;
  const auto measure_from = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.warmup));
  const auto stop_at = measure_from + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.duration));
  std::vector<std::shared_ptr<LoadConnection>> connections;
  int active = o.connections;
  asio::steady_timer drain_timer(io), memory_timer(io);
  auto on_finished = [&] {
    if (--active == 0) {
      drain_timer.cancel();
      memory_timer.cancel();
    }
  };
  const tcp::endpoint endpoint(asio::ip::make_address(o.host), o.port);
  for (int i = 0; i < o.connections; ++i) {
    connections.push_back(std::make_shared<LoadConnection>(
        io, o, shape, o.seed * 1000 + static_cast<unsigned>(i), static_cast<std::size_t>(i),
        measure_from, stop_at, on_finished));
    connections.back()->start(endpoint, static_cast<double>(i) / o.connections);
  }
  drain_timer.expires_at(stop_at + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.drain)));
  drain_timer.async_wait([&](boost::system::error_code ec) {
    if (ec) return;
    for (auto& c : connections) c->abort();
  });
  std::function<void(boost::system::error_code)> sample = [&](boost::system::error_code ec) {
    if (ec || active == 0) return;
    const auto kib = memory.take();
    if (!memory.start) memory.start = kib;
    if (o.rss_every > 0 && kib) {
      memory_timer.expires_after(std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.rss_every)));
      memory_timer.async_wait(sample);
    }
  };
  if (o.daemon_pid > 0) {
    memory_timer.expires_at(measure_from);
    memory_timer.async_wait(sample);
  }
  io.run();
  if (o.daemon_pid > 0) {
    memory.end = memory.take();
    if (!memory.start) memory.start = memory.end;  // the run ended before the warmup did
  }

  Stats all;
  for (auto& c : connections) all.merge(c->stats());

  std::vector<std::string> failures;
  auto total = [](const std::map<std::string, std::uint64_t>& m) {
    std::uint64_t n = 0;
    for (const auto& [k, v] : m) n += v;
    return n;
  };
  if (all.answered == 0) failures.push_back("no request was answered");
  if (all.lost > 0) failures.push_back(std::to_string(all.lost) + " requests lost (no reply)");
  if (all.unexpected_replies > 0) {
    failures.push_back(std::to_string(all.unexpected_replies) + " unexpected replies");
  }
  if (const auto n = total(all.unexpected_errors)) {
    failures.push_back(std::to_string(n) + " good requests failed");
  }
  if (const auto n = total(all.wrong_replies)) {
    failures.push_back(std::to_string(n) + " bad requests got the wrong reply");
  }
  if (all.dropped > 0) failures.push_back(std::to_string(all.dropped) + " connections dropped");
  if (memory.vanished) failures.push_back("the daemon (pid " + std::to_string(o.daemon_pid) + ") is gone");

  const double seconds = o.duration;
  std::printf("mesh %s (%llu vertices, %llu faces), %d connections x depth %d, %s, mix",
              o.mesh.c_str(), static_cast<unsigned long long>(shape.vertices),
              static_cast<unsigned long long>(shape.faces), o.connections, o.depth,
              o.rate > 0 ? ("rate " + std::to_string(static_cast<long>(o.rate)) + "/s " +
                            (o.poisson ? "poisson" : "even")).c_str()
                         : "closed loop");
  for (const auto& [k, v] : o.mix) std::printf(" %s=%g", k.c_str(), v);
  std::printf(", bad %g, points %s%s\n", o.bad, o.points.c_str(), o.http ? ", http" : "");
  std::printf("requests     %llu sent (+%llu notifications), %llu answered (%llu good ok), "
              "%llu lost, %llu unexpected replies, %llu connections dropped\n",
              static_cast<unsigned long long>(all.sent),
              static_cast<unsigned long long>(all.notifications),
              static_cast<unsigned long long>(all.answered),
              static_cast<unsigned long long>(all.ok),
              static_cast<unsigned long long>(all.lost),
              static_cast<unsigned long long>(all.unexpected_replies),
              static_cast<unsigned long long>(all.dropped));
  std::printf("measured     %llu replies to the requests sent in the %.1f s after the warmup\n",
              static_cast<unsigned long long>(all.measured), seconds);
  std::printf("throughput   %.0f req/s, %.1f MB/s of replies\n",
              static_cast<double>(all.measured) / seconds,
              static_cast<double>(all.measured_bytes) / seconds / 1e6);
  json latency = latency_summary(all.latencies_ms);
  std::printf("latency ms   p50 %.3f  p99 %.3f  p999 %.3f  max %.3f\n", latency["p50"].get<double>(),
              latency["p99"].get<double>(), latency["p999"].get<double>(), latency["max"].get<double>());
  json by_kind = json::object();
  for (auto& [kind, v] : all.latencies_by_kind) {
    by_kind[kind] = latency_summary(v);
    const json& s = by_kind[kind];
    std::printf("  %-24s n %-8llu p50 %.3f  p99 %.3f  p999 %.3f  max %.3f\n", kind.c_str(),
                static_cast<unsigned long long>(v.size()), s["p50"].get<double>(),
                s["p99"].get<double>(), s["p999"].get<double>(), s["max"].get<double>());
  }
  if (o.http) {
    std::printf("http         statuses");
    for (const auto& [status, n] : all.statuses) {
      std::printf(" %s: %llu", status.c_str(), static_cast<unsigned long long>(n));
    }
    std::printf("; %llu reconnects (Connection: close, or closed idle), %llu requests resent\n",
                static_cast<unsigned long long>(all.reconnects),
                static_cast<unsigned long long>(all.resent));
  }
  if (o.rate > 0) std::printf("late slots   %llu (depth was full when the rate wanted a request)\n", static_cast<unsigned long long>(all.late));
  for (const auto& [reason, n] : all.expected_errors) {
    std::printf("expected     %-20s %llu\n", reason.c_str(), static_cast<unsigned long long>(n));
  }
  for (const auto& [reason, n] : all.allowed_errors) {
    std::printf("tolerated    %-20s %llu\n", reason.c_str(), static_cast<unsigned long long>(n));
  }
  for (const auto& [reason, n] : all.unexpected_errors) {
    std::printf("UNEXPECTED   %-20s %llu\n", reason.c_str(), static_cast<unsigned long long>(n));
  }
  for (const auto& [what, n] : all.wrong_replies) {
    std::printf("WRONG REPLY  %s: %llu\n", what.c_str(), static_cast<unsigned long long>(n));
  }
  for (const auto& line : all.samples) std::printf("example      %s\n", line.c_str());
  json memory_json = nullptr;
  if (o.daemon_pid > 0) {
    const auto s = memory.start.value_or(0), e = memory.end.value_or(0);
    std::printf("daemon RSS   start %llu KiB, end %llu KiB, max %llu KiB (%+lld KiB), %zu samples%s\n",
                static_cast<unsigned long long>(s), static_cast<unsigned long long>(e),
                static_cast<unsigned long long>(memory.max()),
                static_cast<long long>(e) - static_cast<long long>(s), memory.samples.size(),
                memory.vanished ? "; the daemon is gone" : "");
    json samples = json::array();
    for (const auto& [t, kib] : memory.samples) samples.push_back({t, kib});
    memory_json = {{"pid", o.daemon_pid},
                   {"start_kib", memory.start ? json(*memory.start) : json(nullptr)},
                   {"end_kib", memory.end ? json(*memory.end) : json(nullptr)},
                   {"max_kib", memory.max()},
                   {"alive_at_end", !memory.vanished},
                   {"samples", samples}};
  }
  std::printf("result       %s", failures.empty() ? "PASS" : "FAIL:");
  for (std::size_t i = 0; i < failures.size(); ++i) {
    std::printf("%s %s", i == 0 ? "" : ";", failures[i].c_str());
  }
  std::printf("\n");
  std::fflush(stdout);

  if (!o.json_path.empty()) {
    json mix = json::object();
    for (const auto& [k, v] : o.mix) mix[k] = v;
    const json summary = {
        {"transport", o.http ? "http" : "tcp"},
        {"mesh", o.mesh},
        {"vertices", shape.vertices},
        {"faces", shape.faces},
        {"connections", o.connections},
        {"depth", o.depth},
        {"rate", o.rate},
        {"arrivals", o.poisson ? "poisson" : "even"},
        {"duration_s", o.duration},
        {"warmup_s", o.warmup},
        {"drain_s", o.drain},
        {"mix", mix},
        {"bad_fraction", o.bad},
        {"allowed_errors", o.allowed_errors},
        {"sent", all.sent},
        {"notifications", all.notifications},
        {"sent_by_kind", all.sent_by_kind},
        {"answered", all.answered},
        {"ok", all.ok},
        {"lost", all.lost},
        {"unexpected_replies", all.unexpected_replies},
        {"connections_dropped", all.dropped},
        {"http_statuses", all.statuses},
        {"reconnects", all.reconnects},
        {"resent", all.resent},
        {"late", all.late},
        {"measured", all.measured},
        {"throughput_rps", static_cast<double>(all.measured) / seconds},
        {"reply_mb_per_s", static_cast<double>(all.measured_bytes) / seconds / 1e6},
        {"latency_ms", latency},
        {"latency_ms_by_kind", by_kind},
        {"expected_errors", all.expected_errors},
        {"tolerated_errors", all.allowed_errors},
        {"unexpected_errors", all.unexpected_errors},
        {"wrong_replies", all.wrong_replies},
        {"examples", all.samples},
        {"memory", memory_json},
        {"passed", failures.empty()},
        {"failures", failures},
    };
    write_atomically(o.json_path, summary.dump(2) + "\n");
  }
  return failures.empty() ? 0 : 1;
}

/// Latencies (ms) of a server with no overhead at all: Poisson arrivals of `rate` per second,
/// one FIFO queue, `workers` workers, service times drawn from the measured ones (ms). What the
/// daemon's latencies at that rate are to be compared with: the rest is the daemon's own cost.
std::vector<double> ideal_server_latencies(const std::vector<double>& service_ms, int workers,
                                           double rate, unsigned seed) {
  std::vector<double> sojourn;
  if (service_ms.empty() || rate <= 0 || workers <= 0) return sojourn;
  std::mt19937_64 rng(seed);
  std::exponential_distribution<double> gap_ms(rate / 1000.0);
  std::uniform_int_distribution<std::size_t> pick(0, service_ms.size() - 1);
  std::vector<double> free_at(static_cast<std::size_t>(workers), 0.0);
  const std::size_t n = std::max<std::size_t>(200000, service_ms.size());
  sojourn.reserve(n);
  double arrival = 0;
  for (std::size_t i = 0; i < n; ++i) {
    arrival += gap_ms(rng);
    auto worker = std::min_element(free_at.begin(), free_at.end());
    const double start = std::max(arrival, *worker);
    *worker = start + service_ms[pick(rng)];
    sojourn.push_back(*worker - arrival);
  }
  return sojourn;
}

int run_in_process(const Options& o) {
  using namespace geoprox;
  const LoadedGraph loaded(o.in_process_mesh, o.in_process_graph);
  const TriangleMesh& mesh = loaded.mesh;
  const GeodesicQuery& query = *loaded.query;
  const MeshShape shape{mesh.num_vertices(), mesh.num_faces()};
  std::atomic<std::uint64_t> done{0};
  std::vector<std::vector<double>> latencies(static_cast<std::size_t>(o.threads));
  auto worker = [&](int t) {
    QueryScratch scratch = query.make_scratch();
    PointSource points(shape, o.points, o.seed * 1000 + static_cast<unsigned>(t));
    auto point = [&]() {
      if (o.points == "vertex") return SurfacePoint::vertex(points.vertex());
      auto [f, b] = points.face_point();
      return SurfacePoint::face(f, b[0], b[1], b[2]);
    };
    const auto warm_end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.warmup));
    while (Clock::now() < warm_end) query.distance(point(), point(), scratch);
    const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.duration));
    std::uint64_t n = 0;
    for (auto now = Clock::now(); now < end;) {
      const SurfacePoint s = point(), e = point();
      try {
        query.distance(s, e, scratch);
      } catch (const Unreachable&) {
      }
      const auto after = Clock::now();
      latencies[static_cast<std::size_t>(t)].push_back(std::chrono::duration<double, std::milli>(after - now).count());
      now = after;
      ++n;
    }
    done += n;
  };
  std::vector<std::thread> threads;
  for (int t = 0; t < o.threads; ++t) threads.emplace_back(worker, t);
  for (auto& t : threads) t.join();
  std::vector<double> all;
  for (auto& l : latencies) all.insert(all.end(), l.begin(), l.end());
  std::printf("in-process   %s (%zu faces), %d threads, points %s\n", o.in_process_mesh.c_str(),
              mesh.num_faces(), o.threads, o.points.c_str());
  std::printf("throughput   %.0f distances/s\n", static_cast<double>(done.load()) / o.duration);
  std::printf("latency ms   p50 %.3f  p99 %.3f  p999 %.3f\n", percentile(all, 0.5),
              percentile(all, 0.99), percentile(all, 0.999));
  const double half_rate = static_cast<double>(done.load()) / o.duration / 2;
  std::vector<double> sojourn = ideal_server_latencies(all, o.threads, half_rate, o.seed);
  std::printf("ideal server at half that rate (%.0f/s, Poisson arrivals, FIFO, %d workers, these "
              "service times, no overhead): p50 %.3f  p99 %.3f  p999 %.3f\n",
              half_rate, o.threads, percentile(sojourn, 0.5), percentile(sojourn, 0.99),
              percentile(sojourn, 0.999));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Options o = parse(argc, argv);
    return o.in_process_mesh.empty() ? run_network(o) : run_in_process(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "load_generator: %s\n", e.what());
    return 1;
  }
}
