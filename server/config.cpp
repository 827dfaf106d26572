#include "server/config.h"

#include <cstdlib>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "protocol/messages.h"

namespace geoprox::server {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

class Reader {
 public:
  Reader(const json& object, std::string where) : object_(object), where_(std::move(where)) {}

  /// Refuses keys not in `known`, naming the first one.
  void only(std::initializer_list<const char*> known) const {
    std::set<std::string> allowed(known.begin(), known.end());
    for (auto it = object_.begin(); it != object_.end(); ++it) {
      if (!allowed.count(it.key())) {
        std::string list;
        for (const char* k : known) list += std::string(list.empty() ? "" : ", ") + k;
        throw ConfigError(where_ + ": unknown key \"" + it.key() + "\" (known keys: " + list +
                          ")");
      }
    }
  }

  const json* find(const char* key) const {
    auto it = object_.find(key);
    if (it == object_.end() || it->is_null()) return nullptr;
    return &*it;
  }

  std::string name(const char* key) const { return where_ + "." + key; }

  void string(const char* key, std::string& out) const {
    if (const json* v = find(key)) {
      if (!v->is_string()) throw ConfigError(name(key) + ": expected a string");
      out = v->get<std::string>();
    }
  }

  void boolean(const char* key, bool& out) const {
    if (const json* v = find(key)) {
      if (!v->is_boolean()) throw ConfigError(name(key) + ": expected true or false");
      out = v->get<bool>();
    }
  }

  template <class T>
  void integer(const char* key, T& out, std::int64_t min,
               std::int64_t max = std::numeric_limits<std::int64_t>::max()) const {
    if (const json* v = find(key)) {
      if (!v->is_number_integer()) throw ConfigError(name(key) + ": expected an integer");
      std::int64_t value = 0;
      if (v->is_number_unsigned()) {
        const auto u = v->get<std::uint64_t>();
        if (u > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
          throw ConfigError(name(key) + ": too large");
        }
        value = static_cast<std::int64_t>(u);
      } else {
        value = v->get<std::int64_t>();
      }
      if (value < min || value > max) {
        throw ConfigError(name(key) + ": " + std::to_string(value) + " is out of range [" +
                          std::to_string(min) + ", " + std::to_string(max) + "]");
      }
      out = static_cast<T>(value);
    }
  }

 private:
  const json& object_;
  std::string where_;
};

fs::path resolve(const fs::path& base, const std::string& text) {
  fs::path p(text);
  if (p.is_relative()) p = base / p;
  return p.lexically_normal();
}

SamplingMethod parse_sampling(const std::string& text, const std::string& where) {
  if (text == "auto") return SamplingMethod::Automatic;
  if (text == "fmm") return SamplingMethod::FastMarching;
  if (text == "exact") return SamplingMethod::Exact;
  throw ConfigError(where + ": \"" + text + "\" is not a sampling method (auto, fmm, exact)");
}

}  // namespace

std::string sampling_config_name(SamplingMethod sampling) {
  switch (sampling) {
    case SamplingMethod::FastMarching:
      return "fmm";
    case SamplingMethod::Exact:
      return "exact";
    case SamplingMethod::Automatic:
      break;
  }
  return "auto";
}

bool is_valid_log_level(const std::string& level) {
  static const std::set<std::string> levels = {"trace", "debug", "info",    "warn",
                                               "error", "critical", "off"};
  return levels.count(level) != 0;
}

unsigned Config::effective_compute_threads() const {
  if (compute_threads != 0) return compute_threads;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1 : hw;
}

