// The proximity-graph file (no paper for the binary bundle; the text format is the paper's §2.2
// listing): one versioned, little-endian, memory-mappable bundle per mesh holding everything the
// queries need (the mesh's faces, positions and intrinsic edge lengths, the samples, the graph in
// CSR form with distances and end directions, the per-vertex cover table), plus the paper's text
// format for interchange. The byte layout is in core/graph/graph_file_format.h.
//
// Opening maps the file read-only and the views point straight into the mapping: nothing is
// parsed or copied. Opening validates everything the queries will follow (header, section
// table, the checksum if asked, then the arrays: CSR offsets monotone, ids in range, numbers
// finite). Every failure is a FileError whose code says which:
//   FileNotFound, NotAFile (a directory...), EmptyFile, ReadError, ForeignFile (bad magic),
//   WrongEndianness, UnsupportedVersion, Truncated (shorter than its header says),
//   CorruptHeader (header/section table inconsistent: sizes, alignment, overlaps, counts,
//   trailing bytes), ChecksumMismatch, CorruptGraph (array contents invalid), and
//   MeshMismatch from verify_mesh().
// Writers never modify a file in place (write to a temporary, fsync, rename), so a mapped file
// never changes under a reader; truncating a mapped file from outside would raise SIGBUS.
#pragma once

#include <cstddef>
#include <array>
#include <cstdint>
#include <iosfwd>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/graph/proximity_graph.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"

namespace geoprox {

/// The format versions this build writes and reads: 2 for a graph over the mesh as given, 3 for
/// one built on a refinement of it (ProximityGraph::refined), which also stores the map.
inline constexpr std::uint32_t kGraphFileVersion = 2;
inline constexpr std::uint32_t kGraphFileVersionRefined = 3;

// The on-disk header and section-table row (core/graph/graph_file_format.h).
struct GraphFileHeader;
struct GraphFileSection;
struct GraphFileRefinement;

/// What the writer records besides the graph.
struct GraphFileMetadata {
  /// Sampling method recorded in the header; Automatic (default) records
  /// graph.stats.sampling_used.
  SamplingMethod sampling = SamplingMethod::Automatic;
  /// Informational name of the source mesh (truncated to 255 bytes; default empty).
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

/// Fingerprint of a mesh as a graph file sees it: a hash of its counts, its faces' vertex ids
/// and the IEEE bits of its intrinsic edge lengths (not the positions; definition in
/// core/graph/graph_file_format.h).
std::uint64_t mesh_fingerprint(const TriangleMesh& mesh, const IntrinsicGeometry& geometry);

/// Writes the bundle of `graph`, built on `mesh` with `geometry` (when the build refined the mesh,
/// the bundle holds the refined mesh, the map and the fingerprint of `mesh`: version 3), to a
/// unique temporary file next to `path` (named `<path>.tmp-XXXXXX`, six
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
  /// Hash the whole file and compare with the stored checksum (catches any flipped bit);
  /// default on. Opening reads every page anyway (the structural checks scan all arrays), so
  /// the hash adds little. Without it, out-of-range ids, broken CSR rows and non-finite numbers
  /// are still refused, but a flipped bit inside a distance or coordinate (or in R, r, the
  /// fingerprint) is not.
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

  /// The graph, in place (spans into the mapping). For a refined graph it is over the refined
  /// mesh (make_mesh()), not the mesh queries are given in.
  ProximityGraphView view() const { return view_; }
  std::span<const Triangle> faces() const { return faces_; }
  std::span<const Vec3> positions() const { return positions_; }
  std::span<const double> edge_lengths() const { return edge_lengths_; }

  /// What the header records (zeros and empty while not open).
  std::uint32_t format_version() const;
  GraphFileParams params() const;
  GraphFileCounts counts() const;
  double longest_edge() const;     ///< R (mesh units)
  double covering_radius() const;  ///< r (mesh units)
  double link_radius() const;      ///< rho (mesh units; 0 when unknown)
  std::uint64_t fingerprint() const;
  std::uint64_t checksum() const { return checksum_; }
  std::string_view source_mesh() const;
  /// The header and the section table as on disk (all zeros and empty while not open), for
  /// tools that inspect the format; their layout is in core/graph/graph_file_format.h.
  const GraphFileHeader& header() const;
  std::span<const GraphFileSection> sections() const;

  /// A version-3 file's graph is over a refinement of the mesh queries are given in
  /// (core/graph/refined_surface.h): that mesh's counts and the refinement's edge limit.
  struct RefinedFrom {
    std::uint64_t vertices = 0, faces = 0, edges = 0;
    double max_edge_length = 0;  ///< mesh units
  };
  /// Set for a version-3 file, empty otherwise.
  std::optional<RefinedFrom> refined_from() const;
  /// Per face of the stored (refined) mesh: the input face it lies in, and its corners'
  /// barycentrics there; empty unless refined_from().
  std::span<const std::uint32_t> source_face() const { return source_face_; }
  std::span<const std::array<std::array<double, 3>, 3>> source_bary() const {
    return source_bary_;
  }

  /// Throws FileError ("MeshMismatch") if the file was built for another mesh (for a refined
  /// graph, the mesh it refined): says whether the vertex/face/edge counts, the connectivity
  /// (first differing face) or the edge lengths (first differing edge) differ, or, for a refined
  /// graph, that the counts or the fingerprint do.
  void verify_mesh(const TriangleMesh& mesh, const IntrinsicGeometry& geometry) const;
  /// The mesh stored in the bundle (copies its faces and positions): the mesh the graph is
  /// over, with the original's ids, or the refined mesh of a refined graph.
  TriangleMesh make_mesh() const;
  /// The bundle's intrinsic edge lengths on `mesh` (usually make_mesh()); `mesh` must outlive it.
  IntrinsicGeometry make_geometry(const TriangleMesh& mesh) const;

 private:
  void release() noexcept;

  std::string path_;
  const unsigned char* base_ = nullptr;
  std::size_t size_ = 0;
  const GraphFileHeader* header_ = nullptr;  // in the mapping
  const GraphFileSection* sections_ = nullptr;
  std::size_t section_count_ = 0;
  std::uint64_t checksum_ = 0;
  std::span<const Triangle> faces_;
  std::span<const Vec3> positions_;
  std::span<const double> edge_lengths_;
  ProximityGraphView view_;
  const GraphFileRefinement* refined_from_ = nullptr;  // in the mapping, version 3
  std::span<const std::uint32_t> source_face_;
  std::span<const std::array<std::array<double, 3>, 3>> source_bary_;
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

/// Writes the graph in the text format. Throws InvalidInput ("InvalidGraph") for inconsistent
/// edge arrays, FileError ("WriteError") if the stream fails.
void export_paper_text(std::ostream& out, const TriangleMesh& mesh,
                       const IntrinsicGeometry& geometry, const ProximityGraphView& graph);

/// Reads the text format: every sample coordinate must match a mesh vertex exactly or within
/// tuning::kSampleMatchTolerance of the bounding-box diagonal (the nearest such vertex),
/// directions become face-frame directions at the sample's vertex. Rows are grouped by ID1 in
/// file order. The result has neighbors = smallest non-empty row length, R = longest edge,
/// r = 0 (unknown) and an empty cover table (cover_offsets all zero). Throws FileError
/// ("ParseError") naming the line.
ProximityGraph import_paper_text(std::istream& in, const TriangleMesh& mesh,
                                 const IntrinsicGeometry& geometry);

}  // namespace geoprox
