// The proximity-graph file (no paper for the binary bundle; the text format is the paper's §2.2
// listing): one versioned, little-endian, memory-mappable bundle per mesh holding everything the
// queries need (the mesh's faces, positions and intrinsic edge lengths, the samples, the graph in
// CSR form with distances and end directions, the per-vertex cover table), plus the paper's text
// format for interchange.
//
// Binary layout, version 2 (all integers and IEEE doubles/floats little-endian):
//
//   offset  size  field
//   0       8     magic "GEOPROXG"
//   8       4     format version (kGraphFileVersion)
//   12      4     endianness marker 0x01020304 (reads 0x04030201 on a byte-swapped file)
//   16      4     header_size: bytes before the first array (fixed header + section table,
//                 a multiple of 64)
//   20      4     section_count
//   24      8     file_size: total bytes, checksum included
//   32      4     n_P (samples), 36 m_P (neighbours), 40 sampling method, 44 reserved (0)
//   48      8     R (longest graph edge), 56 r (covering radius), doubles
//   64      8x6   counts: vertices, faces, edges, samples, graph edges, cover entries (uint64)
//   112     8     mesh fingerprint (mesh_fingerprint below)
//   120     8     link radius (double, mesh units; 0 when unknown)
//   128     256   source mesh name, NUL-padded (informational)
//   384     32xN  section table: {uint32 id, uint32 element size, uint64 offset, uint64 bytes,
//                 uint64 element count}, one row per GraphFileSectionId
//   ...           arrays, each starting at a multiple of 64, zero padding in between:
//                 faces (3 x uint32), positions (3 x double), edge lengths (double), sample
//                 vertex (uint32), edge offsets (uint32, n_P + 1), edge target (uint32), edge
//                 distance (double), edge direction (GraphDirection: uint32 face, float x,
//                 float y), cover offsets (uint32, vertices + 1), cover sample (uint32), cover
//                 distance (float)
//   file_size-8 8 checksum: graph_file_hash(bytes [0, file_size - 8), kGraphFileChecksumSeed)
//
// Opening maps the file read-only (MAP_PRIVATE) and the views point straight into the mapping:
// nothing is parsed or copied. Validation is linear: header and section table first, then (if
// requested) the checksum, then the array contents (CSR offsets monotone, ids in range, numbers
// finite). Every failure is a FileError whose reason says which:
//   FileNotFound, NotAFile (a directory...), EmptyFile, ReadError, ForeignFile (bad magic),
//   WrongEndianness, UnsupportedVersion, Truncated (shorter than its header says),
//   CorruptHeader (header/section table inconsistent: sizes, alignment, overlaps, counts,
//   trailing bytes), ChecksumMismatch, CorruptGraph (array contents invalid), and
//   MeshMismatch from verify_mesh().
// Writers never modify a file in place (write to a temporary, fsync, rename), so a mapped file
// never changes under a reader; truncating a mapped file from outside would raise SIGBUS.
#pragma once

#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/graph/proximity_graph.h"

