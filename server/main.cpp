// geoproxd: the geoprox query daemon. docs/daemon.md is the manual.
//
//   geoproxd --config FILE [--bind ADDR] [--port N] [--admin-port N] [--port-file FILE]
//   geoproxd --config FILE --check
//   geoproxd --probe [--bind ADDR] [--admin-port N]
//
// Exit codes: 0 success (also --help, --version, a drained shutdown); 1 a config, check, probe
// or start failure; 2 a command line that was not understood.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>

#include "core/graph/graph_file.h"
#include "core/graph/loaded_graph.h"
#include "core/graph/proximity_graph.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh_io.h"
#include "core/mesh/mesh_repair.h"
#include "server/config.h"
#include "server/logging.h"
#include "server/registry.h"
#include "server/server.h"

namespace {

using namespace geoprox;
using namespace geoprox::server;

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

constexpr const char* kDescription =
    "geoproxd: the geoprox query daemon (docs/daemon.md is the manual).\n"
    "  geoproxd --config FILE [--bind ADDR] [--port N] [--admin-port N] [--http-port N]\n"
    "           [--port-file FILE]\n"
    "  geoproxd --config FILE --check\n"
    "  geoproxd --probe [--bind ADDR] [--admin-port N]\n";

constexpr const char* kFooter =
    "Environment: GEOPROX_LOG_LEVEL (trace..off), GEOPROX_ADMIN_TOKEN (enables admin methods),\n"
    "GEOPROX_QUERY_TOKEN (connections must send server.auth with it before querying).\n"
    "Signals: SIGTERM/SIGINT drain and exit 0 (a second one stops at once); SIGHUP reloads the\n"
    "graph files.";

/// The flags as given. Ports stay text until parse_port, whose message names the flag.
struct Args {
  std::string config;
  std::string bind;
  std::string port;
  std::string admin_port;
  std::string http_port;
  std::string port_file;
  bool check = false;
  bool probe = false;
};

/// The flags parsed: what overrides the config.
struct Overrides {
  std::optional<std::string> bind;
  std::optional<int> port;
  std::optional<int> admin_port;
  std::optional<int> http_port;
};

/// Declares the flags. A flag given twice takes its last value.
void add_options(CLI::App& app, Args& args) {
  app.option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  app.get_formatter()->column_width(20);
  app.add_option("--config", args.config,
                 "the JSON configuration (configs/README.md documents every key)")
      ->type_name("FILE");
  app.add_option("--bind", args.bind, "address of the query port (overrides \"bind\")")
      ->type_name("ADDR");
  app.add_option("--port", args.port, "query port, 0 for an ephemeral one (overrides \"port\")")
      ->type_name("N");
  app.add_option("--admin-port", args.admin_port,
                 "admin HTTP port (/metrics, /healthz, /readyz), 0 = off")
      ->type_name("N");
  app.add_option("--http-port", args.http_port,
                 "HTTP API port (docs/http.md), 0 = off (overrides \"http_port\")")
      ->type_name("N");
  app.add_option("--port-file", args.port_file,
                 "once listening, write {\"port\": N, \"admin_port\": M, \"http_port\": H}\n"
                 "to FILE")
      ->type_name("FILE");
  app.add_flag("--check", args.check,
               "validate the config, the meshes and the graph files, then exit\n"
               "(0: all usable; 1: something is wrong, printed on stderr)");
  app.add_flag("--probe", args.probe,
               "container health check: GET /readyz on the admin port (default\n"
               "127.0.0.1:7879, or --bind/--admin-port; no --config needed);\n"
               "exit 0 when ready, 1 otherwise");
  app.set_version_flag("--version", std::string("geoproxd ") + GEOPROX_VERSION);
  app.footer(kFooter);
  app.allow_extras();  // refused by parse_command_line, naming the first one
}

int parse_port(const std::string& flag, const std::string& text) {
  char* end = nullptr;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || value < 0 || value > 65535) {
    throw ConfigError(flag + ": \"" + text + "\" is not a port number (0 to 65535)");
  }
  return static_cast<int>(value);
}

