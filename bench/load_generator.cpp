// Load generator for geoproxd (issue 5 §6): N TCP connections speaking the protocol, each
// keeping up to `depth` requests in flight (pipelining), a mix of methods on random surface
// points, for a fixed duration. Reports throughput, latency percentiles (p50/p99/p999/max,
// measured from the moment a request is written to the moment its reply line is read) and
// errors by reason.
//
//   load_generator [--host 127.0.0.1] [--port 7878] [--mesh spot] [--connections 16]
//                  [--depth 8] [--duration 10] [--warmup 1] [--rate 0]
//                  [--mix distance=1,path=0,field=0,matrix=0,exact=0] [--points face|vertex]
//                  [--encoding f32le-base64|json] [--matrix-size 4] [--seed 1]
//   load_generator --in-process MESH GRAPH [--threads 2] [--duration 10] [--points face|vertex]
//
// --rate R (requests/s over all connections) paces the requests (open loop; a request whose
// slot comes while `depth` are in flight is counted as "late" and sent when a slot frees);
// 0 runs closed loop, as fast as the server answers. --in-process runs the same random
// point-to-point distances on GeodesicQuery directly, one scratch per thread: the reference
// rate the daemon is compared with. Run the daemon with log_level "warn" (or "info") while
// measuring: per-request lines are debug.
#include <utility>  // before Boost.Asio 1.74: its awaitable.hpp uses std::exchange

#include <boost/asio.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "core/geodesic_query.h"
#include "core/graph_file.h"
#include "core/intrinsic_geometry.h"
#include "core/mesh_io.h"
#include "protocol/json_rpc.h"

namespace {

namespace asio = boost::asio;
using asio::ip::tcp;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

struct Options {
  std::string host = "127.0.0.1";
  std::uint16_t port = 7878;
  std::string mesh = "spot";
  int connections = 16;
  int depth = 8;
  double duration = 10;
  double warmup = 1;
  double rate = 0;
  std::map<std::string, double> mix = {{"distance", 1}};
  std::string points = "face";
  std::string encoding = "f32le-base64";
  int matrix_size = 4;
  unsigned seed = 1;
  std::string in_process_mesh, in_process_graph;
  int threads = 2;
};

[[noreturn]] void usage(const std::string& why) {
  std::fprintf(stderr, "load_generator: %s (see the header of bench/load_generator.cpp)\n",
               why.c_str());
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) usage(a + " needs a value");
      return argv[++i];
    };
    if (a == "--host") o.host = next();
    else if (a == "--port") o.port = static_cast<std::uint16_t>(std::stoi(next()));
    else if (a == "--mesh") o.mesh = next();
    else if (a == "--connections") o.connections = std::stoi(next());
    else if (a == "--depth") o.depth = std::stoi(next());
    else if (a == "--duration") o.duration = std::stod(next());
    else if (a == "--warmup") o.warmup = std::stod(next());
    else if (a == "--rate") o.rate = std::stod(next());
    else if (a == "--points") o.points = next();
    else if (a == "--encoding") o.encoding = next();
    else if (a == "--matrix-size") o.matrix_size = std::stoi(next());
    else if (a == "--seed") o.seed = static_cast<unsigned>(std::stoul(next()));
    else if (a == "--threads") o.threads = std::stoi(next());
    else if (a == "--in-process") {
      o.in_process_mesh = next();
      o.in_process_graph = next();
    } else if (a == "--mix") {
      o.mix.clear();
      std::string text = next();
      std::size_t pos = 0;
      while (pos < text.size()) {
        const std::size_t comma = text.find(',', pos);
        const std::string item = text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
        const std::size_t eq = item.find('=');
        if (eq == std::string::npos) usage("--mix wants method=weight,...");
        o.mix[item.substr(0, eq)] = std::stod(item.substr(eq + 1));
        if (comma == std::string::npos) break;
        pos = comma + 1;
      }
    } else {
      usage("unknown argument " + a);
    }
  }
  if (o.connections < 1 || o.depth < 1 || o.duration <= 0) usage("bad numbers");
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

struct Stats {
  std::vector<double> latencies_ms;
  std::map<std::string, std::uint64_t> errors;
  std::uint64_t ok = 0;
  std::uint64_t late = 0;
  std::uint64_t bytes = 0;
};