namespace geoprox {

inline constexpr char kGraphFileMagic[8] = {'G', 'E', 'O', 'P', 'R', 'O', 'X', 'G'};
inline constexpr std::uint32_t kGraphFileVersion = 2;
inline constexpr std::uint32_t kGraphFileEndianMarker = 0x01020304u;
inline constexpr std::size_t kGraphFileAlignment = 64;

/// The fixed part of the header, exactly as on disk (see the table above).
struct GraphFileHeader {
  char magic[8];
  std::uint32_t version;
  std::uint32_t endian_marker;
  std::uint32_t header_size;
  std::uint32_t section_count;
  std::uint64_t file_size;
  std::uint32_t param_samples;    ///< n_P
  std::uint32_t param_neighbors;  ///< m_P
  std::uint32_t param_sampling;   ///< SamplingMethod
  std::uint32_t reserved0;
  double longest_edge;     ///< R
  double covering_radius;  ///< r
  std::uint64_t num_vertices;
  std::uint64_t num_faces;
  std::uint64_t num_edges;
  std::uint64_t num_samples;
  std::uint64_t num_graph_edges;
  std::uint64_t num_covers;
  std::uint64_t mesh_fingerprint;
  double link_radius;  ///< radius of the query points' exact link solves
  char source_mesh[256];
};
static_assert(sizeof(GraphFileHeader) == 384);
static_assert(std::is_trivially_copyable_v<GraphFileHeader>);
static_assert(std::is_standard_layout_v<GraphFileHeader>);

enum class GraphFileSectionId : std::uint32_t {
  Faces = 1,           ///< Triangle (3 x uint32) per face
  Positions = 2,       ///< Vec3 (3 x double) per vertex
  EdgeLengths = 3,     ///< double per mesh edge (intrinsic lengths)
  SampleVertex = 4,    ///< uint32 per sample
  EdgeOffsets = 5,     ///< uint32, samples + 1
  EdgeTarget = 6,      ///< uint32 per graph edge
  EdgeDistance = 7,    ///< double per graph edge
  EdgeDirection = 8,   ///< GraphDirection (12 bytes) per graph edge
  CoverOffsets = 9,    ///< uint32, vertices + 1
  CoverSample = 10,    ///< uint32 per cover entry
  CoverDistance = 11,  ///< float per cover entry
};
inline constexpr std::uint32_t kGraphFileSectionCount = 11;

/// One row of the section table, exactly as on disk.
struct GraphFileSection {
  std::uint32_t id;            ///< GraphFileSectionId
  std::uint32_t element_size;  ///< bytes per element
  std::uint64_t offset;        ///< from the start of the file, a multiple of 64
  std::uint64_t size;          ///< bytes = element_size * count
  std::uint64_t count;         ///< elements
};
static_assert(sizeof(GraphFileSection) == 32);
static_assert(std::is_trivially_copyable_v<GraphFileSection>);

/// "faces", "positions", ... ("unknown" for other ids).
std::string_view graph_file_section_name(std::uint32_t id);

/// What the writer records besides the graph.
struct GraphFileMetadata {
  /// Sampling method recorded in the header; Automatic records graph.stats.sampling_used.
  SamplingMethod sampling = SamplingMethod::Automatic;
  /// Informational name of the source mesh (truncated to 255 bytes).
  std::string source_mesh;
};

struct GraphFileParams {
  std::uint32_t num_samples = 0;  ///< n_P
  std::uint32_t neighbors = 0;    ///< m_P
  SamplingMethod sampling = SamplingMethod::Automatic;
};

struct GraphFileCounts {
  std::uint64_t vertices = 0, faces = 0, edges = 0;
  std::uint64_t samples = 0, graph_edges = 0, covers = 0;
};

/// 64-bit hash used by the file (checksum and fingerprint). Not cryptographic; ~19 GB/s on
/// warm memory. Definition (for other readers of the format): with A = 0x9E3779B97F4A7C15,
/// B = 0xD6E8FEB86659FD93, C = 0xBF58476D1CE4E5B9, D = 0x94D049BB133111EB, lanes start at
/// (seed + A, seed ^ B, seed - C, ~seed + D); the input, zero-padded to a multiple of 32 bytes,
/// is read as little-endian 64-bit words w, word i going to lane i % 4 as
/// lane = rotl(lane + w * B, 29) * A; then h = lane0, h = (h ^ rotl(lane1, 17)) * C,
/// h = (h ^ rotl(lane2, 31)) * D, h = (h ^ rotl(lane3, 47)) * A, h ^= length_in_bytes * B, and
/// finally h ^= h >> 30, h *= C, h ^= h >> 27, h *= D, h ^= h >> 31 (all mod 2^64).
std::uint64_t graph_file_hash(const void* data, std::size_t size, std::uint64_t seed = 0);
/// Seeds: the file checksum is graph_file_hash(file, file_size - 8, kGraphFileChecksumSeed).
inline constexpr std::uint64_t kGraphFileChecksumSeed = 0x47656f50726f7843ull;  // "GeoProxC"
inline constexpr std::uint64_t kMeshFingerprintSeed = 0x47656f50726f784dull;    // "GeoProxM"

/// Fingerprint of a mesh as a graph file sees it: graph_file_hash with kMeshFingerprintSeed of
/// the counts (vertices, faces, edges as three uint64), then the face vertex ids (3 x uint32 per
/// face) and the IEEE bits of the intrinsic edge lengths (not the positions).
std::uint64_t mesh_fingerprint(const TriangleMesh& mesh, const IntrinsicGeometry& geometry);

/// Writes the bundle to a unique temporary file next to `path` (named `<path>.tmp-XXXXXX`, six
/// letters or digits, and locked with flock(2) while it is written), fsyncs it, renames it over
/// `path` and fsyncs the directory: `path` is either the old file or the complete new one.
/// Throws InvalidInput ("InvalidGraph") if the graph's arrays are inconsistent with each other
/// or with the mesh (before anything is created), FileError ("WriteError", naming the path and
/// the system's error text) if the file cannot be written; the temporary is removed either way.
void write_graph_file(const std::string& path, const TriangleMesh& mesh,
                      const IntrinsicGeometry& geometry, const ProximityGraph& graph,
                      const GraphFileMetadata& metadata = {});

/// Removes the temporaries of write_graph_file(`path`) that a writer killed mid-write (kill -9,
/// power loss) left behind: files named `<path>.tmp-XXXXXX` whose lock no one holds. The
/// temporary of a live writer (another process writing the same path) is locked and left
/// alone. Returns the names removed; never throws (a directory that cannot be read removes
/// nothing).
std::vector<std::string> remove_stale_graph_temporaries(const std::string& path);

struct GraphFileOpenOptions {
  /// Hash the whole file and compare with the stored checksum (catches any flipped bit).
  /// Opening reads every page anyway (the structural checks scan all arrays), and that first
  /// read of the mapping is most of the cost; the hash itself runs at ~19 GB/s once the pages
  /// are in cache. Measured on a 100k-face bundle (12.7 MiB, 5000 x 18 edges, 50k x 18 covers),
  /// 2-core VM: 4.8 ms CPU per open with the checksum, 4.2 ms without. Without it, out-of-range
  /// ids, broken CSR rows and non-finite numbers are still refused, but a flipped bit inside a
  /// distance or coordinate (or in R, r, the fingerprint) is not.
  bool verify_checksum = true;
};

/// A graph file mapped read-only. Move-only; the views stay valid while the object (or the
/// object it was moved into) lives. Thread-safe for concurrent reads.
class MappedGraphFile {
 public:
  using OpenOptions = GraphFileOpenOptions;

