// `geoprox remote ...`: the command-line client of a geoproxd daemon, through the C++ client
// library (clients/cpp/geoprox_client.h). The offline `distance` and `field` commands
// (query_commands.cpp) read files; everything that talks to a daemon is under `remote`.
// `field --out` and `path --out` write result files: the daemon does not send mesh geometry,
// so `field --out` reads a local copy (--mesh-file).
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "clients/cli/cli.h"
#include "clients/cli/result_files.h"
#include "clients/cpp/geoprox_client.h"
#include "core/base/errors.h"
#include "core/mesh/mesh_io.h"

namespace geoprox::cli {
namespace {

// Exit codes of the client commands (exit_code_footer() in main.cpp lists them).
constexpr int kExitConnection = 4;  ///< cannot connect, or the connection was lost
constexpr int kExitTimeout = 5;     ///< no connection or no reply in time
constexpr int kExitServer = 6;      ///< the server answered with an error

struct Common {
  std::string host = "127.0.0.1";
  int port = 7878;
  int timeout_ms = 60000;
  bool json = false;
  std::string token;  ///< the daemon's query token (server.auth); empty: none
};

struct RemoteArgs {
  Common common;
  std::string mesh;
  std::string source;
  std::string target;
  std::vector<std::string> sources;
  std::vector<std::string> targets;
  std::optional<double> cutoff;
  bool csv = false;
  std::string out;        ///< field: PLY file, path: OBJ file, written instead of stdout
  std::string mesh_file;  ///< field --out: local copy of the daemon's mesh (for its geometry)
  bool repair = false;    ///< field --out: load --mesh-file repaired, as the daemon's "repair"
};

void add_common(CLI::App* command, Common& common) {
  command->add_option("--host", common.host, "Daemon address (env GEOPROX_HOST)")
      ->envname("GEOPROX_HOST")
      ->capture_default_str();
  command->add_option("--port", common.port, "Daemon query port (env GEOPROX_PORT)")
      ->envname("GEOPROX_PORT")
      ->check(CLI::Range(1, 65535))
      ->capture_default_str();
  command
      ->add_option("--timeout-ms", common.timeout_ms,
                   "Connect and reply timeout in milliseconds")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command->add_flag("--json", common.json, "Print the reply's result as JSON (one line)");
  command
      ->add_option("--token", common.token,
                   "The daemon's query token, sent with server.auth (env GEOPROX_TOKEN; prefer\n"
                   "the environment: other users can read command lines)")
      ->envname("GEOPROX_TOKEN");
}

std::string number_text(const nlohmann::json& value) {
  std::string out;
  append_number(out, value.is_number() ? value.get<double>() : HUGE_VAL);
  return out;
}

void print(const std::string& text) {
  std::fwrite(text.data(), 1, text.size(), stdout);
}

/// `key value` lines of an object, nested objects flattened as `outer.inner`.
void append_object(std::string& out, const nlohmann::json& object, const std::string& prefix) {
  for (const auto& [key, value] : object.items()) {
    const std::string name = prefix.empty() ? key : prefix + "." + key;
    if (value.is_object()) {
      append_object(out, value, name);
      continue;
    }
    out += name + " ";
    if (value.is_string()) out += value.get<std::string>();
    else if (value.is_number_float()) out += number_text(value);
    else if (value.is_array()) {
      std::string items;
      for (const auto& item : value) {
        items += (items.empty() ? "" : ",") +
                 (item.is_string() ? item.get<std::string>() : item.dump());
      }
      out += items.empty() ? "-" : items;
    } else if (value.is_null()) out += "-";
    else out += value.dump();
    out += "\n";
  }
}

std::string format_result(const std::string& command, const RemoteArgs& args,
                          const nlohmann::json& result) {
  if (args.common.json) return result.dump() + "\n";
  std::string out;
  if (command == "distance") {
    out += "distance " + number_text(result.at("distance")) + "\n";
    out += std::string("exact ") + (result.value("exact", false) ? "yes" : "no") + "\n";
  } else if (command == "path") {
    out += "distance " + number_text(result.at("distance")) + "\n";
    for (const auto& point : result.at("points")) {
      const auto& bary = point.at("bary");
      const auto& position = point.at("position");
      out += "f:" + std::to_string(point.at("face").get<std::uint64_t>()) + ":" +
             number_text(bary.at(0)) + ":" + number_text(bary.at(1)) + ":" +
             number_text(bary.at(2)) + " " + number_text(position.at(0)) + " " +
             number_text(position.at(1)) + " " + number_text(position.at(2)) + "\n";
    }
  } else if (command == "field") {
    const auto& distances = result.at("distances");
    const auto nearest = result.find("nearest_source");
    const bool has_nearest = nearest != result.end() && nearest->is_array();
    for (std::size_t i = 0; i < distances.size(); ++i) {
      if (args.csv) {
        out += std::to_string(i) + "," + number_text(distances[i]);
        if (has_nearest) {
          const auto& n = (*nearest)[i];
          out += "," + (n.is_null() ? std::string() : n.dump());
        }
      } else {
        out += number_text(distances[i]);
      }
      out += "\n";
    }
  } else if (command == "matrix") {
    const char* separator = args.csv ? "," : " ";
    for (const auto& row : result.at("distances")) {
      std::string line;
      for (const auto& value : row) line += (line.empty() ? "" : separator) + number_text(value);
      out += line + "\n";
    }
  } else if (command == "meshes") {
    char line[512];
    std::snprintf(line, sizeof line, "%-24s %-9s %8s %10s %8s\n", "id", "state", "progress",
                  "faces", "samples");
    out += line;
    for (const auto& mesh : result.at("meshes")) {
      const auto& samples = mesh.at("samples");
      std::snprintf(line, sizeof line, "%-24s %-9s %7.0f%% %10llu %8s\n",
                    mesh.at("id").get<std::string>().c_str(),
                    mesh.at("state").get<std::string>().c_str(),
                    100.0 * mesh.value("progress", 0.0),
                    static_cast<unsigned long long>(mesh.value("faces", std::uint64_t{0})),
                    samples.is_null() ? "-" : samples.dump().c_str());
      out += line;
    }
  } else {  // health, info
    append_object(out, result, "");
  }
  return out;
}

std::vector<double> field_distances(const nlohmann::json& result) {
  std::vector<double> distances;
  for (const auto& d : result.at("distances")) {
    distances.push_back(d.is_number() ? d.get<double>() : HUGE_VAL);  // null: not reached
  }
  return distances;
}

/// Writes the result of `field` or `path` to args.out (see the commands' --help).
void write_result_file(const std::string& command, const RemoteArgs& args,
                       const nlohmann::json& result, const std::optional<TriangleMesh>& mesh) {
  const std::string daemon = args.common.host + ":" + std::to_string(args.common.port);
  if (command == "field") {
    const std::vector<double> distances = field_distances(result);
    if (distances.size() != mesh->num_vertices()) {
      throw InvalidInput(ErrorCode::MeshMismatch, "--mesh-file " + args.mesh_file + " has " +
                                                      std::to_string(mesh->num_vertices()) +
                                                      " vertices but the daemon's '" + args.mesh +
                                                      "' has " + std::to_string(distances.size()) +
                                                      ": not the same mesh");
    }
    write_field_ply(args.out, *mesh, distances,
                    {"geoprox remote field of " + args.mesh + " from " + join_words(args.sources) +
                     " (daemon " +
                     daemon + ", geometry from " + args.mesh_file + ")"});
    print_diagnostic("field",
                     "wrote " + args.out + " (" + field_file_summary(*mesh, distances) + ")");
    return;
  }
  std::vector<Vec3> points;
  for (const auto& point : result.at("points")) {
    const auto& p = point.at("position");
    points.push_back({p.at(0).get<double>(), p.at(1).get<double>(), p.at(2).get<double>()});
  }
  std::string distance;
  append_number(distance, result.at("distance").get<double>());
  const std::string summary =
      "distance " + distance + ", " + std::to_string(points.size()) + " points";
  write_path_obj(args.out, points,
                 {"geoprox remote path on " + args.mesh + " from " + args.source + " to " +
                      args.target + " (daemon " + daemon + ")",
                  summary + " (mesh units)"});
  print_diagnostic("path", "wrote " + args.out + " (" + summary + ")");
}

void run_remote(const std::string& command, const RemoteArgs& args) {
  // The local mesh first: a wrong --mesh-file fails before anything is asked of the daemon.
  std::optional<TriangleMesh> mesh;
  if (command == "field" && !args.out.empty()) {
    mesh.emplace(load_command_mesh(args.mesh_file, args.repair).mesh);
  }
  client::Options options;
  options.connect_timeout_ms = args.common.timeout_ms;
  options.read_timeout_ms = args.common.timeout_ms;
  options.token = args.common.token;
  int exit_code = kExitOk;
  std::string diagnostic;
  try {
    client::Client client(args.common.host, static_cast<std::uint16_t>(args.common.port),
                          options);
    nlohmann::json result;
    if (command == "distance") {
      result = client.distance(args.mesh, args.source, args.target);
    } else if (command == "path") {
      result = client.path(args.mesh, args.source, args.target);
    } else if (command == "field") {
      result = client.field(args.mesh, args.sources, args.cutoff);
    } else if (command == "matrix") {
      result = client.matrix(args.mesh, args.sources, args.targets);
    } else if (command == "meshes") {
      result = client.mesh_list();
    } else if (command == "health") {
      result = client.health();
    } else {
      result = args.mesh.empty() ? client.server_info() : client.mesh_info(args.mesh);
    }
    if (args.out.empty()) {
      print(format_result(command, args, result));
    } else {
      write_result_file(command, args, result, mesh);
    }
    return;
  } catch (const client::ServerError& e) {
    exit_code = kExitServer;
    diagnostic = std::string(e.what()) + " [" + e.reason() + "]";
  } catch (const client::TimeoutError& e) {
    exit_code = kExitTimeout;
    diagnostic = std::string(e.what()) + " [Timeout]";
  } catch (const client::ConnectionError& e) {
    exit_code = kExitConnection;
    diagnostic = std::string(e.what()) + " [ConnectionFailed]";
  } catch (const nlohmann::json::exception& e) {
    exit_code = kExitConnection;
    diagnostic = std::string("unexpected reply from the server: ") + e.what() + " [BadReply]";
  }
  std::fflush(stdout);
  print_diagnostic("error", diagnostic);
  std::exit(exit_code);
}

}  // namespace

void add_client_commands(CLI::App& app, std::vector<Command>& commands) {
  const std::string point_help =
      "Points: v:ID, e:ID:t, f:ID:b0:b1:b2, s:SAMPLE or p:X,Y,Z (see docs/protocol.md).";
  CLI::App* remote = app.add_subcommand(
      "remote", "Query a geoproxd daemon (distance, path, field, matrix, meshes, health, info)");
  remote->require_subcommand(1);
  remote->footer(
      "Options --host (default $GEOPROX_HOST or 127.0.0.1), --port ($GEOPROX_PORT or 7878),\n"
      "--token ($GEOPROX_TOKEN: the query token of a daemon that has one), --timeout-ms and\n"
      "--json go after the subcommand, e.g.\n"
      "  geoprox remote distance spot v:0 f:100:0.2:0.3:0.5 --port 7878\n\n" +
      exit_code_footer());

  // Each subcommand has its own arguments: CLI11 applies --host/--port environment defaults to
  // the subcommands not given too, which must not overwrite the given one's values.
  struct Child {
    CLI::App* app;
    std::string name;
    std::shared_ptr<RemoteArgs> args;
  };
  std::vector<Child> children;
  std::shared_ptr<RemoteArgs> args;
  auto add = [&](const std::string& name, const std::string& description,
                 const std::string& footer) {
    CLI::App* sub = remote->add_subcommand(name, description);
    args = std::make_shared<RemoteArgs>();
    add_common(sub, args->common);
    sub->footer(footer + (footer.empty() ? "" : "\n\n") + exit_code_footer());
    children.push_back({sub, name, args});
    return sub;
  };

  CLI::App* distance = add("distance", "Geodesic distance between two points",
                           point_help + "\nOutput: 'distance D' and 'exact yes|no'.");
  distance->add_option("MESH_ID", args->mesh, "Mesh id on the daemon")->required();
  distance->add_option("SOURCE", args->source, "Source point")->required();
  distance->add_option("TARGET", args->target, "Target point")->required();

  CLI::App* path = add("path", "Shortest path between two points",
                       point_help +
                           "\nOutput: 'distance D', then one line per path point from source to\n"
                           "target: 'f:FACE:b0:b1:b2 X Y Z'.");
  path->add_option("MESH_ID", args->mesh, "Mesh id on the daemon")->required();
  path->add_option("SOURCE", args->source, "Source point")->required();
  path->add_option("TARGET", args->target, "Target point")->required();
  path->add_option("-o,--out", args->out,
                   "Write the path as an OBJ polyline ('v X Y Z' per point, one 'l' line)\n"
                   "instead of printing it");

  CLI::App* field = add("field", "Distance of every vertex from the nearest source",
                        point_help +
                            "\nOutput: one distance per vertex in vertex order ('inf' where not\n"
                            "reached); with --csv 'VERTEX,DISTANCE[,NEAREST_SOURCE]'.\n" +
                            field_ply_footer() +
                            "\nThe daemon sends distances only: --out needs --mesh-file, a local\n"
                            "copy of the mesh file the daemon serves (same vertices, same order;\n"
                            "with --repair when the daemon repairs it).");
  field->add_option("MESH_ID", args->mesh, "Mesh id on the daemon")->required();
  field->add_option("SOURCE", args->sources, "Source point(s)")->required();
  field->add_option("--cutoff", args->cutoff, "Vertices farther than this are not reached")
      ->check(CLI::PositiveNumber);
  field->add_flag("--csv", args->csv, "Comma-separated lines with the vertex index");
  CLI::Option* mesh_file =
      field->add_option("--mesh-file", args->mesh_file,
                        "Local copy of the daemon's mesh file: its geometry, for --out");
  field->add_option("-o,--out", args->out, "Write the mesh with the field as a PLY file instead")
      ->needs(mesh_file);
  field
      ->add_flag("--repair", args->repair,
                 "Load --mesh-file repaired, as a daemon whose mesh has \"repair\": true serves "
                 "it")
      ->needs(mesh_file);

  CLI::App* matrix = add("matrix", "Distances from every source to every target",
                         point_help +
                             "\nOutput: one row per source, one column per target ('inf' when\n"
                             "unreachable), space- or (--csv) comma-separated.");
  matrix->add_option("MESH_ID", args->mesh, "Mesh id on the daemon")->required();
  matrix->add_option("--sources", args->sources, "Source points")->required();
  matrix->add_option("--targets", args->targets, "Target points")->required();
  matrix->add_flag("--csv", args->csv, "Comma-separated rows");

  add("meshes", "The daemon's meshes: id, state, build progress, faces, samples", "");
  add("health", "The daemon's health: status, meshes ready, uptime, requests in flight", "");
  CLI::App* info = add("info", "The daemon's version and limits, or one mesh's details", "");
  info->add_option("MESH_ID", args->mesh, "Mesh id (omit for the server itself)");

  commands.push_back({remote, [children] {
                        for (const Child& child : children) {
                          if (child.app->parsed()) run_remote(child.name, *child.args);
                        }
                      }});
}

}  // namespace geoprox::cli
