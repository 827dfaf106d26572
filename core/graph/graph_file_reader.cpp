// Reading graph files: MappedGraphFile maps a file and validates it, check by check, before any
// view points into it.
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/base/errors.h"
#include "core/base/tuning.h"
#include "core/graph/graph_file.h"
#include "core/graph/graph_file_format.h"
#include "core/graph/graph_file_internal.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

namespace {

using namespace graph_file_detail;

[[noreturn]] void throw_open_error(ErrorCode code, const std::string& path,
                                   const std::string& what) {
  throw FileError(code, "graph file '" + path + "': " + what);
}

/// The known sections of a file's table, by index in kSections, then kRefinementSections.
using SectionsById =
    std::array<const GraphFileSection*, kGraphFileSectionCount + kGraphFileRefinementSectionCount>;

const GraphFileSection& section(const SectionsById& found, GraphFileSectionId id) {
  return *found[static_cast<std::uint32_t>(id) - 1];
}

template <typename T>
std::span<const T> section_span(const unsigned char* base, const GraphFileSection& s) {
  return {reinterpret_cast<const T*>(base + s.offset), static_cast<std::size_t>(s.count)};
}

struct FileDescriptorCloser {
  int fd;
  ~FileDescriptorCloser() { ::close(fd); }
};

// ---------------------------------------------------------------------------------------------
// The checks of MappedGraphFile::open, in the order it runs them.

/// Opens `path` read-only and returns its descriptor: a regular file that is not empty, whose
/// size `size` gets.
int open_regular_file(const std::string& path, std::uint64_t& size) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int error = errno;
    if (error == ENOENT || error == ENOTDIR) {
      throw_open_error(ErrorCode::FileNotFound, path, "no such file");
    }
    throw_open_error(ErrorCode::ReadError, path, "cannot open: " + errno_text(error));
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int error = errno;
    ::close(fd);
    throw_open_error(ErrorCode::ReadError, path, "cannot stat: " + errno_text(error));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    throw_open_error(
        ErrorCode::NotAFile, path,
        S_ISDIR(st.st_mode) ? "is a directory, not a graph file" : "is not a regular file");
  }
  size = static_cast<std::uint64_t>(st.st_size);
  if (size == 0) {
    ::close(fd);
    throw_open_error(ErrorCode::EmptyFile, path, "is empty (0 bytes), not a graph file");
  }
  return fd;
}

/// The magic (a shorter file that starts like the magic is a truncated graph file), then room
/// for the fixed header.
void check_magic(const unsigned char* base, std::uint64_t size, const std::string& path) {
  if (size < sizeof kGraphFileMagic) {
    if (std::memcmp(base, kGraphFileMagic, size) == 0) {
      throw_open_error(ErrorCode::Truncated, path,
                       "truncated to " + std::to_string(size) + " bytes, inside the header");
    }
    throw_open_error(ErrorCode::ForeignFile, path, "not a geoprox graph file (no GEOPROXG magic)");
  }
  if (std::memcmp(base, kGraphFileMagic, sizeof kGraphFileMagic) != 0) {
    throw_open_error(ErrorCode::ForeignFile, path, "not a geoprox graph file (no GEOPROXG magic)");
  }
  if (size < kFixedHeaderSize) {
    throw_open_error(ErrorCode::Truncated, path,
                     "truncated to " + std::to_string(size) + " bytes, inside the " +
                         std::to_string(kFixedHeaderSize) + "-byte header");
  }
}

/// Byte order and format version.
void check_endianness_and_version(const GraphFileHeader& h, const std::string& path) {
  if (h.endian_marker != kGraphFileEndianMarker) {
    if (h.endian_marker == __builtin_bswap32(kGraphFileEndianMarker)) {
      throw_open_error(ErrorCode::WrongEndianness, path,
                       "written with the other byte order (big-endian)");
    }
    throw_open_error(ErrorCode::CorruptHeader, path,
                     "bad endianness marker " + hex64(h.endian_marker));
  }
  if (h.version != kGraphFileVersion && h.version != kGraphFileVersionRefined) {
    throw_open_error(ErrorCode::UnsupportedVersion, path,
                     "format version " + std::to_string(h.version) +
                         (h.version > kGraphFileVersionRefined ? " is newer than" : " is not") +
                         " the versions this build reads (" + std::to_string(kGraphFileVersion) +
                         " and " + std::to_string(kGraphFileVersionRefined) +
                         "); rebuild the graph with this geoprox");
  }
}

