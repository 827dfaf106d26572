// Tests of core/graph/graph_file.h: the binary bundle (round trip, layout, every kind of damaged
// file, atomic writes, moves), the paper's text format, and the open time of a ~100k-face bundle.
// Graphs are built by hand here (consistent CSR arrays, random but valid directions), so these
// tests do not depend on the proximity-graph builder.
#include "core/graph/graph_file.h"

#include <gtest/gtest.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/base/errors.h"
#include "core/graph/graph_file_format.h"
#include "tests/core/test_meshes.h"
#include "tests/core/test_support.h"

namespace geoprox {
namespace {

namespace fs = std::filesystem;
namespace tm = test_meshes;
using test_support::expect_same_graph;
using test_support::same_bits;

// ---------------------------------------------------------------------------------------------
// Helpers

class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "geoprox-graph-file-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::set<std::string> listing() const {
    std::set<std::string> names;
    for (const auto& entry : fs::directory_iterator(path_)) {
      names.insert(entry.path().filename().string());
    }
    return names;
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::vector<unsigned char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const std::string& path, const std::vector<unsigned char>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

// Pages of `path` in the page cache (mincore over a mapping of the whole file).
long resident_pages(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error("cannot open " + path);
  const auto size = static_cast<std::size_t>(fs::file_size(path));
  void* map = ::mmap(nullptr, size, PROT_READ, MAP_SHARED, fd, 0);
  ::close(fd);
  if (map == MAP_FAILED) throw std::runtime_error("cannot map " + path);
  const auto page = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
  std::vector<unsigned char> resident((size + page - 1) / page);
  const int status = ::mincore(map, size, resident.data());
  ::munmap(map, size);
  if (status != 0) throw std::runtime_error("mincore failed on " + path);
  return std::count_if(resident.begin(), resident.end(), [](unsigned char r) { return r & 1; });
}

ProximityGraphView view_of(const ProximityGraph& g) {
  ProximityGraphView v;
  v.num_vertices = g.num_vertices;
  v.num_samples = static_cast<std::uint32_t>(g.sample_vertex.size());
  v.neighbors = g.neighbors;
  v.longest_edge = g.longest_edge;
  v.covering_radius = g.covering_radius;
  v.link_radius = g.link_radius;
  v.sample_vertex = g.sample_vertex;
  v.edge_offsets = g.edge_offsets;
  v.edge_target = g.edge_target;
  v.edge_distance = g.edge_distance;
  v.edge_direction = g.edge_direction;
  v.cover_offsets = g.cover_offsets;
  v.cover_sample = g.cover_sample;
  v.cover_distance = g.cover_distance;
  return v;
}

/// A unit direction strictly inside the corner wedge of face f at its corner k (face frame).
GraphDirection wedge_direction(const IntrinsicGeometry& geometry, std::uint32_t f, int k,
                               tm::Rng& rng) {
  const Vec2 cv = geometry.face_corner(f, k);
  const Vec2 ca = geometry.face_corner(f, (k + 1) % 3);
  const Vec2 cb = geometry.face_corner(f, (k + 2) % 3);
  const double a = rng.uniform(0.05, 1), b = rng.uniform(0.05, 1);
  const double x = a * (ca.x - cv.x) + b * (cb.x - cv.x);
  const double y = a * (ca.y - cv.y) + b * (cb.y - cv.y);
  const double n = std::hypot(x, y);
  return {f, static_cast<float>(x / n), static_cast<float>(y / n)};
}

/// A consistent graph: `num_samples` samples spread over the vertices, each linked to
/// `neighbors` distinct random samples (Euclidean distances, directions inside a wedge at the
/// sample), each vertex covered by `covers` random samples.
ProximityGraph synthetic_graph(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                               std::uint32_t num_samples, std::uint32_t neighbors,
                               std::uint32_t covers, std::uint64_t seed = 7) {
  tm::Rng rng(seed);
  ProximityGraph g;
  const auto nv = static_cast<std::uint32_t>(mesh.num_vertices());
  g.num_vertices = nv;
  g.neighbors = neighbors;
  g.stats.sampling_used = SamplingMethod::FastMarching;
  for (std::uint32_t i = 0; i < num_samples; ++i) {
    g.sample_vertex.push_back(static_cast<std::uint32_t>(std::uint64_t{i} * nv / num_samples));
  }
  g.edge_offsets.push_back(0);
  for (std::uint32_t i = 0; i < num_samples; ++i) {
    const std::uint32_t v = g.sample_vertex[i];
    std::vector<std::uint32_t> targets;
    while (targets.size() < std::min(neighbors, num_samples - 1)) {
      const std::uint32_t j = rng.below(num_samples);
      if (j != i && std::find(targets.begin(), targets.end(), j) == targets.end()) {
        targets.push_back(j);
      }
    }
    const auto halfedges = mesh.outgoing_halfedges(v);
    for (std::uint32_t j : targets) {
      const double d = norm(mesh.position(g.sample_vertex[j]) - mesh.position(v));
      const std::uint32_t h = halfedges[rng.below(static_cast<std::uint32_t>(halfedges.size()))];
      g.edge_target.push_back(j);
      g.edge_distance.push_back(d);
      g.edge_direction.push_back(
          wedge_direction(geometry, TriangleMesh::face_of(h), static_cast<int>(h % 3), rng));
      g.longest_edge = std::max(g.longest_edge, d);
    }
    g.edge_offsets.push_back(static_cast<std::uint32_t>(g.edge_target.size()));
  }
  g.cover_offsets.push_back(0);
  for (std::uint32_t v = 0; v < nv; ++v) {
    for (std::uint32_t c = 0; c < std::min(covers, num_samples); ++c) {
      const std::uint32_t s = rng.below(num_samples);
      g.cover_sample.push_back(s);
      g.cover_distance.push_back(
          static_cast<float>(norm(mesh.position(g.sample_vertex[s]) - mesh.position(v))));
      g.covering_radius = std::max(g.covering_radius, 0.25 * g.longest_edge);
    }
    g.cover_offsets.push_back(static_cast<std::uint32_t>(g.cover_sample.size()));
  }
  return g;
}

std::string reason_of_open(const std::string& path, bool verify_checksum = true) {
  try {
    MappedGraphFile::open(path, {.verify_checksum = verify_checksum});
  } catch (const FileError& e) {
    return e.reason() + ": " + e.what();
  }
  return "opened";
}

/// Runs `f`, expecting a geoprox::Error with `reason`; returns its message.
template <typename F>
std::string expect_reason(F&& f, const std::string& reason) {
  try {
    f();
  } catch (const Error& e) {
    EXPECT_EQ(e.reason(), reason) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "expected " << reason << ", nothing thrown";
  return {};
}

/// Flat grid options without designated initializers (GridOptions has members without defaults
/// that -Wmissing-field-initializers would flag).
tm::GridOptions grid_options(int nx, int ny, double h, double jitter = 0, std::uint64_t seed = 1) {
  tm::GridOptions o;
  o.nx = nx;
  o.ny = ny;
  o.hx = o.hy = h;
  o.jitter = jitter;
  o.seed = seed;
  return o;
}

struct Fixture {
  tm::TestMesh cube = tm::make_test_mesh(tm::cube_surface(6, 2.0).data);
  ProximityGraph graph = synthetic_graph(*cube.mesh, *cube.geometry, 40, 6, 3);
};

// ---------------------------------------------------------------------------------------------
// Binary bundle: round trip

TEST(GraphFile, BinaryRoundTripIsBitwise) {
  Fixture fx;
  TempDir dir;
  const std::string path = dir.file("cube.geoprox");
  write_graph_file(path, *fx.cube.mesh, *fx.cube.geometry, fx.graph,
                   {.sampling = SamplingMethod::Exact, .source_mesh = "cube.obj"});
  const MappedGraphFile file = MappedGraphFile::open(path);
  const ProximityGraphView v = file.view();
  const ProximityGraph& g = fx.graph;

  expect_same_graph(v, g);
  EXPECT_TRUE(same_bits(file.faces(), fx.cube.mesh->faces()));
  EXPECT_TRUE(same_bits(file.positions(), fx.cube.mesh->positions()));
  EXPECT_TRUE(same_bits(file.edge_lengths(), fx.cube.geometry->edge_lengths()));

  // Header accessors.
  EXPECT_EQ(file.format_version(), kGraphFileVersion);
  EXPECT_EQ(file.params().num_samples, 40u);
  EXPECT_EQ(file.params().neighbors, 6u);
  EXPECT_EQ(file.params().sampling, SamplingMethod::Exact);
  EXPECT_EQ(file.longest_edge(), g.longest_edge);
  EXPECT_EQ(file.covering_radius(), g.covering_radius);
  EXPECT_EQ(file.link_radius(), g.link_radius);
  const GraphFileCounts c = file.counts();
  EXPECT_EQ(c.vertices, fx.cube.mesh->num_vertices());
  EXPECT_EQ(c.faces, fx.cube.mesh->num_faces());
  EXPECT_EQ(c.edges, fx.cube.mesh->num_edges());
  EXPECT_EQ(c.samples, 40u);
  EXPECT_EQ(c.graph_edges, g.edge_target.size());
  EXPECT_EQ(c.covers, g.cover_sample.size());
  EXPECT_EQ(file.fingerprint(), mesh_fingerprint(*fx.cube.mesh, *fx.cube.geometry));
  EXPECT_EQ(file.source_mesh(), "cube.obj");
  EXPECT_EQ(file.file_size(), fs::file_size(path));
  EXPECT_EQ(file.header().file_size, fs::file_size(path));
  EXPECT_NO_THROW(file.verify_mesh(*fx.cube.mesh, *fx.cube.geometry));

  // Layout: every array 64-byte aligned in the mapping, sections in the documented order.
  ASSERT_EQ(file.sections().size(), kGraphFileSectionCount);
  for (std::uint32_t k = 0; k < kGraphFileSectionCount; ++k) {
    const GraphFileSection& s = file.sections()[k];
    EXPECT_EQ(s.id, k + 1);
    EXPECT_EQ(s.offset % 64, 0u) << graph_file_section_name(s.id);
    EXPECT_EQ(s.size, s.count * s.element_size);
  }
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(v.edge_direction.data()) % 64, 0u);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(file.positions().data()) % 64, 0u);
  EXPECT_EQ(graph_file_section_name(8), "edge_direction");

