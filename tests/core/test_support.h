// Small helpers shared by the core test files (formatting, bitwise comparison of arrays and of
// proximity graphs, the shipped sample meshes). Header-only, like test_meshes.h.
#pragma once

#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/mesh/mesh_io.h"
#include "core/graph/proximity_graph.h"
#include "tests/core/test_meshes.h"

namespace geoprox::test_support {

/// A double at full precision, for failure messages.
inline std::string fmt(double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

/// Same length and the same bytes (element types of the same size).
template <typename T, typename U>
bool same_bits(std::span<const T> a, const std::vector<U>& b) {
  static_assert(sizeof(T) == sizeof(U));
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}
template <typename T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return same_bits(std::span<const T>(a), b);
}

/// Every array and scalar of the view equals the graph's, bit for bit.
inline void expect_same_graph(const ProximityGraphView& v, const ProximityGraph& g) {
  EXPECT_EQ(v.num_vertices, g.num_vertices);
  EXPECT_EQ(v.num_samples, g.sample_vertex.size());
  EXPECT_EQ(v.neighbors, g.neighbors);
  EXPECT_EQ(std::bit_cast<std::uint64_t>(v.longest_edge),
            std::bit_cast<std::uint64_t>(g.longest_edge));
  EXPECT_EQ(std::bit_cast<std::uint64_t>(v.covering_radius),
            std::bit_cast<std::uint64_t>(g.covering_radius));
  EXPECT_EQ(std::bit_cast<std::uint64_t>(v.link_radius),
            std::bit_cast<std::uint64_t>(g.link_radius));
  EXPECT_TRUE(same_bits(v.sample_vertex, g.sample_vertex));
  EXPECT_TRUE(same_bits(v.edge_offsets, g.edge_offsets));
  EXPECT_TRUE(same_bits(v.edge_target, g.edge_target));
  EXPECT_TRUE(same_bits(v.edge_distance, g.edge_distance));
  EXPECT_TRUE(same_bits(v.edge_direction, g.edge_direction));
  EXPECT_TRUE(same_bits(v.cover_offsets, g.cover_offsets));
  EXPECT_TRUE(same_bits(v.cover_sample, g.cover_sample));
  EXPECT_TRUE(same_bits(v.cover_distance, g.cover_distance));
}

/// Path of a file of tests/data/ (small hand-made meshes, good and bad).
inline std::string test_data_file(const std::string& name) {
  return std::string(GEOPROX_SOURCE_DIR) + "/tests/data/" + name;
}
/// Path of a mesh of data/meshes/ (the repository's own copies).
inline std::string shipped_mesh_file(const std::string& name) {
  return std::string(GEOPROX_SOURCE_DIR) + "/data/meshes/" + name;
}

/// Folder of the optional corpus of larger and non-redistributable meshes: $GEOPROX_SHARED_MESHES
/// if set, else ../shared/meshes beside the source tree (present on the project's machines and
/// in CI, absent from a clone elsewhere).
inline std::string corpus_dir() {
  if (const char* env = std::getenv("GEOPROX_SHARED_MESHES"); env && *env) return env;
  return GEOPROX_SHARED_MESHES;
}
/// Path of a mesh of the optional corpus, or nothing when it is absent.
inline std::optional<std::string> corpus_mesh_file(const std::string& name) {
  const std::string path = corpus_dir() + "/" + name;
  if (std::filesystem::exists(path)) return path;
  return std::nullopt;
}
/// The one-line reason a test that needs the corpus skips without it.
inline std::string corpus_skip_reason(const std::string& name) {
  return "needs " + name + " of the optional mesh corpus, absent at " + corpus_dir() +
         " (set GEOPROX_SHARED_MESHES)";
}

/// A mesh of data/meshes/, loaded once per call.
inline test_meshes::TestMesh shipped_mesh(const std::string& name) {
  const std::string path = shipped_mesh_file(name);
  test_meshes::TestMesh out;
  out.mesh = std::make_unique<TriangleMesh>(load_mesh(path));
  out.geometry = std::make_unique<IntrinsicGeometry>(*out.mesh);
  return out;
}

/// spot.obj (5,856 faces), loaded once for the whole test binary.
inline const test_meshes::TestMesh& spot() {
  static const test_meshes::TestMesh m = shipped_mesh("spot.obj");
  return m;
}

}  // namespace geoprox::test_support