namespace {

/// The "limits" object: protocol limits and the server's own.
void read_limits(const json& limits, const std::string& where, Config& config) {
  if (!limits.is_object()) throw ConfigError(where + ": expected an object");
  const Reader l(limits, where);
  l.only({"max_line_bytes", "max_nesting_depth", "max_points_per_request", "max_matrix_pairs",
          "max_field_sources", "max_batch_requests", "max_output_bytes", "default_timeout_ms",
          "max_timeout_ms", "max_connections", "max_inflight_per_connection", "max_queue",
          "read_timeout_ms", "max_write_buffer_bytes", "http_request_timeout_ms",
          "http_max_header_bytes"});
  protocol::Limits& p = config.limits;
  ServerLimits& s = config.server_limits;
  l.integer("max_line_bytes", p.max_line_bytes, 64, std::int64_t{1} << 32);
  l.integer("max_nesting_depth", p.max_nesting_depth, 8, 10'000);
  l.integer("max_points_per_request", p.max_points_per_request, 2, 100'000'000);
  l.integer("max_matrix_pairs", p.max_matrix_pairs, 1, std::int64_t{1} << 40);
  l.integer("max_field_sources", p.max_field_sources, 1, 100'000'000);
  l.integer("max_batch_requests", p.max_batch_requests, 1, 100'000'000);
  l.integer("max_output_bytes", p.max_output_bytes, 1024, std::int64_t{1} << 40);
  l.integer("default_timeout_ms", p.default_timeout_ms, 1, 86'400'000);
  l.integer("max_timeout_ms", p.max_timeout_ms, 1, 86'400'000);
  l.integer("max_connections", s.max_connections, 1, 1'000'000);
  l.integer("max_inflight_per_connection", s.max_inflight_per_connection, 1, 1'000'000);
  l.integer("max_queue", s.max_queue, 0, 100'000'000);
  l.integer("read_timeout_ms", s.read_timeout_ms, 1, 86'400'000);
  l.integer("max_write_buffer_bytes", s.max_write_buffer_bytes, 1024, std::int64_t{1} << 40);
  l.integer("http_request_timeout_ms", s.http_request_timeout_ms, 1, 86'400'000);
  l.integer("http_max_header_bytes", s.http_max_header_bytes, 1024, 1 << 20);
}

/// One entry of "meshes"; `ids` and `graphs` are those of the entries before it (no id or
/// graph file twice).
MeshConfig read_mesh(const json& m, const std::string& where, const Config& config,
                     std::set<std::string>& ids, std::set<fs::path>& graphs) {
  if (!m.is_object()) throw ConfigError(where + ": expected an object");
  const Reader r(m, where);
  r.only({"id", "mesh", "graph", "metric", "repair", "samples", "neighbors", "link_samples",
          "sampling"});
  MeshConfig mesh;
  r.string("id", mesh.id);
  if (mesh.id.empty()) throw ConfigError(where + ".id: required");
  if (!protocol::is_valid_mesh_id(mesh.id)) {
    throw ConfigError(where + ".id: \"" + mesh.id +
                      "\" is not a valid mesh id (1 to 128 of A-Z a-z 0-9 . _ -, starting "
                      "with a letter or digit)");
  }
  if (!ids.insert(mesh.id).second) {
    throw ConfigError(where + ".id: \"" + mesh.id + "\" is used twice");
  }
  std::string mesh_file, graph_file = mesh.id + ".geoprox";
  r.string("mesh", mesh_file);
  if (mesh_file.empty()) throw ConfigError(where + ".mesh: required");
  r.string("graph", graph_file);
  if (graph_file.empty()) throw ConfigError(where + ".graph: must not be empty");
  mesh.mesh_path = resolve(config.data_dir, mesh_file);
  mesh.graph_path = resolve(config.graph_dir, graph_file);
  if (!graphs.insert(mesh.graph_path).second) {
    throw ConfigError(where + ".graph: " + mesh.graph_path.string() +
                      " is the graph file of another mesh");
  }
  std::string metric_file;
  r.string("metric", metric_file);
  if (r.find("metric") != nullptr && metric_file.empty()) {
    throw ConfigError(where + ".metric: must not be empty (leave it out for no metric)");
  }
  if (!metric_file.empty()) mesh.build.metric_path = resolve(config.data_dir, metric_file);
  r.boolean("repair", mesh.build.repair);
  r.integer("samples", mesh.build.samples, 0, std::numeric_limits<std::uint32_t>::max());
  r.integer("neighbors", mesh.build.neighbors, 0, std::numeric_limits<std::uint32_t>::max());
  r.integer("link_samples", mesh.build.link_samples, 0,
            std::numeric_limits<std::uint32_t>::max());
  std::string sampling = "auto";
  r.string("sampling", sampling);
  mesh.build.sampling = parse_sampling(sampling, where + ".sampling");
  return mesh;
}

}  // namespace

Config parse_config(const json& document, const fs::path& base_dir, const std::string& origin) {
  if (!document.is_object()) throw ConfigError(origin + ": the top level must be an object");
  Config config;
  const Reader top(document, origin);
  top.only({"bind", "port", "admin_bind", "admin_port", "http_bind", "http_port",
            "http_cors_origins", "http_static_dir", "compute_threads", "io_threads",
            "io_coalesce_us", "io_slice_us", "split_near_pairs", "build_threads", "data_dir", "graph_dir",
            "log_level", "log_json", "admin_token", "query_token", "shutdown_timeout_ms",
            "not_ready_retry_after_ms", "limits", "meshes"});
  top.string("bind", config.bind);
  config.admin_bind = config.bind;
  top.string("admin_bind", config.admin_bind);
  top.integer("port", config.port, 0, 65535);
  top.integer("admin_port", config.admin_port, 0, 65535);
  config.http_bind = config.bind;
  top.string("http_bind", config.http_bind);
  top.integer("http_port", config.http_port, 0, 65535);
  if (const json* origins = top.find("http_cors_origins")) {
    const std::string where = top.name("http_cors_origins");
    if (!origins->is_array()) throw ConfigError(where + ": expected an array of origins");
    for (std::size_t i = 0; i < origins->size(); ++i) {
      const json& entry = (*origins)[i];
      if (!entry.is_string() || entry.get_ref<const std::string&>().empty()) {
        throw ConfigError(where + "[" + std::to_string(i) +
                          "]: expected an origin such as \"https://example.org\" or \"*\"");
      }
      config.http_cors_origins.push_back(entry.get<std::string>());
    }
  }
  if (top.find("http_static_dir") != nullptr) {
    std::string static_dir;
    top.string("http_static_dir", static_dir);
    config.http_static_dir =
        static_dir.empty() ? fs::path() : resolve(base_dir, static_dir);
  }
  top.integer("compute_threads", config.compute_threads, 0, 1024);
  top.integer("io_threads", config.io_threads, 1, 64);
  top.integer("io_coalesce_us", config.io_coalesce_us, 0, 10000);
  top.integer("io_slice_us", config.io_slice_us, 0, 100000);
  if (config.io_slice_us != 0 && config.io_slice_us < 100) {
    throw ConfigError(top.name("io_slice_us") +
                      ": 0 (the kernel's default) or 100 to 100000 microseconds (the range the "
                      "kernel accepts), not " + std::to_string(config.io_slice_us));
  }
  top.boolean("split_near_pairs", config.split_near_pairs);
  top.integer("build_threads", config.build_threads, 0, 1024);
  std::string data_dir = ".";
  std::string graph_dir = "var/graphs";
  top.string("data_dir", data_dir);
  top.string("graph_dir", graph_dir);
  if (data_dir.empty()) throw ConfigError(top.name("data_dir") + ": must not be empty");
  if (graph_dir.empty()) throw ConfigError(top.name("graph_dir") + ": must not be empty");
  config.data_dir = resolve(base_dir, data_dir);
  config.graph_dir = resolve(base_dir, graph_dir);
  top.string("log_level", config.log_level);
  top.boolean("log_json", config.log_json);
  top.string("admin_token", config.admin_token);
  top.string("query_token", config.query_token);
  top.integer("shutdown_timeout_ms", config.shutdown_timeout_ms, 0, 3'600'000);
  top.integer("not_ready_retry_after_ms", config.not_ready_retry_after_ms, 1, 3'600'000);

  if (const json* limits = top.find("limits")) read_limits(*limits, top.name("limits"), config);

  if (const json* meshes = top.find("meshes")) {
    if (!meshes->is_array()) throw ConfigError(top.name("meshes") + ": expected an array");
    std::set<std::string> ids;
    std::set<fs::path> graphs;
    for (std::size_t i = 0; i < meshes->size(); ++i) {
      const std::string where = top.name("meshes") + "[" + std::to_string(i) + "]";
      config.meshes.push_back(read_mesh((*meshes)[i], where, config, ids, graphs));
    }
  }
  validate_config(config);
  return config;
}

void validate_config(const Config& config) {
  if (!is_valid_log_level(config.log_level)) {
    throw ConfigError("log_level: \"" + config.log_level +
                      "\" is not a level (trace, debug, info, warn, error, critical, off)");
  }
  if (config.limits.default_timeout_ms > config.limits.max_timeout_ms) {
    throw ConfigError("limits.default_timeout_ms (" +
                      std::to_string(config.limits.default_timeout_ms) +
                      ") must not exceed limits.max_timeout_ms (" +
                      std::to_string(config.limits.max_timeout_ms) + ")");
  }
  if (!config.query_token.empty() && config.query_token == config.admin_token) {
    // One secret for both would let every query client call the admin methods.
    throw ConfigError("query_token: must differ from admin_token (the query token is given to "
                      "every client; the admin token must stay with the operators)");
  }
  if (config.admin_port != 0 && config.admin_port == config.port &&
      config.admin_bind == config.bind) {
    throw ConfigError("admin_port: must differ from port (" + std::to_string(config.port) + ")");
  }
  if (config.http_port != 0 &&
      ((config.http_port == config.port && config.http_bind == config.bind) ||
       (config.http_port == config.admin_port && config.http_bind == config.admin_bind))) {
    throw ConfigError("http_port: must differ from port and admin_port (" +
                      std::to_string(config.http_port) + ")");
  }
}

Config load_config(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw ConfigError(file.string() + ": cannot open the config file");
  std::ostringstream text;
  text << in.rdbuf();
  json document;
  try {
    document = json::parse(text.str(), nullptr, true, /*ignore_comments=*/false);
  } catch (const json::parse_error& e) {
    throw ConfigError(file.string() + ": invalid JSON: " + e.what());
  }
  fs::path base = fs::absolute(file).parent_path();
  Config config = parse_config(document, base, file.string());
  config.config_file = fs::absolute(file).lexically_normal();
  return config;
}

void apply_environment(Config& config) {
  if (const char* level = std::getenv("GEOPROX_LOG_LEVEL"); level && *level) {
    config.log_level = level;
  }
  if (const char* token = std::getenv("GEOPROX_ADMIN_TOKEN"); token && *token) {
    config.admin_token = token;
  }
  if (const char* token = std::getenv("GEOPROX_QUERY_TOKEN"); token && *token) {
    config.query_token = token;
  }
  validate_config(config);
}

}  // namespace geoprox::server