  // Automatic records the method the builder used.
  write_graph_file(path, *fx.cube.mesh, *fx.cube.geometry, fx.graph);
  EXPECT_EQ(MappedGraphFile::open(path).params().sampling, SamplingMethod::FastMarching);
}

TEST(GraphFile, AFileNotOpenReportsZeros) {
  Fixture fx;
  TempDir dir;
  write_graph_file(dir.file("g"), *fx.cube.mesh, *fx.cube.geometry, fx.graph,
                   {.source_mesh = "cube.obj"});
  MappedGraphFile opened = MappedGraphFile::open(dir.file("g"));
  const MappedGraphFile moved = std::move(opened);
  EXPECT_EQ(moved.source_mesh(), "cube.obj");
  const MappedGraphFile fresh;
  for (const MappedGraphFile* file : {&fresh, static_cast<const MappedGraphFile*>(&opened)}) {
    const MappedGraphFile& f = *file;
    EXPECT_FALSE(f.is_open());
    EXPECT_EQ(f.format_version(), 0u);
    EXPECT_EQ(f.params().num_samples, 0u);
    EXPECT_EQ(f.counts().vertices, 0u);
    EXPECT_EQ(f.longest_edge(), 0.0);
    EXPECT_EQ(f.link_radius(), 0.0);
    EXPECT_EQ(f.fingerprint(), 0u);
    EXPECT_EQ(f.source_mesh(), "");
    EXPECT_TRUE(f.sections().empty());
    EXPECT_EQ(f.header().file_size, 0u);
    EXPECT_EQ(f.view().num_samples, 0u);
  }
}

TEST(GraphFile, WritingIsDeterministic) {
  Fixture fx;
  TempDir dir;
  write_graph_file(dir.file("a"), *fx.cube.mesh, *fx.cube.geometry, fx.graph);
  write_graph_file(dir.file("b"), *fx.cube.mesh, *fx.cube.geometry, fx.graph);
  EXPECT_EQ(read_bytes(dir.file("a")), read_bytes(dir.file("b")));
}

// The writer drops the file's pages from the page cache once they are durable, so that the
// daemon serving a graph it has just built reads it back through readahead (graph_file.md).
TEST(GraphFile, WrittenPagesLeaveThePageCache) {
  Fixture fx;
  TempDir dir;
  // Where the file system keeps such pages anyway (tmpfs: they are the file), there is nothing
  // to test: a plain file written, synced and advised the same way tells.
  const std::string probe = dir.file("probe");
  write_bytes(probe, std::vector<unsigned char>(64 * 1024, 7));
  {
    const int fd = ::open(probe.c_str(), O_RDONLY | O_CLOEXEC);
    ASSERT_GE(fd, 0);
    ::fsync(fd);
    ::posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED);
    ::close(fd);
  }
  if (resident_pages(probe) > 0) {
    GTEST_SKIP() << "this file system keeps a synced file's pages cached (tmpfs, some FUSE)";
  }
  const std::string path = dir.file("g.geoprox");
  write_graph_file(path, *fx.cube.mesh, *fx.cube.geometry, fx.graph);
  EXPECT_EQ(resident_pages(path), 0);
}

