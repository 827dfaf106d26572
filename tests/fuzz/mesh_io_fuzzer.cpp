// libFuzzer target: the mesh loaders (core/mesh/mesh_io.h) on hostile files, then what `geoprox info`
// computes from a mesh that loaded (core/mesh/mesh_report.h), what `geoprox refine` makes of it
// (core/mesh/mesh_refinement.h), and what `geoprox repair` makes of the file (core/mesh/mesh_repair.h).
//
// Input: one selector byte, then the file's bytes. The selector picks the extension, which is
// what picks the reader: 0 .obj, 1 .off, 2 .ply (ascii or binary, from its header), 3 .stl
// (ascii or binary, from its size); other values wrap around. scripts/fuzz prefixes the seeds
// from tests/data/ accordingly.
//
// Findings: any crash, sanitizer report or hang, any exception other than the documented
// FileError / MeshError, a loaded mesh that breaks what load_mesh promises, a refined mesh that
// does not load or keeps an edge over its limit, a repaired mesh that does not load, and a
// repair that changes a mesh that loaded.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/base/errors.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/mesh_io.h"
#include "core/mesh/mesh_refinement.h"
#include "core/mesh/mesh_repair.h"
#include "core/mesh/mesh_report.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

const geoprox::fuzz::ScratchDirectory scratch;

void check_loaded_mesh(const geoprox::TriangleMesh& mesh) {
  GEOPROX_FUZZ_CHECK(mesh.num_faces() > 0, "a loaded mesh has faces");
  for (const geoprox::Vec3& p : mesh.positions()) {
    GEOPROX_FUZZ_CHECK(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z),
                       "finite coordinates");
  }
  for (const geoprox::Triangle& t : mesh.faces()) {
    GEOPROX_FUZZ_CHECK(t[0] < mesh.num_vertices() && t[1] < mesh.num_vertices() &&
                           t[2] < mesh.num_vertices(),
                       "face ids in range");
    GEOPROX_FUZZ_CHECK(t[0] != t[1] && t[1] != t[2] && t[2] != t[0], "distinct corners");
  }
}

// What `geoprox refine` does with a mesh that loaded, to edges of 0.75 mean edge lengths (or
// refuses: RefinementTooLarge past a few thousand faces): the result loads and keeps no edge
// longer, nor moves the input's vertices.
void check_refine(const geoprox::TriangleMesh& mesh, const geoprox::IntrinsicGeometry& geometry) {
  geoprox::MeshRefinementOptions options;
  options.max_edge_length = 0.75 * geometry.mean_edge_length();
  options.max_faces = 4 * mesh.num_faces() + 4000;
  if (!(std::isfinite(options.max_edge_length) && options.max_edge_length > 0)) return;
  geoprox::RefinedMesh refined;
  try {
    refined = geoprox::refine_long_edges(mesh, options);
  } catch (const geoprox::InvalidInput&) {
    return;  // too many faces
  }
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    const geoprox::Vec3 &a = refined.positions[v], &b = mesh.position(v);
    GEOPROX_FUZZ_CHECK(a.x == b.x && a.y == b.y && a.z == b.z, "refine keeps the input's vertices");
  }
  for (const geoprox::Triangle& t : refined.faces) {
    for (int k = 0; k < 3; ++k) {
      GEOPROX_FUZZ_CHECK(geoprox::norm(refined.positions[t[k]] - refined.positions[t[(k + 1) % 3]]) <=
                             options.max_edge_length,
                         "no refined edge over the limit");
    }
  }
  try {
    check_loaded_mesh(geoprox::TriangleMesh(refined.positions, refined.faces));
  } catch (const geoprox::MeshError&) {
    GEOPROX_FUZZ_CHECK(false, "a refined mesh loads");
  }
}

// What `geoprox repair` does with the file: its result loads, and equals a mesh that loaded.
void check_repair(const std::string& path, bool loaded) {
  geoprox::MeshSoup soup;
  try {
    soup = geoprox::load_mesh_soup(path);
  } catch (const geoprox::Error&) {
    GEOPROX_FUZZ_CHECK(!loaded, "a file that loads reads as a soup");
    return;
  }
  if (soup.faces.empty()) return;  // EmptyMesh, as load_mesh says
  const geoprox::RepairedMesh repaired = geoprox::repair_mesh(soup.positions, soup.faces);
  if (loaded) {
    GEOPROX_FUZZ_CHECK(repaired.report.unchanged() && repaired.faces == soup.faces &&
                           repaired.positions.size() == soup.positions.size(),
                       "repair leaves a mesh that loads as it is");
  }
  if (repaired.faces.empty()) return;  // every face repeated a vertex
  try {
    check_loaded_mesh(geoprox::TriangleMesh(repaired.positions, repaired.faces));
  } catch (const geoprox::MeshError&) {
    GEOPROX_FUZZ_CHECK(false, "a repaired mesh loads");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  static const char* const kNames[] = {"input.obj", "input.off", "input.ply", "input.stl"};
  const std::string path = scratch.write(kNames[data[0] % 4], data + 1, size - 1);
  bool loaded = false;
  try {
    const geoprox::TriangleMesh mesh = geoprox::load_mesh(path);
    loaded = true;
    check_loaded_mesh(mesh);
    // What `geoprox info` does next. Geometry may still refuse the mesh (edge lengths that
    // overflow to infinity): a MeshError, caught below.
    const geoprox::IntrinsicGeometry geometry(mesh);
    const geoprox::MeshReport report = geoprox::compute_mesh_report(mesh, geometry);
    GEOPROX_FUZZ_CHECK(report.vertices == mesh.num_vertices() &&
                           report.faces == mesh.num_faces() && report.edges == mesh.num_edges(),
                       "report counts match the mesh");
    GEOPROX_FUZZ_CHECK(report.components >= 1 && report.components <= mesh.num_faces(),
                       "components in [1, faces]");
    GEOPROX_FUZZ_CHECK(report.genus_per_component.size() == report.components,
                       "one genus per component");
    GEOPROX_FUZZ_CHECK(!geoprox::format_mesh_report(report).empty(), "a report text");
    check_refine(mesh, geometry);
  } catch (const geoprox::FileError&) {
  } catch (const geoprox::MeshError&) {
  }
  check_repair(path, loaded);
  return 0;
}