  /// Maps and validates `path` (throws FileError with the reasons listed at the top).
  static MappedGraphFile open(const std::string& path, const OpenOptions& options = {});

  MappedGraphFile() = default;
  MappedGraphFile(MappedGraphFile&& other) noexcept;
  MappedGraphFile& operator=(MappedGraphFile&& other) noexcept;
  MappedGraphFile(const MappedGraphFile&) = delete;
  MappedGraphFile& operator=(const MappedGraphFile&) = delete;
  ~MappedGraphFile();

  bool is_open() const { return base_ != nullptr; }
  const std::string& path() const { return path_; }
  std::size_t file_size() const { return size_; }

  /// The graph, in place (spans into the mapping).
  ProximityGraphView view() const { return view_; }
  std::span<const Triangle> faces() const { return faces_; }
  std::span<const Vec3> positions() const { return positions_; }
  std::span<const double> edge_lengths() const { return edge_lengths_; }

  const GraphFileHeader& header() const { return header_; }
  std::uint32_t format_version() const { return header_.version; }
  GraphFileParams params() const;
  GraphFileCounts counts() const;
  double longest_edge() const { return header_.longest_edge; }
  double covering_radius() const { return header_.covering_radius; }
  double link_radius() const { return header_.link_radius; }
  std::uint64_t fingerprint() const { return header_.mesh_fingerprint; }
  std::uint64_t checksum() const { return checksum_; }
  std::string_view source_mesh() const;
  /// The section table (in the mapping).
  std::span<const GraphFileSection> sections() const { return sections_; }