TEST(GraphFile, MakeMeshRebuildsTheSameMesh) {
  Fixture fx;
  TempDir dir;
  write_graph_file(dir.file("g"), *fx.cube.mesh, *fx.cube.geometry, fx.graph);
  const MappedGraphFile file = MappedGraphFile::open(dir.file("g"));
  const TriangleMesh mesh = file.make_mesh();
  const IntrinsicGeometry geometry = file.make_geometry(mesh);
  ASSERT_EQ(mesh.num_edges(), fx.cube.mesh->num_edges());
  EXPECT_EQ(mesh.faces(), fx.cube.mesh->faces());
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    EXPECT_EQ(std::memcmp(&mesh.position(v), &fx.cube.mesh->position(v), sizeof(Vec3)), 0);
  }
  for (std::uint32_t e = 0; e < mesh.num_edges(); ++e) {
    EXPECT_EQ(mesh.edge_origin(e), fx.cube.mesh->edge_origin(e));
    EXPECT_EQ(geometry.edge_length(e), fx.cube.geometry->edge_length(e));
  }
  EXPECT_EQ(mesh_fingerprint(mesh, geometry), file.fingerprint());
  EXPECT_NO_THROW(file.verify_mesh(mesh, geometry));
}

TEST(GraphFile, GraphWithoutEdgesOrCovers) {
  tm::TestMesh grid = tm::make_test_mesh(tm::flat_grid(grid_options(3, 3, 0.1)));
  ProximityGraph g;
  g.num_vertices = static_cast<std::uint32_t>(grid.mesh->num_vertices());
  g.sample_vertex = {0, 5};
  g.edge_offsets = {0, 0, 0};
  TempDir dir;
  write_graph_file(dir.file("g"), *grid.mesh, *grid.geometry, g);  // empty cover table
  const MappedGraphFile file = MappedGraphFile::open(dir.file("g"));
  EXPECT_EQ(file.view().num_edges(), 0u);
  EXPECT_EQ(file.view().cover_offsets.size(), grid.mesh->num_vertices() + 1);
  EXPECT_TRUE(file.view().cover_sample.empty());
}

TEST(GraphFile, ViewSurvivesMoves) {
  Fixture fx;
  TempDir dir;
  write_graph_file(dir.file("g"), *fx.cube.mesh, *fx.cube.geometry, fx.graph);
  MappedGraphFile a = MappedGraphFile::open(dir.file("g"));
  const ProximityGraphView before = a.view();
  MappedGraphFile b(std::move(a));
  EXPECT_FALSE(a.is_open());  // NOLINT(bugprone-use-after-move): moved-from state is defined
  EXPECT_TRUE(a.view().edge_target.empty());
  std::vector<MappedGraphFile> files;
  files.push_back(std::move(b));
  files.emplace_back();
  files.back() = std::move(files.front());  // move-assign into an empty one
  files.erase(files.begin());
  files.reserve(16);  // reallocation moves it again
  const ProximityGraphView after = files.front().view();
  EXPECT_EQ(after.edge_target.data(), before.edge_target.data());  // same mapping, no copy
  EXPECT_TRUE(same_bits(after.edge_distance, fx.graph.edge_distance));
  EXPECT_TRUE(same_bits(after.cover_sample, fx.graph.cover_sample));
  EXPECT_TRUE(same_bits(files.front().faces(), fx.cube.mesh->faces()));
  EXPECT_EQ(files.front().path(), dir.file("g"));

  // Move-assigning over an open file unmaps the old one and takes the new one.
  MappedGraphFile c = MappedGraphFile::open(dir.file("g"));
  c = std::move(files.front());
  EXPECT_TRUE(same_bits(c.view().edge_target, fx.graph.edge_target));
}

TEST(GraphFile, OpenWithoutChecksumVerification) {
  Fixture fx;
  TempDir dir;
  write_graph_file(dir.file("g"), *fx.cube.mesh, *fx.cube.geometry, fx.graph);
  const MappedGraphFile file = MappedGraphFile::open(dir.file("g"), {.verify_checksum = false});
  EXPECT_TRUE(same_bits(file.view().edge_distance, fx.graph.edge_distance));
  EXPECT_EQ(file.checksum(), MappedGraphFile::open(dir.file("g")).checksum());
}

TEST(GraphFile, ReplacingAFileLeavesOpenMappingsIntact) {
  Fixture fx;
  TempDir dir;
  const std::string path = dir.file("g");
  write_graph_file(path, *fx.cube.mesh, *fx.cube.geometry, fx.graph);
  const MappedGraphFile old_file = MappedGraphFile::open(path);
  const ProximityGraph other = synthetic_graph(*fx.cube.mesh, *fx.cube.geometry, 30, 4, 2, 99);
  write_graph_file(path, *fx.cube.mesh, *fx.cube.geometry, other);
  EXPECT_TRUE(same_bits(old_file.view().edge_target, fx.graph.edge_target));
  EXPECT_TRUE(same_bits(MappedGraphFile::open(path).view().edge_target, other.edge_target));
  EXPECT_EQ(dir.listing(), std::set<std::string>{"g"});
}

TEST(GraphFile, HashMatchesItsDocumentedDefinition) {
  // Straightforward re-implementation of the definition in graph_file.h.
  auto reference = [](const std::vector<unsigned char>& in, std::uint64_t seed) {
    const std::uint64_t A = 0x9E3779B97F4A7C15ull, B = 0xD6E8FEB86659FD93ull,
                        C = 0xBF58476D1CE4E5B9ull, D = 0x94D049BB133111EBull;
    std::uint64_t lane[4] = {seed + A, seed ^ B, seed - C, ~seed + D};
    std::vector<unsigned char> padded = in;
    padded.resize((in.size() + 31) / 32 * 32, 0);
    for (std::size_t i = 0; i * 8 < padded.size(); ++i) {
      std::uint64_t w = 0;
      for (int b = 7; b >= 0; --b) w = (w << 8) | padded[i * 8 + b];  // little-endian
      lane[i % 4] = std::rotl(lane[i % 4] + w * B, 29) * A;
    }
    std::uint64_t h = lane[0];
    h = (h ^ std::rotl(lane[1], 17)) * C;
    h = (h ^ std::rotl(lane[2], 31)) * D;
    h = (h ^ std::rotl(lane[3], 47)) * A;
    h ^= static_cast<std::uint64_t>(in.size()) * B;
    h ^= h >> 30;
    h *= C;
    h ^= h >> 27;
    h *= D;
    h ^= h >> 31;
    return h;
  };
  tm::Rng rng(1);
  for (std::size_t size : {0, 1, 7, 8, 31, 32, 33, 64, 100, 1000}) {
    std::vector<unsigned char> data(size);
    for (unsigned char& c : data) c = static_cast<unsigned char>(rng.below(256));
    EXPECT_EQ(graph_file_hash(data.data(), size, 42), reference(data, 42)) << size;
  }
  // The stored checksum and fingerprint follow the documented seeds.
  Fixture fx;
  TempDir dir;
  write_graph_file(dir.file("g"), *fx.cube.mesh, *fx.cube.geometry, fx.graph);
  const std::vector<unsigned char> bytes = read_bytes(dir.file("g"));
  std::uint64_t stored = 0;
  std::memcpy(&stored, bytes.data() + bytes.size() - 8, 8);
  EXPECT_EQ(stored, reference({bytes.begin(), bytes.end() - 8}, kGraphFileChecksumSeed));
  std::vector<unsigned char> mesh_bytes(24);
  const std::uint64_t counts[3] = {fx.cube.mesh->num_vertices(), fx.cube.mesh->num_faces(),
                                   fx.cube.mesh->num_edges()};
  std::memcpy(mesh_bytes.data(), counts, 24);
  const auto* f = reinterpret_cast<const unsigned char*>(fx.cube.mesh->faces().data());
  mesh_bytes.insert(mesh_bytes.end(), f, f + 12 * fx.cube.mesh->num_faces());
  const auto* l = reinterpret_cast<const unsigned char*>(fx.cube.geometry->edge_lengths().data());
  mesh_bytes.insert(mesh_bytes.end(), l, l + 8 * fx.cube.mesh->num_edges());
  EXPECT_EQ(mesh_fingerprint(*fx.cube.mesh, *fx.cube.geometry),
            reference(mesh_bytes, kMeshFingerprintSeed));
}

