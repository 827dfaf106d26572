// geoproxd configuration: one JSON file (configs/README.md and docs/daemon.md document every key
// and its default), then the environment (GEOPROX_LOG_LEVEL, GEOPROX_ADMIN_TOKEN,
// GEOPROX_QUERY_TOKEN), then the command line (--bind, --port, --admin-port, --http-port).
// Unknown keys are refused, naming the key, so a misspelt option never silently falls back to
// its default.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/graph/proximity_graph.h"
#include "protocol/limits.h"

namespace geoprox::server {

/// A configuration that cannot be used; the message names the file and the key.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Graph build parameters (as `geoprox build`); 0 / Automatic take the paper's Table 1 values.
struct BuildParams {
  std::uint32_t samples = 0;
  std::uint32_t neighbors = 0;
  std::uint32_t link_samples = 0;
  SamplingMethod sampling = SamplingMethod::Automatic;
  /// Riemannian metric side file (docs/metrics.md; absolute, lexically normal), as `geoprox
  /// build --metric`: the mesh's edge lengths come from it, for the build and for every load
  /// (a graph file built without it, or with another, is refused and rebuilt). Empty: none.
  std::filesystem::path metric_path = {};
  /// Load the mesh repaired (core/mesh/mesh_repair.h; ids as in the file `geoprox repair`
  /// writes), for the build and for every load, instead of refusing a mesh that is not an
  /// oriented manifold (which then fails to load). A mesh that needs no repair is the same
  /// either way, and so is its graph file.
  bool repair = false;
};

/// One mesh of the config's "meshes" array, paths resolved.
struct MeshConfig {
  std::string id;
  std::filesystem::path mesh_path;   ///< absolute, lexically normal
  std::filesystem::path graph_path;  ///< absolute, lexically normal
  BuildParams build;
};

/// Transport limits (beyond protocol::Limits, which the protocol layer enforces).
struct ServerLimits {
  std::size_t max_connections = 1024;
  std::size_t max_inflight_per_connection = 64;
  /// Requests waiting for a compute thread (not counting the running ones) before new ones are
  /// answered Overloaded.
  std::size_t max_queue = 1024;
  /// A connection with nothing in flight and nothing to write that sends nothing for this long
  /// is closed.
  std::int64_t read_timeout_ms = 60'000;
  /// Replies queued for a connection beyond this many bytes: the client is not reading, it is
  /// disconnected (a single reply is always accepted).
  std::size_t max_write_buffer_bytes = std::size_t{128} << 20;
  /// HTTP: a request's header and body must arrive within this long of its first byte, else
  /// 408 and the connection is closed (slow senders cannot hold a connection).
  std::int64_t http_request_timeout_ms = 10'000;
  /// HTTP: bytes of a request's start line and header fields (431 beyond).
  std::size_t http_max_header_bytes = 16 * 1024;
};

struct Config {
  std::filesystem::path config_file;  ///< empty when built in code (tests)
  std::string bind = "127.0.0.1";
  std::uint16_t port = 7878;
  std::string admin_bind = "127.0.0.1";
  std::uint16_t admin_port = 7879;  ///< 0: no admin HTTP endpoint
  std::string http_bind = "127.0.0.1";
  std::uint16_t http_port = 7880;  ///< 0: no HTTP API (docs/http.md)
  /// Origins whose browser pages may call the HTTP API (CORS); "*" allows any. Empty: none.
  std::vector<std::string> http_cors_origins;
  /// The web viewer's built files, served at "/" of the HTTP listener (server/static_files.h):
  /// nullopt (the key absent) finds the installed or source-tree clients/web/dist; an empty
  /// path serves none.
  std::optional<std::filesystem::path> http_static_dir;
  unsigned compute_threads = 0;     ///< 0: std::thread::hardware_concurrency()
  unsigned io_threads = 1;
  /// Under load (4 requests per compute thread waiting), an I/O thread pauses this long (us)
  /// between its rounds of events, so replies and reads go in batches; 0: never.
  unsigned io_coalesce_us = 500;
  /// The scheduler time slice the I/O threads ask for (us; Linux 6.12+, server/thread_slice.h):
  /// shorter than the compute threads', so that a woken I/O thread preempts one at once and a
  /// finished answer leaves without waiting for a core. 0: the kernel's default; else 100 to
  /// 100000.
  unsigned io_slice_us = 100;
  /// A near pair's two exact solves (most of its time) run on two compute threads when one of
  /// them is idle, so that at low load such a query takes about half as long.
  bool split_near_pairs = true;
  unsigned build_threads = 0;       ///< OpenMP threads of one graph build; 0: all cores
  std::filesystem::path data_dir;   ///< absolute
  std::filesystem::path graph_dir;  ///< absolute
  std::string log_level = "info";
  bool log_json = false;
  std::string admin_token;  ///< empty: admin methods disabled
  /// Non-empty: a connection must send server.auth with it before any method other than
  /// server.health. Empty: queries are open (to whoever reaches `bind`).
  std::string query_token;
  std::int64_t shutdown_timeout_ms = 10'000;
  /// Retry hint of MeshNotReady errors.
  std::int64_t not_ready_retry_after_ms = 1'000;
  protocol::Limits limits;
  ServerLimits server_limits;
  std::vector<MeshConfig> meshes;

  unsigned effective_compute_threads() const;
};

/// Reads and validates `file` (relative paths inside it are relative to its directory).
Config load_config(const std::filesystem::path& file);
/// Validates a parsed document; relative paths are resolved against `base_dir`.
Config parse_config(const nlohmann::json& document, const std::filesystem::path& base_dir,
                    const std::string& origin = "config");
/// Environment overrides: GEOPROX_LOG_LEVEL, GEOPROX_ADMIN_TOKEN, GEOPROX_QUERY_TOKEN (non-empty
/// values win).
void apply_environment(Config& config);
/// Checks values that flags or the environment may have changed (log level, the two tokens
/// being different...). Throws ConfigError.
void validate_config(const Config& config);

/// "trace", "debug", "info", "warn", "error", "critical", "off".
bool is_valid_log_level(const std::string& level);

std::string sampling_config_name(SamplingMethod sampling);  ///< "auto", "fmm", "exact"

}  // namespace geoprox::server
