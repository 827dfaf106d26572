// `geoprox`: the command-line tool (CLI11 subcommands). Turns every failure into one line on
// standard error and a documented exit code (see exit_code_footer()).
#include <CLI/CLI.hpp>
#include <exception>
#include <new>
#include <string>
#include <vector>

#include "clients/cli/cli.h"
#include "core/base/errors.h"
#include "core/mesh/mesh_repair.h"

namespace geoprox::cli {

std::string exit_code_footer() {
  return "Exit codes:\n"
         "  0  success (an unreachable --to point is a valid answer: distance inf)\n"
         "  1  usage error: the command line was not understood\n"
         "  2  input or output error: missing or unreadable file, bad mesh, bad point\n"
         "     syntax, id out of range, output not writable\n"
         "  3  internal error: a bug in geoprox\n"
         "  4  remote: cannot connect to the daemon, or the connection was lost\n"
         "  5  remote: timeout (no connection or no reply within --timeout-ms)\n"
         "  6  remote: the daemon answered with an error (its reason in brackets)\n"
         "Errors are reported as one line on standard error: 'geoprox: error: ...'.";
}

}  // namespace geoprox::cli

int main(int argc, char** argv) {
  using namespace geoprox::cli;

  CLI::App app{
      "geoprox: geodesic distances and shortest paths on triangle meshes.\n"
      "Points are written v:ID (a vertex), e:ID:t (the point at t in [0,1] along an edge) or\n"
      "f:ID:b0:b1:b2 (barycentrics in the order of the face's vertices in the file); ids are\n"
      "0-based file order.",
      "geoprox"};
  app.set_version_flag("--version", std::string("geoprox ") + kVersion);
  app.require_subcommand(1);
  app.footer(exit_code_footer());

  std::vector<Command> commands;
  add_offline_commands(app, commands);
  add_graph_commands(app, commands);
  add_query_commands(app, commands);
  add_eval_command(app, commands);
  add_application_commands(app, commands);
  add_client_commands(app, commands);

  // CLI11 would report an unknown command as "A subcommand is required": name it instead.
  if (argc > 1 && argv[1][0] != '-') {
    const std::string name = argv[1];
    bool known = false;
    for (const Command& command : commands) known = known || command.app->get_name() == name;
    if (!known) {
      std::string names;
      for (const Command& command : commands) {
        names += (names.empty() ? "" : ", ") + command.app->get_name();
      }
      print_diagnostic("error", "unknown command '" + name + "' (commands: " + names +
                                    "; see 'geoprox --help')");
      return kExitUsage;
    }
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) {
      return app.exit(e);  // --help, --version
    }
    print_diagnostic("error", std::string(e.what()) + " (see 'geoprox --help')");
    return kExitUsage;
  }

  try {
    for (const Command& command : commands) {
      if (command.app->parsed()) {
        command.run();
        return kExitOk;
      }
    }
    print_diagnostic("error", "no command given (see 'geoprox --help')");
    return kExitUsage;
  } catch (const geoprox::InternalError& e) {
    print_diagnostic("error", std::string("internal error: ") + e.what() + " (a bug in geoprox)");
    return kExitInternal;
  } catch (const geoprox::Error& e) {
    std::string hint;
    if (dynamic_cast<const geoprox::MeshError*>(&e) && geoprox::repair_fixes(e.code())) {
      hint = " (--repair loads it repaired; 'geoprox repair MESH -o OUT.obj' writes that copy)";
    }
    print_diagnostic("error", std::string(e.what()) + " [" + e.reason() + "]" + hint);
    return kExitInput;
  } catch (const std::bad_alloc&) {
    print_diagnostic("error", "out of memory [ResourceExhausted]");
    return kExitInput;
  } catch (const std::exception& e) {
    print_diagnostic("error", std::string("internal error: ") + e.what());
    return kExitInternal;
  }
}