/// Header geometry: sizes self-consistent, then compared with the file's `size`.
void check_header_sizes(const GraphFileHeader& h, std::uint64_t size, const std::string& path) {
  const std::uint64_t table_end =
      kFixedHeaderSize + std::uint64_t{h.section_count} * sizeof(GraphFileSection);
  if (h.section_count < kGraphFileSectionCount || h.section_count > kGraphFileMaxSections ||
      h.header_size % kGraphFileAlignment != 0 || h.header_size < table_end) {
    throw_open_error(ErrorCode::CorruptHeader, path,
                     "inconsistent header: header_size " + std::to_string(h.header_size) + " for " +
                         std::to_string(h.section_count) + " sections");
  }
  if (h.file_size < std::uint64_t{h.header_size} + 8 || h.file_size % 8 != 0) {
    throw_open_error(ErrorCode::CorruptHeader, path,
                     "inconsistent header: file_size " + std::to_string(h.file_size) + " with a " +
                         std::to_string(h.header_size) + "-byte header");
  }
  if (size < h.file_size) {
    throw_open_error(ErrorCode::Truncated, path,
                     "truncated: " + std::to_string(size) + " bytes, the header says " +
                         std::to_string(h.file_size));
  }
  if (size > h.file_size) {
    throw_open_error(ErrorCode::CorruptHeader, path,
                     std::to_string(size - h.file_size) +
                         " bytes of trailing data after the end recorded in the header (" +
                         std::to_string(h.file_size) + " bytes)");
  }
}

/// Build parameters and counts: a known sampling method, n_P = samples, 32-bit ids.
void check_header_counts(const GraphFileHeader& h, const std::string& path) {
  if (h.param_sampling > static_cast<std::uint32_t>(SamplingMethod::Exact) ||
      h.param_samples != h.num_samples) {
    throw_open_error(ErrorCode::CorruptHeader, path, "inconsistent build parameters in the header");
  }
  const std::uint64_t u32max = std::numeric_limits<std::uint32_t>::max();
  if (h.num_vertices >= u32max || h.num_faces >= u32max || h.num_edges >= u32max ||
      h.num_samples >= u32max || h.num_graph_edges > u32max || h.num_covers > u32max) {
    throw_open_error(ErrorCode::CorruptHeader, path, "counts in the header exceed 32-bit ids");
  }
}

/// One row of the section table, known or not: aligned, inside the data area, its size
/// `count` elements of `element_size` bytes.
void check_section_extent(const GraphFileSection& s, const GraphFileHeader& h,
                          const std::string& name, const std::string& path) {
  const std::uint64_t data_end = h.file_size - 8;
  if (s.offset % kGraphFileAlignment != 0) {
    throw_open_error(ErrorCode::CorruptHeader, path,
                     name + " is not 64-byte aligned (offset " + std::to_string(s.offset) + ")");
  }
  if (s.offset < h.header_size || s.offset > data_end || s.size > data_end - s.offset) {
    throw_open_error(ErrorCode::CorruptHeader, path,
                     name + " [" + std::to_string(s.offset) + ", +" + std::to_string(s.size) +
                         ") lies outside the data area [" + std::to_string(h.header_size) + ", " +
                         std::to_string(data_end) + ")");
  }
  if (s.element_size == 0 || s.size % s.element_size != 0 || s.size / s.element_size != s.count) {
    throw_open_error(ErrorCode::CorruptHeader, path,
                     name + " has " + std::to_string(s.size) + " bytes for " +
                         std::to_string(s.count) + " elements of " +
                         std::to_string(s.element_size) + " bytes");
  }
}