/// Parses the command line (into the Args bound by add_options). Returns the exit code when
/// there is nothing more to do (--help, --version, a command line not understood), else
/// nullopt. A flag without its value is a ConfigError (exit 1), an unknown argument a usage
/// error (exit 2).
std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version
  } catch (const CLI::ArgumentMismatch& e) {
    const std::string message = e.what();
    throw ConfigError(message.substr(0, message.find(':')) + ": needs a value");
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "geoproxd: %s\n%s", e.what(), app.help().c_str());
    return kExitUsage;
  }
  if (const std::vector<std::string> extras = app.remaining(); !extras.empty()) {
    std::fprintf(stderr, "geoproxd: unknown argument \"%s\"\n%s", extras.front().c_str(),
                 app.help().c_str());
    return kExitUsage;
  }
  return std::nullopt;
}

Overrides overrides_of(const CLI::App& app, const Args& args) {
  Overrides out;
  if (app.count("--bind")) out.bind = args.bind;
  if (app.count("--port")) out.port = parse_port("--port", args.port);
  if (app.count("--admin-port")) out.admin_port = parse_port("--admin-port", args.admin_port);
  if (app.count("--http-port")) out.http_port = parse_port("--http-port", args.http_port);
  return out;
}

/// `--probe`: readiness over the admin port with plain sockets (the runtime image has no curl).
int run_probe(const std::string& address, int port) {
  sockaddr_in where{};
  where.sin_family = AF_INET;
  where.sin_port = htons(static_cast<std::uint16_t>(port));
  const std::string host = address == "0.0.0.0" ? "127.0.0.1" : address;
  if (inet_pton(AF_INET, host.c_str(), &where.sin_addr) != 1) {
    std::fprintf(stderr, "geoproxd: probe: \"%s\" is not an IPv4 address\n", host.c_str());
    return kExitFailure;
  }
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return kExitFailure;
  timeval timeout{2, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof timeout);
  std::string reply;
  if (connect(fd, reinterpret_cast<const sockaddr*>(&where), sizeof where) == 0) {
    const char request[] = "GET /readyz HTTP/1.0\r\nHost: localhost\r\n\r\n";
    if (send(fd, request, sizeof request - 1, MSG_NOSIGNAL) == sizeof request - 1) {
      char buf[256];
      ssize_t n = 0;
      while (reply.size() < 64 && (n = recv(fd, buf, sizeof buf, 0)) > 0) reply.append(buf, n);
    }
  }
  close(fd);
  const bool ready = reply.rfind("HTTP/1.", 0) == 0 && reply.find(" 200 ") != std::string::npos;
  if (!ready) {
    std::fprintf(stderr, "geoproxd: probe: %s:%d is not ready%s\n", host.c_str(), port,
                 reply.empty() ? " (no answer)" : "");
  }
  return ready ? kExitOk : kExitFailure;
}