class LoadConnection : public std::enable_shared_from_this<LoadConnection> {
 public:
  LoadConnection(asio::io_context& io, const Options& o, MeshShape shape, unsigned seed,
                 Clock::time_point measure_from, Clock::time_point stop_at)
      : o_(o), socket_(io), timer_(io), points_(shape, o.points, seed),
        measure_from_(measure_from), stop_at_(stop_at) {
    for (const auto& [name, weight] : o.mix) {
      names_.push_back(name);
      weights_.push_back(weight);
    }
    pick_ = std::discrete_distribution<std::size_t>(weights_.begin(), weights_.end());
  }

  void start(const tcp::endpoint& endpoint) {
    socket_.connect(endpoint);
    socket_.set_option(tcp::no_delay(true));
    read();
    if (o_.rate > 0) {
      interval_ = std::chrono::duration<double>(o_.connections / o_.rate);
      next_slot_ = Clock::now();
      tick();
    } else {
      for (int i = 0; i < o_.depth; ++i) send_one();
    }
  }

  Stats& stats() { return stats_; }

 private:
  std::string make_request() {
    const std::string method = names_[pick_(points_.rng())];
    json params = {{"mesh", o_.mesh}};
    std::string wire_method = method;
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
      wire_method = method;  // any other method name, e.g. server.health
      params = json::object();
    }
    const std::uint64_t id = next_id_++;
    sent_[id] = Clock::now();
    return json({{"jsonrpc", "2.0"}, {"id", id}, {"method", wire_method}, {"params", params}})
               .dump() +
           "\n";
  }

  void send_one() {
    if (Clock::now() >= stop_at_) return;
    ++in_flight_;
    out_.push_back(make_request());
    if (!writing_) write();
  }

  void tick() {
    const auto now = Clock::now();
    if (now >= stop_at_) return;
    while (next_slot_ <= now) {
      if (in_flight_ < o_.depth) {
        send_one();
      } else {
        ++stats_.late;
        ++owed_;
      }
      next_slot_ += std::chrono::duration_cast<Clock::duration>(interval_);
    }
    timer_.expires_at(next_slot_);
    timer_.async_wait([self = shared_from_this()](boost::system::error_code ec) {
      if (!ec) self->tick();
    });
  }

  void write() {
    writing_ = true;
    writing_now_.swap(out_);
    out_.clear();
    buffers_.clear();
    for (const auto& s : writing_now_) buffers_.emplace_back(s.data(), s.size());
    asio::async_write(socket_, buffers_, [self = shared_from_this()](boost::system::error_code ec, std::size_t) {
      self->writing_ = false;
      self->writing_now_.clear();
      if (ec) return;
      if (!self->out_.empty()) self->write();
    });
  }

  void read() {
    asio::async_read_until(socket_, buffer_, '\n',
                           [self = shared_from_this()](boost::system::error_code ec, std::size_t n) {
                             if (ec) return;
                             self->on_line(n);
                           });
  }

  void on_line(std::size_t n) {
    std::string line(asio::buffers_begin(buffer_.data()), asio::buffers_begin(buffer_.data()) + static_cast<std::ptrdiff_t>(n));
    buffer_.consume(n);
    const auto now = Clock::now();
    try {
      const geoprox::protocol::Reply reply = geoprox::protocol::parse_reply(line);
      const std::uint64_t id = std::stoull(reply.id.json_text());
      auto it = sent_.find(id);
      if (it != sent_.end()) {
        if (it->second >= measure_from_) {
          stats_.latencies_ms.push_back(
              std::chrono::duration<double, std::milli>(now - it->second).count());
          stats_.bytes += n;
          if (reply.error) {
            ++stats_.errors[reply.error->reason];
          } else {
            ++stats_.ok;
          }
        }
        sent_.erase(it);
      }
    } catch (const std::exception& e) {
      ++stats_.errors["unparseable reply"];
    }
    --in_flight_;
    if (o_.rate <= 0) {
      send_one();
    } else if (owed_ > 0 && now < stop_at_) {
      --owed_;
      send_one();
    }
    if (in_flight_ > 0 || now < stop_at_) {
      read();
    } else {
      boost::system::error_code ignored;
      timer_.cancel();
      socket_.close(ignored);
    }
  }

  const Options& o_;
  tcp::socket socket_;
  asio::steady_timer timer_;
  PointSource points_;
  std::vector<std::string> names_;
  std::vector<double> weights_;
  std::discrete_distribution<std::size_t> pick_;
  Clock::time_point measure_from_, stop_at_;
  std::chrono::duration<double> interval_{0};
  Clock::time_point next_slot_;
  asio::streambuf buffer_;
  std::vector<std::string> out_, writing_now_;
  std::vector<asio::const_buffer> buffers_;
  bool writing_ = false;
  int in_flight_ = 0;
  std::uint64_t owed_ = 0;
  std::uint64_t next_id_ = 1;
  std::unordered_map<std::uint64_t, Clock::time_point> sent_;
  Stats stats_;
};