/// A known section (index k in kSections): first of its id, with its element size and the
/// element count the header's counts imply.
void check_known_section(const GraphFileSection& s, int k, const GraphFileHeader& h,
                         const SectionsById& found, const std::string& name,
                         const std::string& path) {
  const std::uint64_t expected_count[kGraphFileSectionCount] = {
      h.num_faces,        h.num_vertices,    h.num_edges,       h.num_samples,
      h.num_samples + 1,  h.num_graph_edges, h.num_graph_edges, h.num_graph_edges,
      h.num_vertices + 1, h.num_covers,      h.num_covers};
  if (found[k] != nullptr) {
    throw_open_error(ErrorCode::CorruptHeader, path, name + " appears twice");
  }
  if (s.element_size != kSections[k].element_size) {
    throw_open_error(ErrorCode::CorruptHeader, path,
                     name + " has " + std::to_string(s.element_size) + "-byte elements, not " +
                         std::to_string(kSections[k].element_size));
  }
  if (s.count != expected_count[k]) {
    throw_open_error(ErrorCode::CorruptHeader, path,
                     name + " has " + std::to_string(s.count) +
                         " elements but the header counts imply " +
                         std::to_string(expected_count[k]));
  }
}

/// A refinement section (index r in kRefinementSections): first of its id, with its element size
/// and count (one record, or one per face).
void check_refinement_section(const GraphFileSection& s, int r, const GraphFileHeader& h,
                              const SectionsById& found, const std::string& name,
                              const std::string& path) {
  const std::uint64_t expected_count = r == 0 ? 1 : h.num_faces;
  if (found[kGraphFileSectionCount + r] != nullptr) {
    throw_open_error(ErrorCode::CorruptHeader, path, name + " appears twice");
  }
  if (s.element_size != kRefinementSections[r].element_size || s.count != expected_count) {
    throw_open_error(ErrorCode::CorruptHeader, path,
                     name + " has " + std::to_string(s.count) + " elements of " +
                         std::to_string(s.element_size) + " bytes, not " +
                         std::to_string(expected_count) + " of " +
                         std::to_string(kRefinementSections[r].element_size));
  }
}

/// The section table: every row checked, every known section present once, no overlaps.
SectionsById find_sections(std::span<const GraphFileSection> table, const GraphFileHeader& h,
                           const std::string& path) {
  SectionsById found = {};
  std::vector<std::pair<std::uint64_t, std::uint64_t>> extents;  // offset, end
  for (const GraphFileSection& s : table) {
    const std::string name = "section " + std::string(graph_file_section_name(s.id)) + " (id " +
                             std::to_string(s.id) + ")";
    check_section_extent(s, h, name, path);
    extents.emplace_back(s.offset, s.offset + s.size);
    if (const int k = section_index(s.id); k >= 0) {
      check_known_section(s, k, h, found, name, path);
      found[k] = &s;
    } else if (const int r = refinement_section_index(s.id); r >= 0) {
      check_refinement_section(s, r, h, found, name, path);
      found[kGraphFileSectionCount + r] = &s;
    }  // unknown sections are skipped (bounds checked above)
  }
  for (std::uint32_t k = 0; k < kGraphFileSectionCount + kGraphFileRefinementSectionCount; ++k) {
    const bool wanted = k < kGraphFileSectionCount || h.version == kGraphFileVersionRefined;
    const char* name = k < kGraphFileSectionCount ? kSections[k].name
                                                  : kRefinementSections[k - kGraphFileSectionCount].name;
    if (wanted && found[k] == nullptr) {
      throw_open_error(ErrorCode::CorruptHeader, path, std::string("section ") + name +
                                                           " is missing");
    }
    if (!wanted && found[k] != nullptr) {
      throw_open_error(ErrorCode::CorruptHeader, path,
                       std::string("section ") + name + " in a version " +
                           std::to_string(h.version) + " file");
    }
  }
  std::sort(extents.begin(), extents.end());
  for (std::size_t k = 1; k < extents.size(); ++k) {
    if (extents[k].first < extents[k - 1].second) {
      throw_open_error(ErrorCode::CorruptHeader, path,
                       "sections overlap at offset " + std::to_string(extents[k].first));
    }
  }
  return found;
}

