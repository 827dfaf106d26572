// Mesh files as every command of `geoprox` loads them: as they are, or repaired with --repair
// (core/mesh/mesh_io.h load_mesh_file, core/mesh/mesh_repair.h), saying what repair changed.
#include <CLI/CLI.hpp>
#include <memory>
#include <optional>
#include <string>

#include "clients/cli/cli.h"
#include "core/graph/loaded_graph.h"
#include "core/mesh/mesh_io.h"
#include "core/mesh/mesh_repair.h"

namespace geoprox::cli {

void add_repair_flag(CLI::App& command, bool& repair) {
  command.add_flag("--repair", repair,
                   "Load MESH repaired, as 'geoprox repair' writes it (same ids), instead of "
                   "refusing a mesh that is not an oriented manifold; what changed is printed on "
                   "stderr");
}

void report_repair(const std::string& mesh_path, const std::optional<MeshRepairReport>& report) {
  if (!report || report->unchanged()) return;
  print_diagnostic("repaired " + mesh_path, describe_repair_changes(*report));
}

LoadedMeshFile load_command_mesh(const std::string& path, bool repair) {
  LoadedMeshFile file = load_mesh_file(path, MeshLoadOptions{.repair = repair});
  report_repair(path, file.repair);
  return file;
}

std::shared_ptr<MeshData> load_command_mesh_data(const std::string& path,
                                                 const std::string& metric_path, bool repair) {
  std::shared_ptr<MeshData> data =
      MeshData::load(path, metric_path, MeshLoadOptions{.repair = repair});
  report_repair(path, data->repair);
  return data;
}

}  // namespace geoprox::cli