double percentile(std::vector<double>& v, double p) {
  if (v.empty()) return 0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

MeshShape query_shape(const Options& o) {
  asio::io_context io;
  tcp::socket s(io);
  s.connect(tcp::endpoint(asio::ip::make_address(o.host), o.port));
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
  asio::io_context io(1);
  const auto start = Clock::now();
  const auto measure_from = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.warmup));
  const auto stop_at = measure_from + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.duration));
  std::vector<std::shared_ptr<LoadConnection>> connections;
  const tcp::endpoint endpoint(asio::ip::make_address(o.host), o.port);
  for (int i = 0; i < o.connections; ++i) {
    connections.push_back(std::make_shared<LoadConnection>(io, o, shape, o.seed * 1000 + i, measure_from, stop_at));
    connections.back()->start(endpoint);
  }
  io.run();
  Stats all;
  for (auto& c : connections) {
    Stats& s = c->stats();
    all.latencies_ms.insert(all.latencies_ms.end(), s.latencies_ms.begin(), s.latencies_ms.end());
    for (auto& [k, v] : s.errors) all.errors[k] += v;
    all.ok += s.ok;
    all.late += s.late;
    all.bytes += s.bytes;
  }
  const std::size_t total = all.latencies_ms.size();
  std::printf("mesh %s (%llu vertices, %llu faces), %d connections x depth %d, %s, mix",
              o.mesh.c_str(), static_cast<unsigned long long>(shape.vertices),
              static_cast<unsigned long long>(shape.faces), o.connections, o.depth,
              o.rate > 0 ? ("rate " + std::to_string(static_cast<long>(o.rate)) + "/s").c_str()
                         : "closed loop");
  for (const auto& [k, v] : o.mix) std::printf(" %s=%g", k.c_str(), v);
  std::printf(", points %s\n", o.points.c_str());
  std::printf("requests     %zu in %.1f s (%llu ok, %zu errors)\n", total, o.duration,
              static_cast<unsigned long long>(all.ok), total - all.ok);
  std::printf("throughput   %.0f req/s, %.1f MB/s of replies\n", static_cast<double>(total) / o.duration,
              static_cast<double>(all.bytes) / o.duration / 1e6);
  std::printf("latency ms   p50 %.3f  p99 %.3f  p999 %.3f  max %.3f\n",
              percentile(all.latencies_ms, 0.5), percentile(all.latencies_ms, 0.99),
              percentile(all.latencies_ms, 0.999),
              all.latencies_ms.empty() ? 0.0 : *std::max_element(all.latencies_ms.begin(), all.latencies_ms.end()));
  if (o.rate > 0) std::printf("late slots   %llu (depth was full when the rate wanted a request)\n", static_cast<unsigned long long>(all.late));
  for (const auto& [reason, n] : all.errors) {
    std::printf("error        %-20s %llu\n", reason.c_str(), static_cast<unsigned long long>(n));
  }
  return 0;
}

int run_in_process(const Options& o) {
  using namespace geoprox;
  const TriangleMesh mesh = load_mesh(o.in_process_mesh);
  const IntrinsicGeometry geometry(mesh);
  const MappedGraphFile file = MappedGraphFile::open(o.in_process_graph);
  file.verify_mesh(mesh, geometry);
  const GeodesicQuery query(mesh, geometry, file.view());
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