/// arrays_problem's single-value checks, run on pieces of the file's bytes (split anywhere at
/// multiples of 8 bytes) as they stream through the checksum; keeps the first problem found.
class ValueChecks {
 public:
  ValueChecks(const SectionsById& found, const GraphFileHeader& h, std::span<const Triangle> faces)
      : found_(found), h_(h), faces_(faces) {}

  void run(std::uint64_t offset, const unsigned char* bytes, std::size_t size) {
    if (!problem_.empty()) return;
    using Id = GraphFileSectionId;
    const Chunk chunk{offset, bytes, size};
    std::uint64_t first = 0;
    std::string p;
    if (auto ids = piece<std::uint32_t>(Id::Faces, chunk, first); !ids.empty())
      p = face_ids_problem(ids, first, h_.num_vertices, faces_);
    if (auto c = piece<double>(Id::Positions, chunk, first); p.empty() && !c.empty())
      p = coordinates_problem(c, first);
    if (auto l = piece<double>(Id::EdgeLengths, chunk, first); p.empty() && !l.empty())
      p = edge_lengths_problem(l, first);
    if (auto d = piece<double>(Id::EdgeDistance, chunk, first); p.empty() && !d.empty())
      p = edge_distances_problem(d, first);
    if (auto j = piece<std::uint32_t>(Id::CoverSample, chunk, first); p.empty() && !j.empty())
      p = cover_samples_problem(j, first, h_.num_samples);
    if (auto d = piece<float>(Id::CoverDistance, chunk, first); p.empty() && !d.empty())
      p = cover_distances_problem(d, first);
    problem_ = std::move(p);
  }

  const std::string& problem() const { return problem_; }

 private:
  struct Chunk {  // bytes [offset, offset + size) of the file
    std::uint64_t offset;
    const unsigned char* bytes;
    std::size_t size;
  };
  /// The part of section `id` inside `chunk`, as values of type T;
  /// `first` gets the index of its first value in the section.
  template <class T>
  std::span<const T> piece(GraphFileSectionId id, const Chunk& chunk, std::uint64_t& first) const {
    const GraphFileSection& s = section(found_, id);
    const std::uint64_t lo = std::max(chunk.offset, s.offset),
                        hi = std::min(chunk.offset + chunk.size, s.offset + s.size);
    if (lo >= hi) return {};
    first = (lo - s.offset) / sizeof(T);
    return {reinterpret_cast<const T*>(chunk.bytes + (lo - chunk.offset)), (hi - lo) / sizeof(T)};
  }

  const SectionsById& found_;
  const GraphFileHeader& h_;
  std::span<const Triangle> faces_;  // the mapping's, for messages only
  std::string problem_;
};

/// graph_file_hash of the file's first `size` bytes, read with pread through one reused buffer;
/// `each_piece(offset, bytes, size)` sees every piece read (pieces are multiples of 8 bytes).
std::uint64_t hash_file_prefix(int fd, const std::string& path, std::uint64_t size,
                               std::uint64_t seed, auto&& each_piece) {
  constexpr std::size_t kChunk = tuning::kChecksumReadChunkBytes;
  std::vector<std::uint64_t> words(kChunk / 8);
  auto* buffer = reinterpret_cast<unsigned char*>(words.data());
  StreamHash h(seed);
  for (std::uint64_t offset = 0; offset < size;) {
    const std::size_t want =
        static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, size - offset));
    const ssize_t got = ::pread(fd, buffer, want, static_cast<off_t>(offset));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) {
      throw_open_error(ErrorCode::ReadError, path,
                       "cannot read at offset " + std::to_string(offset) + ": " +
                           (got < 0 ? errno_text(errno) : std::string("unexpected end of file")));
    }
    // Pieces end on 8-byte boundaries (`size` is a multiple of 8): a short read that does not
    // is read again from the boundary.
    const auto usable = static_cast<std::size_t>(got) & ~std::size_t{7};
    h.update(buffer, usable);
    each_piece(offset, buffer, usable);
    offset += usable;
  }
  return h.finish();
}