// ---------------------------------------------------------------------------------------------
// Damaged files

class DamagedGraphFile : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = dir_.file("good.geoprox");
    write_graph_file(path_, *fx_.cube.mesh, *fx_.cube.geometry, fx_.graph);
    good_ = read_bytes(path_);
    const MappedGraphFile file = MappedGraphFile::open(path_);
    sections_.assign(file.sections().begin(), file.sections().end());
  }
  /// Writes `bytes` to a fresh file and returns its open failure "Reason: message".
  std::string open_bytes(const std::vector<unsigned char>& bytes, bool verify_checksum = true) {
    const std::string path = dir_.file("damaged-" + std::to_string(counter_++));
    write_bytes(path, bytes);
    return reason_of_open(path, verify_checksum);
  }
  const GraphFileSection& sec(GraphFileSectionId id) const {
    for (const GraphFileSection& s : sections_) {
      if (s.id == static_cast<std::uint32_t>(id)) return s;
    }
    throw std::runtime_error("no such section");
  }
  template <typename T>
  void poke(std::vector<unsigned char>& bytes, std::uint64_t offset, T value) {
    std::memcpy(bytes.data() + offset, &value, sizeof value);
  }

  Fixture fx_;
  TempDir dir_;
  std::string path_;
  std::vector<unsigned char> good_;
  std::vector<GraphFileSection> sections_;
  int counter_ = 0;
};

bool starts_with(const std::string& s, const std::string& prefix) {
  return s.rfind(prefix, 0) == 0;
}

TEST_F(DamagedGraphFile, GoodFileOpens) { EXPECT_EQ(open_bytes(good_), "opened"); }

TEST_F(DamagedGraphFile, TruncatedAnywhere) {
  const std::uint64_t size = good_.size();
  const std::uint64_t cuts[] = {1,
                                4,
                                8,
                                12,
                                100,
                                383,
                                384,
                                500,  // inside the section table
                                sec(GraphFileSectionId::Faces).offset,
                                sec(GraphFileSectionId::Positions).offset + 7,
                                sec(GraphFileSectionId::EdgeDirection).offset + 13,
                                size / 2,
                                size - 8,  // checksum cut off
                                size - 1};
  for (std::uint64_t cut : cuts) {
    ASSERT_LT(cut, size);
    const std::vector<unsigned char> bytes(good_.begin(), good_.begin() + static_cast<long>(cut));
    const std::string got = open_bytes(bytes);
    EXPECT_TRUE(starts_with(got, "Truncated: ")) << "cut at " << cut << ": " << got;
    EXPECT_NE(got.find("truncated"), std::string::npos) << got;
    EXPECT_NE(got.find("damaged-"), std::string::npos) << "message names the file: " << got;
  }
}

TEST_F(DamagedGraphFile, FlippedByteInAnyArrayFailsTheChecksum) {
  for (const GraphFileSection& s : sections_) {
    if (s.size == 0) continue;
    for (std::uint64_t at : {s.offset, s.offset + s.size / 2, s.offset + s.size - 1}) {
      std::vector<unsigned char> bytes = good_;
      bytes[at] ^= 0x10;
      const std::string got = open_bytes(bytes);
      EXPECT_TRUE(starts_with(got, "ChecksumMismatch: "))
          << graph_file_section_name(s.id) << ": " << got;
      EXPECT_NE(got.find("checksum"), std::string::npos);
    }
  }
  // A flipped bit in the stored checksum, in padding, or in a header double.
  for (std::uint64_t at :
       {std::uint64_t{good_.size() - 3}, std::uint64_t{760}, std::uint64_t{50}}) {
    std::vector<unsigned char> bytes = good_;
    bytes[at] ^= 0x01;
    EXPECT_TRUE(starts_with(open_bytes(bytes), "ChecksumMismatch: ")) << at;
  }
}

TEST_F(DamagedGraphFile, InvalidContentsAreRefusedEvenWithoutChecksum) {
  using Id = GraphFileSectionId;
  struct Case {
    const char* name;
    std::function<void(std::vector<unsigned char>&)> damage;
    const char* expect;  // substring of the message
  };
  const std::uint32_t ns = fx_.graph.sample_vertex.size();
  const std::vector<Case> cases = {
      {"edge target out of range",
       [&](auto& b) { poke<std::uint32_t>(b, sec(Id::EdgeTarget).offset + 8, ns + 3); },
       "targets sample"},
      {"edge offsets decreasing",
       [&](auto& b) { poke<std::uint32_t>(b, sec(Id::EdgeOffsets).offset + 4 * 3, 100000); },
       "edge_offsets"},
      {"cover sample out of range",
       [&](auto& b) { poke<std::uint32_t>(b, sec(Id::CoverSample).offset + 4 * 5, ns); },
       "cover entry 5"},
      {"NaN distance",
       [&](auto& b) { poke<double>(b, sec(Id::EdgeDistance).offset + 8 * 2, std::nan("")); },
       "graph edge 2 has distance"},
      {"negative link radius",
       [&](auto& b) { poke<double>(b, offsetof(GraphFileHeader, link_radius), -1.0); },
       "link radius"},
      {"face vertex out of range",
       [&](auto& b) { poke<std::uint32_t>(b, sec(Id::Faces).offset + 4, 1u << 30); },
       "face 0 has a vertex id out of range"},
      {"sample vertex repeated",
       [&](auto& b) {
         poke<std::uint32_t>(b, sec(Id::SampleVertex).offset + 4, fx_.graph.sample_vertex[0]);
       },
       "repeats vertex"},
      {"direction face far from the sample",
       [&](auto& b) {
         // First edge of sample 0: a face that does not touch sample 0's vertex.
         const Triangle* faces =
             reinterpret_cast<const Triangle*>(b.data() + sec(Id::Faces).offset);
         std::uint32_t f = 0;
         const std::uint32_t v = fx_.graph.sample_vertex[0];
         while (faces[f][0] == v || faces[f][1] == v || faces[f][2] == v) ++f;
         poke<std::uint32_t>(b, sec(Id::EdgeDirection).offset, f);
       },
       "does not touch"},
  };
  for (const Case& c : cases) {
    std::vector<unsigned char> bytes = good_;
    c.damage(bytes);
    EXPECT_TRUE(starts_with(open_bytes(bytes), "ChecksumMismatch: ")) << c.name;
    const std::string got = open_bytes(bytes, /*verify_checksum=*/false);
    EXPECT_TRUE(starts_with(got, "CorruptGraph: ")) << c.name << ": " << got;
    EXPECT_NE(got.find(c.expect), std::string::npos) << c.name << ": " << got;
  }
}

