// Shared declarations of the `geoprox` command-line tool (no paper).
//
// main.cpp owns the CLI11 application and turns exceptions into exit codes; each command group
// (offline_commands.cpp: `info`, `exact`) registers its subcommands and what they run; output.cpp
// writes results to standard output or, all or nothing, to a file.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace CLI {
class App;
}

namespace geoprox::cli {

/// Keep in step with project(VERSION) in the top-level CMakeLists.txt (tests/cli checks it).
inline constexpr const char* kVersion = "0.1.0";

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

/// Adds the offline commands (`info`, `exact`), which call geoprox::core directly.
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

/// Adds the query commands on a built graph (`distance`, `field`, `eval`).
void add_query_commands(CLI::App& app, std::vector<Command>& commands);

/// Adds `expmap` and `spline` (clients/cli/application_commands.cpp).
void add_application_commands(CLI::App& app, std::vector<Command>& commands);

/// Adds `remote`, the client of a geoproxd daemon (clients/cli/client_commands.cpp).
void add_client_commands(CLI::App& app, std::vector<Command>& commands);

/// Prints `geoprox: <label>: <message>` as exactly one line on standard error.
void print_diagnostic(const std::string& label, const std::string& message);

}  // namespace geoprox::cli