/// Hashes the file through `fd` and compares with the `stored` checksum, checking the single
/// values of the arrays on the way (ChecksumMismatch first, then CorruptGraph).
void verify_checksum_and_values(int fd, const std::string& path, const unsigned char* base,
                                const GraphFileHeader& h, const SectionsById& found,
                                std::uint64_t stored) {
  const GraphFileSection& faces = section(found, GraphFileSectionId::Faces);
  ValueChecks checks(found, h, section_span<Triangle>(base, faces));
  const std::uint64_t computed =
      hash_file_prefix(fd, path, h.file_size - 8, kGraphFileChecksumSeed,
                       [&](std::uint64_t offset, const unsigned char* bytes, std::size_t size) {
                         checks.run(offset, bytes, size);
                       });
  if (computed != stored) {
    throw_open_error(ErrorCode::ChecksumMismatch, path,
                     "checksum mismatch (stored " + hex64(stored) + ", computed " +
                         hex64(computed) + "): the file is corrupted");
  }
  if (!checks.problem().empty()) {
    throw_open_error(ErrorCode::CorruptGraph, path, "corrupt contents: " + checks.problem());
  }
}

/// The graph's views into the mapping.
ProximityGraphView view_of(const unsigned char* base, const GraphFileHeader& h,
                           const SectionsById& found) {
  using Id = GraphFileSectionId;
  ProximityGraphView v;
  v.num_vertices = static_cast<std::uint32_t>(h.num_vertices);
  v.num_samples = static_cast<std::uint32_t>(h.num_samples);
  v.neighbors = h.param_neighbors;
  v.longest_edge = h.longest_edge;
  v.covering_radius = h.covering_radius;
  v.link_radius = h.link_radius;
  v.sample_vertex = section_span<std::uint32_t>(base, section(found, Id::SampleVertex));
  v.edge_offsets = section_span<std::uint32_t>(base, section(found, Id::EdgeOffsets));
  v.edge_target = section_span<std::uint32_t>(base, section(found, Id::EdgeTarget));
  v.edge_distance = section_span<double>(base, section(found, Id::EdgeDistance));
  v.edge_direction = section_span<GraphDirection>(base, section(found, Id::EdgeDirection));
  v.cover_offsets = section_span<std::uint32_t>(base, section(found, Id::CoverOffsets));
  v.cover_sample = section_span<std::uint32_t>(base, section(found, Id::CoverSample));
  v.cover_distance = section_span<float>(base, section(found, Id::CoverDistance));
  return v;
}

/// What arrays_problem checks of a mapped file.
GraphArrays arrays_of(const GraphFileHeader& h, std::span<const Triangle> faces,
                      std::span<const Vec3> positions, std::span<const double> edge_lengths,
                      const ProximityGraphView& v, bool values_checked) {
  GraphArrays a;
  a.num_vertices = h.num_vertices;
  a.num_faces = h.num_faces;
  a.num_edges = h.num_edges;
  a.longest_edge = h.longest_edge;
  a.covering_radius = h.covering_radius;
  a.link_radius = h.link_radius;
  a.faces = faces;
  a.positions = positions;
  a.edge_lengths = edge_lengths;
  a.sample_vertex = v.sample_vertex;
  a.edge_offsets = v.edge_offsets;
  a.edge_target = v.edge_target;
  a.edge_distance = v.edge_distance;
  a.edge_direction = v.edge_direction;
  a.cover_offsets = v.cover_offsets;
  a.cover_sample = v.cover_sample;
  a.cover_distance = v.cover_distance;
  a.values_checked = values_checked;
  return a;
}