// Opening with the checksum checks single values on the bytes it reads for the checksum, not
// on the mapping: a file whose checksum was recomputed after the damage (a crafted file) is
// still refused, with the value named.
TEST_F(DamagedGraphFile, InvalidValuesAreRefusedEvenWithAValidChecksum) {
  using Id = GraphFileSectionId;
  struct Case {
    const char* name;
    std::function<void(std::vector<unsigned char>&)> damage;
    std::string expect;
  };
  const std::uint32_t ns = fx_.graph.sample_vertex.size();
  const std::uint64_t last_cover = fx_.graph.cover_sample.size() - 1;
  const std::vector<Case> cases = {
      {"face vertex out of range",
       [&](auto& b) { poke<std::uint32_t>(b, sec(Id::Faces).offset + 12 * 7 + 8, 1u << 30); },
       "face 7 has a vertex id out of range"},
      {"NaN coordinate",
       [&](auto& b) { poke<double>(b, sec(Id::Positions).offset + 24 * 3 + 16, std::nan("")); },
       "vertex 3 has a non-finite coordinate"},
      {"negative edge length",
       [&](auto& b) { poke<double>(b, sec(Id::EdgeLengths).offset + 8 * 11, -0.5); },
       "edge 11 has length"},
      {"infinite graph edge distance",
       [&](auto& b) {
         poke<double>(b, sec(Id::EdgeDistance).offset + 8 * 4, HUGE_VAL);
       },
       "graph edge 4 has distance"},
      {"last cover entry out of range",
       [&](auto& b) { poke<std::uint32_t>(b, sec(Id::CoverSample).offset + 4 * last_cover, ns); },
       "cover entry " + std::to_string(last_cover) + " names sample"},
      {"negative cover distance",
       [&](auto& b) { poke<float>(b, sec(Id::CoverDistance).offset + 4 * 9, -1.0f); },
       "cover entry 9 has distance"},
  };
  for (const Case& c : cases) {
    std::vector<unsigned char> bytes = good_;
    c.damage(bytes);
    poke<std::uint64_t>(bytes, bytes.size() - 8,
                        graph_file_hash(bytes.data(), bytes.size() - 8, kGraphFileChecksumSeed));
    const std::string got = open_bytes(bytes);
    EXPECT_TRUE(starts_with(got, "CorruptGraph: ")) << c.name << ": " << got;
    EXPECT_NE(got.find(c.expect), std::string::npos) << c.name << ": " << got;
  }
  // -0.0 is a valid distance (the fast check sends it to the exact one, which accepts it).
  std::vector<unsigned char> bytes = good_;
  poke<float>(bytes, sec(Id::CoverDistance).offset, -0.0f);
  poke<std::uint64_t>(bytes, bytes.size() - 8,
                      graph_file_hash(bytes.data(), bytes.size() - 8, kGraphFileChecksumSeed));
  EXPECT_EQ(open_bytes(bytes), "opened");
}

TEST_F(DamagedGraphFile, InconsistentHeaderOrSectionTable) {
  // Counts that disagree with the section table (checked before the checksum).
  {
    std::vector<unsigned char> bytes = good_;
    poke<std::uint64_t>(bytes, offsetof(GraphFileHeader, num_graph_edges),
                        fx_.graph.edge_target.size() + 1);
    const std::string got = open_bytes(bytes);
    EXPECT_TRUE(starts_with(got, "CorruptHeader: ")) << got;
    EXPECT_NE(got.find("edge_target"), std::string::npos) << got;
  }
  // A misaligned section.
  {
    std::vector<unsigned char> bytes = good_;
    poke<std::uint64_t>(bytes, 384 + 32 * 2 + offsetof(GraphFileSection, offset),
                        sec(GraphFileSectionId::EdgeLengths).offset + 8);
    const std::string got = open_bytes(bytes);
    EXPECT_TRUE(starts_with(got, "CorruptHeader: ")) << got;
    EXPECT_NE(got.find("aligned"), std::string::npos) << got;
  }
  // A section pointing past the data.
  {
    std::vector<unsigned char> bytes = good_;
    poke<std::uint64_t>(bytes, 384 + 32 * 5 + offsetof(GraphFileSection, offset),
                        (good_.size() + 64) / 64 * 64);
    EXPECT_TRUE(starts_with(open_bytes(bytes), "CorruptHeader: "));
  }
  // Two sections overlapping.
  {
    std::vector<unsigned char> bytes = good_;
    poke<std::uint64_t>(bytes, 384 + 32 * 10 + offsetof(GraphFileSection, offset),
                        sec(GraphFileSectionId::CoverSample).offset);
    const std::string got = open_bytes(bytes);
    EXPECT_TRUE(starts_with(got, "CorruptHeader: ")) << got;
    EXPECT_NE(got.find("overlap"), std::string::npos) << got;
  }
  // Trailing bytes after the recorded end.
  {
    std::vector<unsigned char> bytes = good_;
    bytes.resize(bytes.size() + 64, 0);
    const std::string got = open_bytes(bytes);
    EXPECT_TRUE(starts_with(got, "CorruptHeader: ")) << got;
    EXPECT_NE(got.find("trailing"), std::string::npos) << got;
  }
}