  /// Throws FileError ("MeshMismatch") if the file was built for another mesh: says whether the
  /// vertex/face/edge counts, the connectivity (first differing face) or the edge lengths
  /// (first differing edge) differ.
  void verify_mesh(const TriangleMesh& mesh, const IntrinsicGeometry& geometry) const;
  /// The mesh stored in the bundle (copies its faces and positions). Same ids as the original.
  TriangleMesh make_mesh() const;
  /// The bundle's intrinsic edge lengths on `mesh` (usually make_mesh()); `mesh` must outlive it.
  IntrinsicGeometry make_geometry(const TriangleMesh& mesh) const;

 private:
  void release() noexcept;

  std::string path_;
  const unsigned char* base_ = nullptr;
  std::size_t size_ = 0;
  GraphFileHeader header_{};
  std::uint64_t checksum_ = 0;
  std::span<const GraphFileSection> sections_;
  std::span<const Triangle> faces_;
  std::span<const Vec3> positions_;
  std::span<const double> edge_lengths_;
  ProximityGraphView view_;
};

// ---------------------------------------------------------------------------------------------
// The paper's text format (§2.2):
//
//   # The number of sample points
//   3800
//   # The coordinates of sample points
//   1.2 1.1 0.8                          (one line per sample, x y z)
//   ...
//   # ID1    ID2    Distance    End_direction
//   1 2 0.5534 0.15 0.83 0.5372          (one line per graph edge ID1 -> ID2)
//   ...
//
// IDs are 1-based sample numbers. End_direction is the 3D unit vector in which the geodesic
// leaves sample ID1 towards ID2 (the end of the path at ID1; the row ID2 ID1 holds the other
// end). Numbers are printed with %.17g. The format carries neither m_P, r nor the cover table.

/// 3D unit direction of a stored direction: the face frame's x axis runs along corner 0 ->
/// corner 1 and y towards corner 2; the face-frame vector is mapped through the affine map that
/// takes the intrinsic face layout to the face's 3D triangle (for a mesh whose lengths are its
/// positions' lengths this is the orthonormal in-plane frame).
Vec3 graph_direction_to_3d(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                           const GraphDirection& direction);
/// Inverse at vertex `vertex`: the face around `vertex` whose corner wedge contains `direction`
/// (the one closest to its plane when several do), and the unit face-frame vector. Throws
/// InvalidInput if the direction is not finite and nonzero or the vertex has no face.
GraphDirection graph_direction_from_3d(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                                       std::uint32_t vertex, const Vec3& direction);

void export_paper_text(std::ostream& out, const TriangleMesh& mesh,
                       const IntrinsicGeometry& geometry, const ProximityGraphView& graph);

/// Reads the text format: every sample coordinate must match a mesh vertex exactly or within
/// 1e-9 of the bounding-box diagonal (the nearest such vertex), directions become face-frame
/// directions at the sample's vertex. Rows are grouped by ID1 in file order. The result has
/// neighbors = smallest non-empty row length, R = longest edge, r = 0 (unknown) and an empty
/// cover table (cover_offsets all zero). Throws FileError ("ParseError") naming the line.
ProximityGraph import_paper_text(std::istream& in, const TriangleMesh& mesh,
                                 const IntrinsicGeometry& geometry);

}  // namespace geoprox