/// Validates every mesh and graph file without starting anything. Returns the exit code.
int run_check(const Config& config) {
  int failures = 0;
  std::printf("config %s: OK (%zu meshes; data_dir %s; graph_dir %s)\n",
              config.config_file.string().c_str(), config.meshes.size(),
              config.data_dir.string().c_str(), config.graph_dir.string().c_str());
  for (const MeshConfig& m : config.meshes) {
    try {
      const std::shared_ptr<const MeshData> data =
          MeshData::load(m.mesh_path.string(), m.build.metric_path.string(),
                         MeshLoadOptions{.repair = m.build.repair});
      const TriangleMesh& mesh = data->mesh;
      const IntrinsicGeometry& geometry = data->geometry;
      std::printf("mesh %s: %s OK (%zu vertices, %zu faces%s%s)\n", m.id.c_str(),
                  m.mesh_path.string().c_str(), mesh.num_vertices(), mesh.num_faces(),
                  data->repair ? "; repaired: " : "",
                  data->repair ? describe_repair_changes(*data->repair).c_str() : "");
      std::error_code ec;
      if (!std::filesystem::exists(m.graph_path, ec)) {
        std::printf("graph %s: %s missing (it will be built at start)\n", m.id.c_str(),
                    m.graph_path.string().c_str());
        continue;
      }
      try {
        const MappedGraphFile file = MappedGraphFile::open(m.graph_path.string());
        file.verify_mesh(mesh, geometry);
        std::printf("graph %s: %s OK (version %s, %llu samples)\n", m.id.c_str(),
                    m.graph_path.string().c_str(), mesh_version_of(file).c_str(),
                    static_cast<unsigned long long>(file.counts().samples));
        // Served all the same: a warning, not a failure.
        if (const std::string warning = sparse_sampling_warning(file.view()); !warning.empty()) {
          std::fprintf(stderr, "geoproxd: check: graph %s: warning: %s\n", m.id.c_str(),
                       warning.c_str());
        }
      } catch (const std::exception& e) {
        ++failures;
        std::fprintf(stderr, "geoproxd: check: graph %s: %s: %s (at start it would be rebuilt)\n",
                     m.id.c_str(), m.graph_path.string().c_str(), describe_exception(e).c_str());
      }
    } catch (const std::exception& e) {
      ++failures;
      std::fprintf(stderr, "geoproxd: check: mesh %s: %s: %s\n", m.id.c_str(),
                   m.mesh_path.string().c_str(), describe_exception(e).c_str());
    }
  }
  if (failures) {
    std::fprintf(stderr, "geoproxd: check failed: %d problem%s\n", failures,
                 failures == 1 ? "" : "s");
    return kExitFailure;
  }
  std::printf("check passed\n");
  return kExitOk;
}

/// Runs the daemon until it is shut down. Returns the exit code.
int serve(const Config& config, const std::string& port_file) {
  configure_logging(config.log_level, config.log_json);
  std::signal(SIGPIPE, SIG_IGN);
  spdlog::info("geoproxd {} starting (config {}, pid {})", GEOPROX_VERSION,
               config.config_file.string(), static_cast<long>(getpid()));
  ServerOptions options;
  options.handle_signals = true;
  options.port_file = port_file;
  auto server = std::make_unique<Server>(config, options);
  try {
    server->start();
  } catch (const std::exception& e) {
    spdlog::critical("cannot start: {}", e.what());
    return kExitFailure;
  }
  server->wait();
  if (!server->registry().join(std::chrono::seconds(2))) {
    spdlog::warn("a graph build is still running; exiting without waiting for it");
    spdlog::shutdown();
    std::fflush(nullptr);
    _exit(kExitOk);
  }
  server.reset();
  spdlog::info("geoproxd stopped");
  spdlog::shutdown();
  return kExitOk;
}

int run(int argc, char** argv) {
  CLI::App app(kDescription, "geoproxd");
  Args args;
  add_options(app, args);
  if (const std::optional<int> exit_code = parse_command_line(app, argc, argv)) {
    return *exit_code;
  }
  const Overrides overrides = overrides_of(app, args);
  if (args.probe) {
    return run_probe(overrides.bind.value_or("127.0.0.1"), overrides.admin_port.value_or(7879));
  }
  if (args.config.empty()) {
    std::fprintf(stderr, "geoproxd: --config FILE is required\n%s", app.help().c_str());
    return kExitUsage;
  }
  Config config = load_config(args.config);
  if (overrides.bind) config.bind = *overrides.bind;
  if (overrides.port) config.port = static_cast<std::uint16_t>(*overrides.port);
  if (overrides.admin_port) config.admin_port = static_cast<std::uint16_t>(*overrides.admin_port);
  if (overrides.http_port) config.http_port = static_cast<std::uint16_t>(*overrides.http_port);
  apply_environment(config);
  if (args.check) return run_check(config);
  return serve(config, args.port_file);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const ConfigError& e) {
    std::fprintf(stderr, "geoproxd: config error: %s\n", e.what());
    return kExitFailure;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "geoproxd: %s\n", e.what());
    return kExitFailure;
  }
}
