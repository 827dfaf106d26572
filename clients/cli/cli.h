// Shared declarations of the `geoprox` command-line tool.
//
// main.cpp owns the CLI11 application and turns exceptions into exit codes. Each command group
// registers its subcommands and what they run, in the order of `geoprox --help`:
//   offline_commands.cpp      info, exact, repair, refine (core directly, no graph)
//   graph_commands.cpp        build, inspect (proximity-graph files)
//   query_commands.cpp        distance, field, path, render (queries on a built graph)
//   eval_command.cpp          eval (accuracy against the exact solver, timings)
//   application_commands.cpp  expmap, spline
//   client_commands.cpp       remote (distance, path, field, matrix, meshes, health, info on a
//                             geoproxd daemon)
// output.cpp writes results to standard output or, all or nothing, to a file; result_files.cpp
// and render.cpp write PLY, OBJ and PNG files; mesh_loading.cpp loads mesh files as every
// command does (--repair).
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/graph/loaded_graph.h"
#include "core/mesh/mesh.h"
#include "core/mesh/mesh_io.h"
#include "core/mesh/mesh_repair.h"
#include "core/mesh/surface_point.h"

namespace CLI {
class App;
}

namespace geoprox::cli {

/// The project's version: project(VERSION) in the top-level CMakeLists.txt, given by
/// clients/cli/CMakeLists.txt as GEOPROX_VERSION.
inline constexpr const char* kVersion = GEOPROX_VERSION;

/// Exit codes of `geoprox`, documented in the --help footer.
enum ExitCode : int {
  kExitOk = 0,
  kExitUsage = 1,     ///< the command line was not understood (unknown option, missing argument)
  kExitInput = 2,     ///< input or output error: file, mesh, point syntax, id out of range
  kExitInternal = 3,  ///< a bug in geoprox (failed internal check, unexpected exception)
};

/// The --help footer that lists the exit codes.
std::string exit_code_footer();

/// A registered subcommand: `run` is called once parsing succeeded and `app` was selected.
/// It throws geoprox::Error (or another exception) on failure.
struct Command {
  CLI::App* app = nullptr;
  std::function<void()> run;
};

/// Adds the offline commands (`info`, `exact`, `repair`, `refine`), which call geoprox::core
/// directly.
void add_offline_commands(CLI::App& app, std::vector<Command>& commands);

/// Adds the proximity-graph commands (`build`, `inspect`).
void add_graph_commands(CLI::App& app, std::vector<Command>& commands);

/// Writes `text` to standard output if `out_path` is empty, else to `out_path` atomically.
/// Throws FileError (WriteFailed) on any failure.
void write_output(const std::string& text, const std::string& out_path);
/// Writes `text` atomically to `out_path` if --out was on the command line (`out_given`: an
/// empty path is then a FileError, not standard output), else to standard output.
void write_result(const std::string& text, const std::string& out_path, bool out_given);

/// Writes `text` to a temporary file in the directory of `path`, flushes it to disk and renames
/// it over `path`: readers see the old content or the whole new one, never half a file. On
/// failure the temporary file is removed, `path` is untouched, and FileError is thrown.
void write_file_atomically(const std::string& path, const std::string& text);

/// Parses a point given to `option` (v:/e:/f: syntax); the error names the option.
SurfacePoint parse_point(const std::string& option, const std::string& text);
/// Checks a parsed point against the mesh; the error names the option and the text as given.
void validate_point(const std::string& option, const std::string& text, const SurfacePoint& point,
                    const TriangleMesh& mesh);
/// CLI11 check for --radius-like options: a number >= 0, `inf` allowed.
std::string check_radius(const std::string& text);
/// %.17g, with infinity spelt `inf` whatever the C library does.
void append_number(std::string& out, double value);
/// The words separated by single spaces ("v:0 v:5").
std::string join_words(const std::vector<std::string>& words);

/// Adds the query commands on a built graph (`distance`, `field`, `path`, `render`).
void add_query_commands(CLI::App& app, std::vector<Command>& commands);

/// Adds `eval` (clients/cli/eval_command.cpp).
void add_eval_command(CLI::App& app, std::vector<Command>& commands);

/// --metric on a command that reads a graph: the graph's edge lengths must be the mesh's under
/// that metric (docs/metrics.md), else opening it fails with MeshMismatch.
void add_metric_option(CLI::App& command, std::string& metric);

/// Adds `expmap` and `spline` (clients/cli/application_commands.cpp).
void add_application_commands(CLI::App& app, std::vector<Command>& commands);

/// Adds `remote`, the client of a geoproxd daemon (clients/cli/client_commands.cpp).
void add_client_commands(CLI::App& app, std::vector<Command>& commands);

/// Prints `geoprox: <label>: <message>` as exactly one line on standard error.
void print_diagnostic(const std::string& label, const std::string& message);

/// --repair on a command that reads a mesh file: load it repaired (core/mesh/mesh_repair.h) instead
/// of refusing a mesh that is not an oriented manifold. Ids are those of the file `geoprox repair`
/// writes, so a graph built with --repair is queried with --repair.
void add_repair_flag(CLI::App& command, bool& repair);
/// When `report` changed something, says what on standard error, one line:
/// "geoprox: repaired MESH: 2 edges cut, 5 vertices split (+5 copies)".
void report_repair(const std::string& mesh_path, const std::optional<MeshRepairReport>& report);
/// load_mesh_file with --repair's options, then report_repair.
LoadedMeshFile load_command_mesh(const std::string& path, bool repair);
/// MeshData::load (the mesh under its optional metric) with --repair's options, then
/// report_repair.
std::shared_ptr<MeshData> load_command_mesh_data(const std::string& path,
                                                 const std::string& metric_path, bool repair);

}  // namespace geoprox::cli
