// The graph file's shared pieces: the layout's compile-time checks, section names, the hash and
// the mesh fingerprint. The writer, the reader, the consistency checks and the text format are in
// graph_file_writer.cpp, graph_file_reader.cpp, graph_file_checks.cpp and graph_file_text.cpp.
#include "core/graph/graph_file.h"

#include <bit>
#include <cstddef>
#include <limits>
#include <type_traits>

#include "core/graph/graph_file_format.h"
#include "core/graph/graph_file_internal.h"

namespace geoprox {

static_assert(std::endian::native == std::endian::little,
              "graph files are little-endian and mapped in place: big-endian hosts would need a "
              "byte-swapping reader");
// The arrays are used in place, so the in-memory element types must have the on-disk layout.
static_assert(sizeof(GraphDirection) == 12 && alignof(GraphDirection) == 4);
static_assert(offsetof(GraphDirection, face) == 0 && offsetof(GraphDirection, x) == 4 &&
              offsetof(GraphDirection, y) == 8);
static_assert(std::is_trivially_copyable_v<GraphDirection>);
static_assert(sizeof(Vec3) == 24 && alignof(Vec3) == 8 && std::is_trivially_copyable_v<Vec3>);
static_assert(sizeof(Triangle) == 12 && alignof(Triangle) == 4);
static_assert(sizeof(float) == 4 && std::numeric_limits<float>::is_iec559);
static_assert(sizeof(double) == 8 && std::numeric_limits<double>::is_iec559);
static_assert(offsetof(GraphFileHeader, version) == 8);
static_assert(offsetof(GraphFileHeader, endian_marker) == 12);
static_assert(offsetof(GraphFileHeader, header_size) == 16);
static_assert(offsetof(GraphFileHeader, file_size) == 24);
static_assert(offsetof(GraphFileHeader, param_samples) == 32);
static_assert(offsetof(GraphFileHeader, longest_edge) == 48);
static_assert(offsetof(GraphFileHeader, num_vertices) == 64);
static_assert(offsetof(GraphFileHeader, mesh_fingerprint) == 112);
static_assert(offsetof(GraphFileHeader, source_mesh) == 128);

std::string_view graph_file_section_name(std::uint32_t id) {
  using namespace graph_file_detail;
  if (const int k = section_index(id); k >= 0) return kSections[k].name;
  if (const int k = refinement_section_index(id); k >= 0) return kRefinementSections[k].name;
  return "unknown";
}

std::uint64_t graph_file_hash(const void* data, std::size_t size, std::uint64_t seed) {
  graph_file_detail::StreamHash h(seed);
  h.update(data, size);
  return h.finish();
}

std::uint64_t mesh_fingerprint(const TriangleMesh& mesh, const IntrinsicGeometry& geometry) {
  graph_file_detail::StreamHash h(kMeshFingerprintSeed);
  const std::uint64_t counts[3] = {mesh.num_vertices(), mesh.num_faces(),
                                   geometry.edge_lengths().size()};
  h.update(counts, sizeof counts);
  h.update(mesh.faces().data(), mesh.faces().size() * sizeof(Triangle));
  h.update(geometry.edge_lengths().data(), geometry.edge_lengths().size() * sizeof(double));
  return h.finish();
}

}  // namespace geoprox