/// The refinement sections of a version-3 file, checked: the record's counts are 32-bit and
/// within the file's, its edge limit finite, the source faces in range, the barycentrics on the
/// simplex (RefinementMap checks them again against the mesh it is given).
struct RefinementSections {
  const GraphFileRefinement* record = nullptr;
  std::span<const std::uint32_t> source_face;
  std::span<const std::array<std::array<double, 3>, 3>> source_bary;
};
RefinementSections refinement_sections(const unsigned char* base, const GraphFileHeader& h,
                                       const SectionsById& found, const std::string& path) {
  RefinementSections out;
  out.record = reinterpret_cast<const GraphFileRefinement*>(
      base + section(found, GraphFileSectionId::RefinedFrom).offset);
  const GraphFileRefinement& r = *out.record;
  if (r.input_vertices > h.num_vertices || r.input_faces > h.num_faces || r.input_faces == 0 ||
      r.input_edges > h.num_edges || !(std::isfinite(r.max_edge_length) && r.max_edge_length > 0)) {
    throw_open_error(ErrorCode::CorruptGraph, path,
                     "corrupt contents: the refinement record's counts or edge limit");
  }
  out.source_face = section_span<std::uint32_t>(base, section(found, GraphFileSectionId::SourceFace));
  out.source_bary = section_span<std::array<std::array<double, 3>, 3>>(
      base, section(found, GraphFileSectionId::SourceBary));
  for (std::size_t g = 0; g < out.source_face.size(); ++g) {
    bool inside = out.source_face[g] < r.input_faces;
    for (const auto& b : out.source_bary[g]) {
      inside = inside && b[0] >= 0 && b[1] >= 0 && b[2] >= 0 &&
               std::abs(b[0] + b[1] + b[2] - 1) <= kBarycentricSumTolerance;
    }
    if (!inside) {
      throw_open_error(ErrorCode::CorruptGraph, path,
                       "corrupt contents: face " + std::to_string(g) +
                           " of the refined mesh does not lie in an input face");
    }
  }
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

MappedGraphFile MappedGraphFile::open(const std::string& path, const OpenOptions& options) {
  std::uint64_t size = 0;
  const int fd = open_regular_file(path, size);
  // No MAP_POPULATE: the checksum below reads the file through a small buffer, which costs far
  // less than faulting in every page of the mapping, and the queries fault in the pages they
  // need. The descriptor stays open until the checksum has been read.
  void* map = ::mmap(nullptr, static_cast<std::size_t>(size), PROT_READ, MAP_PRIVATE, fd, 0);
  const int map_error = errno;
  const FileDescriptorCloser fd_closer{fd};
  if (map == MAP_FAILED) {
    throw_open_error(ErrorCode::ReadError, path, "cannot mmap: " + errno_text(map_error));
  }
  MappedGraphFile file;  // unmaps on any throw below
  file.path_ = path;
  file.base_ = static_cast<const unsigned char*>(map);
  file.size_ = static_cast<std::size_t>(size);
  const unsigned char* base = file.base_;

  check_magic(base, size, path);
  const auto& h = *reinterpret_cast<const GraphFileHeader*>(base);
  check_endianness_and_version(h, path);
  check_header_sizes(h, size, path);
  check_header_counts(h, path);
  file.header_ = &h;
  file.sections_ = reinterpret_cast<const GraphFileSection*>(base + kFixedHeaderSize);
  file.section_count_ = h.section_count;
  const SectionsById found = find_sections(file.sections(), h, path);

  file.checksum_ = load64(base + h.file_size - 8);
  if (options.verify_checksum) {
    verify_checksum_and_values(fd, path, base, h, found, file.checksum_);
  }

  file.faces_ = section_span<Triangle>(base, section(found, GraphFileSectionId::Faces));
  file.positions_ = section_span<Vec3>(base, section(found, GraphFileSectionId::Positions));
  file.edge_lengths_ = section_span<double>(base, section(found, GraphFileSectionId::EdgeLengths));
  file.view_ = view_of(base, h, found);
  const GraphArrays arrays = arrays_of(h, file.faces_, file.positions_, file.edge_lengths_,
                                       file.view_, options.verify_checksum);
  if (std::string problem = arrays_problem(arrays); !problem.empty()) {
    throw_open_error(ErrorCode::CorruptGraph, path, "corrupt contents: " + problem);
  }
  if (h.version == kGraphFileVersionRefined) {
    const RefinementSections refinement = refinement_sections(base, h, found, path);
    file.refined_from_ = refinement.record;
    file.source_face_ = refinement.source_face;
    file.source_bary_ = refinement.source_bary;
  }
  return file;
}

MappedGraphFile::MappedGraphFile(MappedGraphFile&& other) noexcept { *this = std::move(other); }

MappedGraphFile& MappedGraphFile::operator=(MappedGraphFile&& other) noexcept {
  if (this != &other) {
    release();
    path_ = std::move(other.path_);
    base_ = std::exchange(other.base_, nullptr);
    size_ = std::exchange(other.size_, 0);
    header_ = std::exchange(other.header_, nullptr);
    sections_ = std::exchange(other.sections_, nullptr);
    section_count_ = std::exchange(other.section_count_, 0);
    checksum_ = std::exchange(other.checksum_, 0);
    faces_ = std::exchange(other.faces_, {});
    positions_ = std::exchange(other.positions_, {});
    edge_lengths_ = std::exchange(other.edge_lengths_, {});
    view_ = std::exchange(other.view_, ProximityGraphView{});
    refined_from_ = std::exchange(other.refined_from_, nullptr);
    source_face_ = std::exchange(other.source_face_, {});
    source_bary_ = std::exchange(other.source_bary_, {});
  }
  return *this;
}

MappedGraphFile::~MappedGraphFile() { release(); }

void MappedGraphFile::release() noexcept {
  if (base_ != nullptr) {
    ::munmap(const_cast<unsigned char*>(base_), size_);
    base_ = nullptr;
    size_ = 0;
  }
}

const GraphFileHeader& MappedGraphFile::header() const {
  static constexpr GraphFileHeader kNotOpen{};
  return header_ != nullptr ? *header_ : kNotOpen;
}

std::span<const GraphFileSection> MappedGraphFile::sections() const {
  return {sections_, section_count_};
}

std::uint32_t MappedGraphFile::format_version() const { return header().version; }

std::optional<MappedGraphFile::RefinedFrom> MappedGraphFile::refined_from() const {
  if (refined_from_ == nullptr) return std::nullopt;
  const GraphFileRefinement& r = *refined_from_;
  return RefinedFrom{r.input_vertices, r.input_faces, r.input_edges, r.max_edge_length};
}

GraphFileParams MappedGraphFile::params() const {
  const GraphFileHeader& h = header();
  return {h.param_samples, h.param_neighbors, static_cast<SamplingMethod>(h.param_sampling)};
}

GraphFileCounts MappedGraphFile::counts() const {
  const GraphFileHeader& h = header();
  return {h.num_vertices, h.num_faces, h.num_edges, h.num_samples, h.num_graph_edges, h.num_covers};
}

double MappedGraphFile::longest_edge() const { return header().longest_edge; }
double MappedGraphFile::covering_radius() const { return header().covering_radius; }
double MappedGraphFile::link_radius() const { return header().link_radius; }
std::uint64_t MappedGraphFile::fingerprint() const { return header().mesh_fingerprint; }

std::string_view MappedGraphFile::source_mesh() const {
  const GraphFileHeader& h = header();
  return {h.source_mesh, ::strnlen(h.source_mesh, sizeof h.source_mesh)};
}

void MappedGraphFile::verify_mesh(const TriangleMesh& mesh,
                                  const IntrinsicGeometry& geometry) const {
  const GraphFileHeader& h = header();
  const std::string prefix = "graph file '" + path_ + "' was built for another mesh: ";
  const std::uint64_t nv = mesh.num_vertices(), nf = mesh.num_faces(),
                      ne = geometry.edge_lengths().size();
  if (refined_from_ != nullptr) {
    const GraphFileRefinement& r = *refined_from_;
    if (nv != r.input_vertices || nf != r.input_faces || ne != r.input_edges) {
      throw FileError(ErrorCode::MeshMismatch,
                      prefix + "it refines a mesh of " + std::to_string(r.input_vertices) +
                          " vertices, " + std::to_string(r.input_faces) + " faces, " +
                          std::to_string(r.input_edges) + " edges; the mesh has " +
                          std::to_string(nv) + " vertices, " + std::to_string(nf) + " faces, " +
                          std::to_string(ne) + " edges");
    }
    if (const std::uint64_t fp = mesh_fingerprint(mesh, geometry); fp != r.input_fingerprint) {
      throw FileError(ErrorCode::MeshMismatch,
                      prefix + "same counts, but the fingerprint of the mesh it refines is " +
                          hex64(r.input_fingerprint) + " and the mesh's " + hex64(fp) +
                          " (other connectivity or edge lengths)");
    }
    return;
  }
  if (nv != h.num_vertices || nf != h.num_faces || ne != h.num_edges) {
    throw FileError(ErrorCode::MeshMismatch,
                    prefix + "it has " + std::to_string(h.num_vertices) + " vertices, " +
                        std::to_string(h.num_faces) + " faces, " + std::to_string(h.num_edges) +
                        " edges; the mesh has " + std::to_string(nv) + " vertices, " +
                        std::to_string(nf) + " faces, " + std::to_string(ne) + " edges");
  }
  const std::uint64_t fp = mesh_fingerprint(mesh, geometry);
  if (fp == h.mesh_fingerprint) return;
  // Say what differs, from the arrays the bundle carries.
  const std::string fingerprints = hex64(h.mesh_fingerprint) + " vs " + hex64(fp);
  for (std::size_t f = 0; f < faces_.size(); ++f) {
    const Triangle& a = faces_[f];
    const Triangle& b = mesh.face(static_cast<std::uint32_t>(f));
    if (a == b) continue;
    throw FileError(ErrorCode::MeshMismatch,
                    prefix + "same counts but different connectivity: face " + std::to_string(f) +
                        " is (" + std::to_string(a[0]) + ", " + std::to_string(a[1]) + ", " +
                        std::to_string(a[2]) + ") in the file and (" + std::to_string(b[0]) + ", " +
                        std::to_string(b[1]) + ", " + std::to_string(b[2]) +
                        ") in the mesh (fingerprint " + fingerprints + ")");
  }
  for (std::size_t e = 0; e < edge_lengths_.size(); ++e) {
    const double a = edge_lengths_[e], b = geometry.edge_length(static_cast<std::uint32_t>(e));
    if (std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b)) continue;
    throw FileError(ErrorCode::MeshMismatch,
                    prefix + "same connectivity but different edge lengths: edge " +
                        std::to_string(e) + " is " + fmt_double(a) + " in the file and " +
                        fmt_double(b) + " in the mesh (fingerprint " + fingerprints + ")");
  }
  throw FileError(ErrorCode::MeshMismatch, prefix + "mesh fingerprint " + hex64(fp) +
                                               " differs from the file's " +
                                               hex64(h.mesh_fingerprint));
}

TriangleMesh MappedGraphFile::make_mesh() const {
  return TriangleMesh(std::vector<Vec3>(positions_.begin(), positions_.end()),
                      std::vector<Triangle>(faces_.begin(), faces_.end()));
}

IntrinsicGeometry MappedGraphFile::make_geometry(const TriangleMesh& mesh) const {
  return IntrinsicGeometry(mesh, std::vector<double>(edge_lengths_.begin(), edge_lengths_.end()));
}

}  // namespace geoprox