TEST_F(DamagedGraphFile, WrongMagicIsAForeignFile) {
  std::vector<unsigned char> bytes = good_;
  bytes[3] = 'X';
  EXPECT_TRUE(starts_with(open_bytes(bytes), "ForeignFile: "));
  const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  EXPECT_TRUE(starts_with(open_bytes({obj.begin(), obj.end()}), "ForeignFile: "));
  EXPECT_TRUE(starts_with(open_bytes({'a', 'b', 'c'}), "ForeignFile: "));
  EXPECT_NE(open_bytes({'a'}).find("GEOPROXG"), std::string::npos);
}

TEST_F(DamagedGraphFile, FutureVersionIsUnsupported) {
  std::vector<unsigned char> bytes = good_;
  poke<std::uint32_t>(bytes, offsetof(GraphFileHeader, version), kGraphFileVersionRefined + 1);
  const std::string got = open_bytes(bytes);
  EXPECT_TRUE(starts_with(got, "UnsupportedVersion: ")) << got;
  EXPECT_NE(got.find("newer"), std::string::npos) << got;
  poke<std::uint32_t>(bytes, offsetof(GraphFileHeader, version), 0);
  EXPECT_TRUE(starts_with(open_bytes(bytes), "UnsupportedVersion: "));
}

TEST_F(DamagedGraphFile, OtherByteOrder) {
  std::vector<unsigned char> bytes = good_;
  poke<std::uint32_t>(bytes, offsetof(GraphFileHeader, endian_marker), 0x04030201u);
  EXPECT_TRUE(starts_with(open_bytes(bytes), "WrongEndianness: "));
}

TEST_F(DamagedGraphFile, EmptyDirectoryAndMissing) {
  EXPECT_TRUE(starts_with(open_bytes({}), "EmptyFile: "));
  const std::string as_dir = reason_of_open(dir_.path().string());
  EXPECT_TRUE(starts_with(as_dir, "NotAFile: ")) << as_dir;
  EXPECT_NE(as_dir.find("directory"), std::string::npos);
  const std::string missing = reason_of_open(dir_.file("nope.geoprox"));
  EXPECT_TRUE(starts_with(missing, "FileNotFound: ")) << missing;
  EXPECT_NE(missing.find("nope.geoprox"), std::string::npos);
  EXPECT_TRUE(starts_with(reason_of_open(dir_.file("nope/deeper")), "FileNotFound: "));
}

TEST_F(DamagedGraphFile, BuiltForAnotherMesh) {
  const MappedGraphFile file = MappedGraphFile::open(path_);
  // Other counts.
  const tm::TestMesh other = tm::make_test_mesh(tm::cube_surface(5, 2.0).data);
  std::string msg =
      expect_reason([&] { file.verify_mesh(*other.mesh, *other.geometry); }, "MeshMismatch");
  EXPECT_NE(msg.find("vertices"), std::string::npos) << msg;
  // Same connectivity, other edge lengths (a scaled cube).
  const tm::TestMesh scaled = tm::make_test_mesh(tm::cube_surface(6, 2.5).data);
  msg = expect_reason([&] { file.verify_mesh(*scaled.mesh, *scaled.geometry); }, "MeshMismatch");
  EXPECT_NE(msg.find("edge lengths"), std::string::npos) << msg;
  // Same counts, other connectivity: flip one cell's diagonal in the cube's face list.
  tm::MeshData data = tm::cube_surface(6, 2.0).data;
  const Triangle a = data.faces[0], b = data.faces[1];  // (p00,p10,p11), (p00,p11,p01)
  data.faces[0] = {a[0], a[1], b[2]};
  data.faces[1] = {a[1], a[2], b[2]};
  const tm::TestMesh flipped = tm::make_test_mesh(std::move(data));
  ASSERT_EQ(flipped.mesh->num_edges(), fx_.cube.mesh->num_edges());
  msg = expect_reason([&] { file.verify_mesh(*flipped.mesh, *flipped.geometry); }, "MeshMismatch");
  EXPECT_NE(msg.find("connectivity"), std::string::npos) << msg;
  // Another metric on the same mesh.
  std::vector<double> lengths = fx_.cube.geometry->edge_lengths();
  for (double& l : lengths) l *= 1.0 + 1e-15 * 4;
  const IntrinsicGeometry metric(*fx_.cube.mesh, lengths);
  expect_reason([&] { file.verify_mesh(*fx_.cube.mesh, metric); }, "MeshMismatch");
}

// ---------------------------------------------------------------------------------------------
// Atomic writes

TEST(GraphFileWrite, InvalidGraphLeavesTheOldFileAndNoTemporary) {
  Fixture fx;
  TempDir dir;
  const std::string path = dir.file("g.geoprox");
  write_graph_file(path, *fx.cube.mesh, *fx.cube.geometry, fx.graph);
  const std::vector<unsigned char> before = read_bytes(path);

  std::vector<std::pair<std::string, ProximityGraph>> bad;
  bad.emplace_back("target out of range", fx.graph);
  bad.back().second.edge_target[3] = 1000;
  bad.emplace_back("offsets of the wrong size", fx.graph);
  bad.back().second.edge_offsets.pop_back();
  bad.emplace_back("distance array short", fx.graph);
  bad.back().second.edge_distance.pop_back();
  bad.emplace_back("direction face not at the sample", fx.graph);
  bad.back().second.edge_direction[0].face = static_cast<std::uint32_t>(fx.cube.mesh->num_faces());
  bad.emplace_back("graph for another vertex count", fx.graph);
  bad.back().second.num_vertices += 1;
  bad.emplace_back("cover offsets past the end", fx.graph);
  bad.back().second.cover_offsets.back() += 1;
  bad.emplace_back("negative R", fx.graph);
  bad.back().second.longest_edge = -1;
  for (const auto& [name, graph] : bad) {
    const std::string msg = expect_reason(
        [&] { write_graph_file(path, *fx.cube.mesh, *fx.cube.geometry, graph); }, "InvalidGraph");
    EXPECT_NE(msg.find(path), std::string::npos) << name << ": " << msg;
    EXPECT_EQ(dir.listing(), std::set<std::string>{"g.geoprox"}) << name;
    EXPECT_EQ(read_bytes(path), before) << name;
  }
  EXPECT_EQ(reason_of_open(path), "opened");
}

TEST(GraphFileWrite, MissingDirectoryNamesThePathAndTheError) {
  Fixture fx;
  TempDir dir;
  const std::string path = dir.file("no-such-dir/g.geoprox");
  const std::string msg = expect_reason(
      [&] { write_graph_file(path, *fx.cube.mesh, *fx.cube.geometry, fx.graph); }, "WriteError");
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  EXPECT_NE(msg.find("No such file or directory"), std::string::npos) << msg;
  EXPECT_TRUE(dir.listing().empty());
  // A directory in the way of the final rename.
  fs::create_directory(dir.file("taken"));
  fs::create_directory(dir.file("taken/inner"));
  expect_reason(
      [&] { write_graph_file(dir.file("taken"), *fx.cube.mesh, *fx.cube.geometry, fx.graph); },
      "WriteError");
  EXPECT_EQ(dir.listing(), std::set<std::string>{"taken"});
}

