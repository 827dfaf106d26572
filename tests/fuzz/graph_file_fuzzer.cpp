// libFuzzer target: the graph-file opener (core/graph/graph_file.h) on hostile bundles, then what
// the server does with a bundle that opened (rebuild its mesh and geometry, verify_mesh).
//
// Input: the file's bytes. The structure is opened without the checksum (a mutated file would
// never get past the hash otherwise): what must hold then is that every id, offset and count
// the queries will follow lies in range. A file that opens is opened again with the checksum,
// which may only add ChecksumMismatch. Seeds: graph files that scripts/fuzz builds with
// `geoprox build` from small meshes.
//
// Findings: any crash, sanitizer report or hang, any exception other than the documented
// FileError / MeshError, and an opened file whose views break the documented invariants.
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "core/base/errors.h"
#include "core/graph/graph_file.h"
#include "core/graph/graph_file_format.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

const geoprox::fuzz::ScratchDirectory scratch;

/// A CSR row array over `rows` rows and `entries` entries: starts at 0, never decreases, ends
/// at the number of entries.
bool is_csr(std::span<const std::uint32_t> offsets, std::size_t rows, std::size_t entries) {
  if (offsets.size() != rows + 1 || offsets[0] != 0 || offsets[rows] != entries) return false;
  for (std::size_t i = 0; i < rows; ++i) {
    if (offsets[i + 1] < offsets[i]) return false;
  }
  return true;
}

void check_opened(const geoprox::MappedGraphFile& file) {
  // What `geoprox inspect` prints.
  GEOPROX_FUZZ_CHECK(file.source_mesh().size() <= sizeof file.header().source_mesh, "name");
  GEOPROX_FUZZ_CHECK(file.params().num_samples == file.counts().samples, "n_P = samples");
  const geoprox::ProximityGraphView view = file.view();
  GEOPROX_FUZZ_CHECK(!(view.error_bound() < 0), "error bound >= 0");
  const std::size_t nv = file.positions().size(), nf = file.faces().size();
  GEOPROX_FUZZ_CHECK(view.num_vertices == nv, "vertex count");
  GEOPROX_FUZZ_CHECK(view.sample_vertex.size() == view.num_samples, "sample count");
  for (const geoprox::Triangle& t : file.faces()) {
    GEOPROX_FUZZ_CHECK(t[0] < nv && t[1] < nv && t[2] < nv, "face ids in range");
  }
  for (std::uint32_t v : view.sample_vertex) GEOPROX_FUZZ_CHECK(v < nv, "sample vertex");
  GEOPROX_FUZZ_CHECK(is_csr(view.edge_offsets, view.num_samples, view.num_edges()),
                     "edge_offsets is CSR");
  GEOPROX_FUZZ_CHECK(view.edge_distance.size() == view.num_edges() &&
                         view.edge_direction.size() == view.num_edges(),
                     "edge arrays sizes");
  for (std::uint32_t j : view.edge_target) GEOPROX_FUZZ_CHECK(j < view.num_samples, "edge target");
  for (const geoprox::GraphDirection& d : view.edge_direction) {
    GEOPROX_FUZZ_CHECK(d.face < nf, "direction face");
  }
  GEOPROX_FUZZ_CHECK(is_csr(view.cover_offsets, nv, view.cover_sample.size()),
                     "cover_offsets is CSR");
  GEOPROX_FUZZ_CHECK(view.cover_distance.size() == view.cover_sample.size(), "cover sizes");
  for (std::uint32_t s : view.cover_sample) GEOPROX_FUZZ_CHECK(s < view.num_samples, "cover");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = scratch.write("input.gpg", data, size);
  geoprox::MappedGraphFile file;
  try {
    file = geoprox::MappedGraphFile::open(path, {.verify_checksum = false});
  } catch (const geoprox::FileError&) {
    return 0;
  }
  check_opened(file);
  try {
    geoprox::MappedGraphFile::open(path, {.verify_checksum = true});
  } catch (const geoprox::FileError& e) {
    GEOPROX_FUZZ_CHECK(e.reason() == "ChecksumMismatch", e.reason() + ": " + e.what());
  }
  try {
    // What a server does with an opened bundle next (and `geoprox inspect --verify`).
    const geoprox::TriangleMesh mesh = file.make_mesh();
    const geoprox::IntrinsicGeometry geometry = file.make_geometry(mesh);
    file.verify_mesh(mesh, geometry);
  } catch (const geoprox::MeshError&) {
    // The stored faces or lengths do not make a valid mesh (non-manifold, triangle inequality).
  } catch (const geoprox::FileError& e) {
    GEOPROX_FUZZ_CHECK(e.reason() == "MeshMismatch", e.reason() + ": " + e.what());
  }
  return 0;
}
