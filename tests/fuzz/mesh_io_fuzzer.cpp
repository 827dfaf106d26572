// libFuzzer target: the mesh loaders (core/mesh/mesh_io.h) on hostile files, then what `geoprox
// info` computes from a mesh that loaded (core/mesh/mesh_report.h), what `geoprox refine` makes of
// it (core/mesh/mesh_refinement.h), and what `geoprox repair` makes of the file
// (core/mesh/mesh_repair.h).
//
// Input: one selector byte, then the file's bytes. The selector picks the extension, which is
// what picks the reader: 0 .obj, 1 .off, 2 .ply (ascii or binary, from its header), 3 .stl
// (ascii or binary, from its size); other values wrap around. scripts/fuzz prefixes the seeds
// from tests/data/ accordingly.
//
// Findings: any crash, sanitizer report or hang, any exception other than the documented
// FileError / MeshError, a loaded mesh that breaks what load_mesh promises, a soup whose
// triangles do not map to the file's polygons by the id rule (mesh_io.h), a refined mesh that
// does not load or keeps an edge over its limit, a repaired mesh that does not load, and a
// repair that changes a mesh that loaded.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

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

// The id rule of mesh_io.h: without polygons, one face record per triangle; with them, each
// triangle's record in file order, record k of c corners giving c - 2 consecutive triangles.
void check_face_polygons(const geoprox::MeshSoup& soup) {
  if (soup.face_polygon.empty()) {
    GEOPROX_FUZZ_CHECK(soup.polygons == soup.faces.size(), "one record per triangle");
    return;
  }
  GEOPROX_FUZZ_CHECK(soup.face_polygon.size() == soup.faces.size(), "a record per triangle");
  GEOPROX_FUZZ_CHECK(
      soup.face_polygon.front() == 0 && soup.face_polygon.back() + 1 == soup.polygons,
      "records from the first to the last");
  std::size_t run = 1;  // triangles of the current record so far
  for (std::size_t f = 1; f <= soup.faces.size(); ++f) {
    if (f < soup.faces.size() && soup.face_polygon[f] == soup.face_polygon[f - 1]) {
      ++run;
      continue;
    }
    // The record that ends at f - 1 had run + 2 distinct corners, and its triangles use them.
    std::vector<std::uint32_t> corners;
    for (std::size_t t = f - run; t < f; ++t) {
      corners.insert(corners.end(), soup.faces[t].begin(), soup.faces[t].end());
    }
    std::sort(corners.begin(), corners.end());
    corners.erase(std::unique(corners.begin(), corners.end()), corners.end());
    GEOPROX_FUZZ_CHECK(corners.size() == run + 2, "a polygon of c corners gives c - 2 triangles");
    if (f < soup.faces.size()) {
      GEOPROX_FUZZ_CHECK(soup.face_polygon[f] == soup.face_polygon[f - 1] + 1,
                         "records in file order, none without triangles");
    }
    run = 1;
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
  check_face_polygons(soup);
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