TEST(GraphFileWrite, FailureInTheMiddleOfWritingRemovesTheTemporary) {
  // RLIMIT_FSIZE makes write() fail with EFBIG part way through (also for root).
  Fixture fx;
  TempDir dir;
  const std::string path = dir.file("g.geoprox");
  write_graph_file(path, *fx.cube.mesh, *fx.cube.geometry, fx.graph);
  const std::vector<unsigned char> before = read_bytes(path);
  const ProximityGraph bigger = synthetic_graph(*fx.cube.mesh, *fx.cube.geometry, 200, 20, 10, 3);

  rlimit old_limit{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  const auto old_handler = ::signal(SIGXFSZ, SIG_IGN);
  rlimit limit = old_limit;
  limit.rlim_cur = 4096;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &limit), 0);
  std::string msg;
  try {
    write_graph_file(path, *fx.cube.mesh, *fx.cube.geometry, bigger);
  } catch (const FileError& e) {
    msg = std::string(e.reason()) + ": " + e.what();
  }
  ::setrlimit(RLIMIT_FSIZE, &old_limit);
  ::signal(SIGXFSZ, old_handler);

  EXPECT_TRUE(starts_with(msg, "WriteError: ")) << msg;
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  EXPECT_NE(msg.find("too large"), std::string::npos) << msg;  // EFBIG's text
  EXPECT_EQ(dir.listing(), std::set<std::string>{"g.geoprox"});
  EXPECT_EQ(read_bytes(path), before);
}

// ---------------------------------------------------------------------------------------------
// Paper text format

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

TEST(PaperText, ExportMatchesThePaperListing) {
  Fixture fx;
  std::ostringstream out;
  export_paper_text(out, *fx.cube.mesh, *fx.cube.geometry, view_of(fx.graph));
  const std::vector<std::string> lines = lines_of(out.str());
  const std::size_t ns = fx.graph.sample_vertex.size(), ne = fx.graph.edge_target.size();
  ASSERT_EQ(lines.size(), 4 + ns + ne);
  EXPECT_EQ(lines[0], "# The number of sample points");
  EXPECT_EQ(lines[1], std::to_string(ns));
  EXPECT_EQ(lines[2], "# The coordinates of sample points");
  EXPECT_EQ(lines[3 + ns], "# ID1    ID2    Distance    End_direction");
  for (std::size_t i = 0; i < ns; ++i) {
    std::istringstream row(lines[3 + i]);
    Vec3 p;
    row >> p.x >> p.y >> p.z;
    EXPECT_TRUE(row && row.eof());
    const Vec3& q = fx.cube.mesh->position(fx.graph.sample_vertex[i]);
    EXPECT_TRUE(p.x == q.x && p.y == q.y && p.z == q.z) << lines[3 + i];
  }
  std::size_t k = 0;
  for (std::size_t i = 0; i < ns; ++i) {
    for (; k < fx.graph.edge_offsets[i + 1]; ++k) {
      std::istringstream row(lines[4 + ns + k]);
      std::size_t id1 = 0, id2 = 0;
      double d = 0;
      Vec3 dir;
      row >> id1 >> id2 >> d >> dir.x >> dir.y >> dir.z;
      ASSERT_TRUE(row && row.eof()) << lines[4 + ns + k];
      EXPECT_EQ(id1, i + 1);  // 1-based ids
      EXPECT_EQ(id2, fx.graph.edge_target[k] + 1);
      EXPECT_EQ(d, fx.graph.edge_distance[k]);
      EXPECT_NEAR(norm(dir), 1.0, 1e-12);
      // Independent 3D frame (test_meshes): x along corner 0 -> 1, y towards corner 2.
      const GraphDirection& g = fx.graph.edge_direction[k];
      const Vec3 expect = tm::face_direction_3d(*fx.cube.mesh, g.face, g.x, g.y);
      EXPECT_NEAR(norm(dir - expect), 0.0, 1e-6) << lines[4 + ns + k];
    }
  }
}

void expect_text_round_trip(const tm::TestMesh& m, const ProximityGraph& g) {
  std::ostringstream out;
  export_paper_text(out, *m.mesh, *m.geometry, view_of(g));
  std::istringstream in(out.str());
  const ProximityGraph back = import_paper_text(in, *m.mesh, *m.geometry);
  EXPECT_EQ(back.num_vertices, g.num_vertices);
  EXPECT_EQ(back.sample_vertex, g.sample_vertex);
  EXPECT_EQ(back.edge_offsets, g.edge_offsets);
  EXPECT_EQ(back.edge_target, g.edge_target);
  EXPECT_TRUE(same_bits<double>(back.edge_distance, g.edge_distance));  // %.17g is exact
  ASSERT_EQ(back.edge_direction.size(), g.edge_direction.size());
  for (std::size_t k = 0; k < g.edge_direction.size(); ++k) {
    const GraphDirection& d = back.edge_direction[k];
    const Triangle& t = m.mesh->face(d.face);
    const std::uint32_t v = [&] {
      for (std::size_t i = 0; i + 1 < g.edge_offsets.size(); ++i) {
        if (k < g.edge_offsets[i + 1]) return g.sample_vertex[i];
      }
      return 0u;
    }();
    EXPECT_TRUE(t[0] == v || t[1] == v || t[2] == v) << "edge " << k;
    EXPECT_NEAR(std::hypot(d.x, d.y), 1.0, 1e-6);
    const Vec3 a = graph_direction_to_3d(*m.mesh, *m.geometry, g.edge_direction[k]);
    const Vec3 b = graph_direction_to_3d(*m.mesh, *m.geometry, d);
    EXPECT_LT(norm(a - b), 1e-6) << "edge " << k;
  }
  EXPECT_EQ(back.longest_edge, *std::max_element(g.edge_distance.begin(), g.edge_distance.end()));
  EXPECT_EQ(back.neighbors, g.neighbors);  // every row has m_P entries here
  EXPECT_EQ(back.cover_offsets, std::vector<std::uint32_t>(g.num_vertices + 1, 0));
  EXPECT_TRUE(back.cover_sample.empty());

  // The imported graph is a valid graph for the binary bundle too.
  TempDir dir;
  write_graph_file(dir.file("g"), *m.mesh, *m.geometry, back);
  const MappedGraphFile file = MappedGraphFile::open(dir.file("g"));
  EXPECT_TRUE(same_bits(file.view().edge_direction, back.edge_direction));
}

TEST(PaperText, RoundTripOnACube) {
  Fixture fx;
  expect_text_round_trip(fx.cube, fx.graph);
}

TEST(PaperText, RoundTripOnAJitteredGridAConeAndASaddle) {
  const tm::TestMesh grid = tm::make_test_mesh(tm::flat_grid(grid_options(12, 9, 0.1, 0.2, 4)));
  expect_text_round_trip(grid, synthetic_graph(*grid.mesh, *grid.geometry, 30, 5, 2, 11));
  const tm::TestMesh cone = tm::make_test_mesh(tm::cone_surface(1.0, 0.7, 9, 4).data);
  expect_text_round_trip(cone, synthetic_graph(*cone.mesh, *cone.geometry, 12, 4, 2, 12));
  const tm::TestMesh saddle = tm::make_test_mesh(tm::saddle_surface(8, 0.8, 3).data);
  expect_text_round_trip(saddle, synthetic_graph(*saddle.mesh, *saddle.geometry, 10, 3, 2, 13));
}

TEST(PaperText, DirectionConversionAroundEveryVertex) {
  // Also with a metric that is not the positions' (uniformly scaled lengths).
  const tm::TestMesh cube = tm::make_test_mesh(tm::cube_surface(3, 1.0).data);
  std::vector<double> lengths = cube.geometry->edge_lengths();
  for (double& l : lengths) l *= 3.0;
  const IntrinsicGeometry scaled(*cube.mesh, lengths);
  tm::Rng rng(5);
  for (const IntrinsicGeometry* geometry :
       {static_cast<const IntrinsicGeometry*>(cube.geometry.get()), &scaled}) {
    for (std::uint32_t v = 0; v < cube.mesh->num_vertices(); ++v) {
      for (std::uint32_t h : cube.mesh->outgoing_halfedges(v)) {
        const GraphDirection d =
            wedge_direction(*geometry, TriangleMesh::face_of(h), static_cast<int>(h % 3), rng);
        const Vec3 d3 = graph_direction_to_3d(*cube.mesh, *geometry, d);
        EXPECT_NEAR(norm(d3), 1.0, 1e-12);
        const GraphDirection back = graph_direction_from_3d(*cube.mesh, *geometry, v, d3);
        EXPECT_EQ(back.face, d.face) << "vertex " << v;  // strictly inside the wedge
        EXPECT_NEAR(back.x, d.x, 1e-6);
        EXPECT_NEAR(back.y, d.y, 1e-6);
      }
    }
  }
  expect_reason([&] { graph_direction_from_3d(*cube.mesh, *cube.geometry, 0, Vec3{}); },
                "BadDirection");
}

TEST(PaperText, SampleCoordinatesMatchWithinTolerance) {
  const tm::TestMesh grid = tm::make_test_mesh(tm::flat_grid(grid_options(6, 6, 1.0)));
  const double diag = tm::bbox_diagonal(*grid.mesh);  // 6 sqrt 2
  auto text = [&](double dx) {
    std::ostringstream s;
    s << "# The number of sample points\n2\n# The coordinates of sample points\n";
    s.precision(17);
    s << 1 + dx << " " << 1 - dx << " " << dx << "\n" << 4 << " " << 5 << " " << 0 << "\n";
    s << "# ID1    ID2    Distance    End_direction\n1 2 5 0.6 0.8 0\n2 1 5 -0.6 -0.8 0\n";
    return s.str();
  };
  for (double dx : {0.0, 1e-12 * diag, 4e-10 * diag}) {
    std::istringstream in(text(dx));
    const ProximityGraph g = import_paper_text(in, *grid.mesh, *grid.geometry);
    EXPECT_EQ(g.sample_vertex, (std::vector<std::uint32_t>{8, 5 * 7 + 4})) << dx;
    EXPECT_EQ(g.neighbors, 1u);
    EXPECT_EQ(g.longest_edge, 5.0);
    const Vec3 d = graph_direction_to_3d(*grid.mesh, *grid.geometry, g.edge_direction[0]);
    EXPECT_NEAR(d.x, 0.6, 1e-7);
    EXPECT_NEAR(d.y, 0.8, 1e-7);
  }
  std::istringstream far(text(1e-6 * diag));
  const std::string msg =
      expect_reason([&] { import_paper_text(far, *grid.mesh, *grid.geometry); }, "ParseError");
  EXPECT_NE(msg.find("line 4"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not at a mesh vertex"), std::string::npos) << msg;
}

TEST(PaperText, ParseErrorsNameTheLine) {
  const tm::TestMesh grid = tm::make_test_mesh(tm::flat_grid(grid_options(2, 2, 1.0)));
  const std::string head =
      "# The number of sample points\n2\n# The coordinates of sample points\n"
      "0 0 0\n2 2 0\n# ID1    ID2    Distance    End_direction\n";
  struct Case {
    std::string text;
    int line;
    const char* says;
  };
  const std::vector<Case> cases = {
      {"", 0, "empty"},
      {"# only a comment\n", 1, "empty"},
      {"two\n", 1, "number of sample points"},
      {"99\n", 1, "only 9 vertices"},
      {"2\n0 0 0\n", 2, "1 of 2"},
      {"2\n0 0\n", 2, "three finite coordinates"},
      {"2\n0 0 nan\n", 2, "three finite coordinates"},
      {"2\n0 0 0\n0 0 0\n", 3, "like sample 1"},
      {"2\n0 0 0\n0.5 0.25 0\n", 3, "not at a mesh vertex"},
      {head + "1 2 1.5 1 0 0\n0 1 1 1 0 0\n", 8, "out of range"},
      {head + "1 3 1 1 0 0\n", 7, "out of range"},
      {head + "1 1 1 1 0 0\n", 7, "itself"},
      {head + "1 2 1 1 0\n", 7, "ID1 ID2 Distance"},
      {head + "1 2 -1 1 0 0\n", 7, "negative"},
      {head + "1 2 1 0 0 0\n", 7, "bad end direction"},
      {head + "1 2 1 1 0 0 7\n", 7, "ID1 ID2 Distance"},
  };
  for (const Case& c : cases) {
    std::istringstream in(c.text);
    const std::string msg =
        expect_reason([&] { import_paper_text(in, *grid.mesh, *grid.geometry); }, "ParseError");
    EXPECT_NE(msg.find("line " + std::to_string(c.line) + ":"), std::string::npos)
        << c.text << " -> " << msg;
    EXPECT_NE(msg.find(c.says), std::string::npos) << c.text << " -> " << msg;
  }
  // A valid one, with CRLF line ends and blank lines.
  std::istringstream ok("# n\r\n2\r\n\r\n0 0 0\r\n2 2 0\r\n1 2 2.8 0.7 0.7 0\r\n");
  const ProximityGraph g = import_paper_text(ok, *grid.mesh, *grid.geometry);
  EXPECT_EQ(g.edge_offsets, (std::vector<std::uint32_t>{0, 1, 1}));
}

}  // namespace
}  // namespace geoprox
