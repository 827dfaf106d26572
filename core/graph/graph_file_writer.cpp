// Writing graph files (write_graph_file) and removing the temporaries of killed writers.
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/base/errors.h"
#include "core/base/tuning.h"
#include "core/graph/graph_file.h"
#include "core/graph/graph_file_format.h"
#include "core/graph/graph_file_internal.h"
#include "core/graph/refined_surface.h"

namespace geoprox {

namespace {

using namespace graph_file_detail;

[[noreturn]] void throw_write_error(const std::string& path, const std::string& step, int error) {
  throw FileError(ErrorCode::WriteError,
                  "cannot write graph file '" + path + "': " + step + ": " + errno_text(error));
}

/// Appended to the graph file's path for its temporary (mkostemp fills in the X's).
constexpr char kTemporarySuffix[] = ".tmp-XXXXXX";

/// A temporary file that is removed unless committed.
struct TempFile {
  std::string name;
  int fd = -1;
  bool committed = false;
  TempFile() = default;
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  ~TempFile() {
    if (fd >= 0) ::close(fd);
    if (!committed && !name.empty()) ::unlink(name.c_str());
  }
};

/// Buffered sequential writer that hashes everything it writes.
class Sink {
 public:
  Sink(int fd, const std::string& path) : fd_(fd), path_(path), hash_(kGraphFileChecksumSeed) {
    buffer_.resize(tuning::kGraphWriteBufferBytes);
  }

  void put(const void* data, std::size_t size) {
    const auto* p = static_cast<const unsigned char*>(data);
    while (size > 0) {
      const std::size_t take = std::min(size, buffer_.size() - used_);
      std::memcpy(buffer_.data() + used_, p, take);
      used_ += take;
      p += take;
      size -= take;
      if (used_ == buffer_.size()) flush();
    }
  }

  void pad_to(std::uint64_t offset) {
    static constexpr unsigned char zeros[kGraphFileAlignment] = {};
    while (position() < offset) {
      put(zeros,
          static_cast<std::size_t>(std::min<std::uint64_t>(offset - position(), sizeof zeros)));
    }
  }

  std::uint64_t position() const { return written_ + used_; }

  void flush() {
    hash_.update(buffer_.data(), used_);
    write_all(buffer_.data(), used_);
    written_ += used_;
    used_ = 0;
  }

  /// Flushes, then appends the checksum of everything written so far (not itself hashed).
  void finish_with_checksum() {
    flush();
    const std::uint64_t checksum = hash_.finish();
    write_all(&checksum, sizeof checksum);
    written_ += sizeof checksum;
  }

 private:
  void write_all(const void* data, std::size_t size) {
    const auto* p = static_cast<const unsigned char*>(data);
    while (size > 0) {
      const ssize_t n = ::write(fd_, p, size);
      if (n < 0) {
        if (errno == EINTR) continue;
        throw_write_error(path_, "write", errno);
      }
      p += n;
      size -= static_cast<std::size_t>(n);
    }
  }

  int fd_;
  const std::string& path_;
  StreamHash hash_;
  std::vector<unsigned char> buffer_;
  std::size_t used_ = 0;
  std::uint64_t written_ = 0;
};

/// The arrays of the file to write. An empty cover table (e.g. from import_paper_text) is
/// written as all-zero offsets, which `zero_cover_offsets` holds.
GraphArrays arrays_to_write(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                            const ProximityGraph& graph,
                            std::vector<std::uint32_t>& zero_cover_offsets) {
  std::span<const std::uint32_t> cover_offsets = graph.cover_offsets;
  if (cover_offsets.empty() && graph.cover_sample.empty()) {
    zero_cover_offsets.assign(mesh.num_vertices() + 1, 0);
    cover_offsets = zero_cover_offsets;
  }
  GraphArrays a;
  a.num_vertices = mesh.num_vertices();
  a.num_faces = mesh.num_faces();
  a.num_edges = mesh.num_edges();
  a.longest_edge = graph.longest_edge;
  a.covering_radius = graph.covering_radius;
  a.link_radius = graph.link_radius;
  a.faces = mesh.faces();
  a.positions = mesh.positions();
  a.edge_lengths = geometry.edge_lengths();
  a.sample_vertex = graph.sample_vertex;
  a.edge_offsets = graph.edge_offsets;
  a.edge_target = graph.edge_target;
  a.edge_distance = graph.edge_distance;
  a.edge_direction = graph.edge_direction;
  a.cover_offsets = cover_offsets;
  a.cover_sample = graph.cover_sample;
  a.cover_distance = graph.cover_distance;
  return a;
}

/// Throws InvalidGraph unless the graph fits the mesh and its arrays fit each other.
void check_writable(const std::string& path, const TriangleMesh& mesh, const ProximityGraph& graph,
                    const GraphArrays& a) {
  std::string problem;
  if (graph.num_vertices != mesh.num_vertices()) {
    problem = "the graph was built for " + std::to_string(graph.num_vertices) +
              " vertices, the mesh has " + std::to_string(mesh.num_vertices());
  } else {
    problem = arrays_problem(a);
  }
  if (!problem.empty()) {
    throw InvalidInput(ErrorCode::InvalidGraph,
                       "refusing to write graph file '" + path + "': " + problem);
  }
}

inline constexpr std::uint32_t kMaxSectionsWritten =
    kGraphFileSectionCount + kGraphFileRefinementSectionCount;

/// Header, section table and array bytes of a file, and where its checksum goes.
struct FileLayout {
  GraphFileHeader header{};
  std::uint32_t sections = 0;
  GraphFileSection table[kMaxSectionsWritten];
  std::span<const std::byte> data[kMaxSectionsWritten];
  std::uint64_t checksum_offset = 0;
};

/// The refinement sections' contents of a graph built on a refinement of `input`.
struct RefinementToWrite {
  GraphFileRefinement record{};
  std::span<const std::uint32_t> source_face;
  std::span<const RefinementMap::CornerBarys> source_bary;
};

RefinementToWrite refinement_to_write(const TriangleMesh& input,
                                      const IntrinsicGeometry& input_geometry,
                                      const RefinedSurface& refined) {
  RefinementToWrite out;
  out.record.input_vertices = input.num_vertices();
  out.record.input_faces = input.num_faces();
  out.record.input_edges = input_geometry.edge_lengths().size();
  out.record.input_fingerprint = mesh_fingerprint(input, input_geometry);
  out.record.max_edge_length = refined.max_edge_length();
  out.source_face = refined.source_face();
  out.source_bary = refined.source_bary();
  return out;
}

GraphFileHeader header_of(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                          const ProximityGraph& graph, const GraphFileMetadata& metadata,
                          const GraphArrays& a) {
  GraphFileHeader header{};
  std::memcpy(header.magic, kGraphFileMagic, sizeof header.magic);
  const bool refined = graph.refined != nullptr;
  header.version = refined ? kGraphFileVersionRefined : kGraphFileVersion;
  header.endian_marker = kGraphFileEndianMarker;
  header.section_count =
      kGraphFileSectionCount + (refined ? kGraphFileRefinementSectionCount : 0);
  header.header_size = static_cast<std::uint32_t>(align_up(
      kFixedHeaderSize + header.section_count * sizeof(GraphFileSection), kGraphFileAlignment));
  header.param_samples = static_cast<std::uint32_t>(graph.sample_vertex.size());
  header.param_neighbors = graph.neighbors;
  const SamplingMethod sampling = metadata.sampling == SamplingMethod::Automatic
                                      ? graph.stats.sampling_used
                                      : metadata.sampling;
  header.param_sampling = static_cast<std::uint32_t>(sampling);
  header.longest_edge = graph.longest_edge;
  header.covering_radius = graph.covering_radius;
  header.link_radius = graph.link_radius;
  header.num_vertices = a.num_vertices;
  header.num_faces = a.num_faces;
  header.num_edges = a.num_edges;
  header.num_samples = a.sample_vertex.size();
  header.num_graph_edges = a.edge_target.size();
  header.num_covers = a.cover_sample.size();
  header.mesh_fingerprint = mesh_fingerprint(mesh, geometry);
  std::memcpy(header.source_mesh, metadata.source_mesh.data(),
              std::min(metadata.source_mesh.size(), sizeof header.source_mesh - 1));
  return header;
}

/// Places the arrays after the header, each at a multiple of kGraphFileAlignment, and the
/// checksum after them; completes the header's file_size.
FileLayout lay_out(const GraphFileHeader& header, const GraphArrays& a,
                   const RefinementToWrite* refinement) {
  FileLayout layout;
  layout.header = header;
  layout.sections = header.section_count;
  const std::span<const std::byte> data[kMaxSectionsWritten] = {
      std::as_bytes(a.faces),         std::as_bytes(a.positions),
      std::as_bytes(a.edge_lengths),  std::as_bytes(a.sample_vertex),
      std::as_bytes(a.edge_offsets),  std::as_bytes(a.edge_target),
      std::as_bytes(a.edge_distance), std::as_bytes(a.edge_direction),
      std::as_bytes(a.cover_offsets), std::as_bytes(a.cover_sample),
      std::as_bytes(a.cover_distance),
      refinement ? std::as_bytes(std::span(&refinement->record, 1)) : std::span<const std::byte>(),
      refinement ? std::as_bytes(refinement->source_face) : std::span<const std::byte>(),
      refinement ? std::as_bytes(refinement->source_bary) : std::span<const std::byte>()};
  std::uint64_t offset = header.header_size;
  for (std::uint32_t k = 0; k < layout.sections; ++k) {
    const SectionSpec& spec =
        k < kGraphFileSectionCount ? kSections[k] : kRefinementSections[k - kGraphFileSectionCount];
    offset = align_up(offset, kGraphFileAlignment);
    GraphFileSection& row = layout.table[k];
    row.id = static_cast<std::uint32_t>(spec.id);
    row.element_size = spec.element_size;
    row.offset = offset;
    row.size = data[k].size();
    row.count = data[k].size() / spec.element_size;
    layout.data[k] = data[k];
    offset += data[k].size();
  }
  layout.checksum_offset = align_up(offset, 8);
  layout.header.file_size = layout.checksum_offset + 8;
  return layout;
}

/// Creates `temp`, a temporary next to the target (so the rename stays within one file
/// system), locked until renamed: remove_stale_graph_temporaries leaves a locked temporary
/// alone. If such a cleaner locked and unlinked it between mkostemp and flock, makes another.
void create_locked_temporary(const std::string& path, TempFile& temp) {
  for (;;) {
    std::string name = path + kTemporarySuffix;
    const int fd = ::mkostemp(name.data(), O_CLOEXEC);
    if (fd < 0) throw_write_error(path, "creating a temporary file", errno);
    temp.name = std::move(name);
    temp.fd = fd;
    struct stat st {};
    if (::flock(fd, LOCK_EX) != 0 || ::fstat(fd, &st) != 0 || st.st_nlink > 0) break;
    ::close(fd);
    temp.fd = -1;
    temp.name.clear();
  }
  if (::fchmod(temp.fd, 0644) != 0) throw_write_error(path, "fchmod", errno);
}

void write_contents(int fd, const std::string& path, const FileLayout& layout) {
  Sink sink(fd, path);
  sink.put(&layout.header, sizeof layout.header);
  sink.put(layout.table, layout.sections * sizeof(GraphFileSection));
  for (std::uint32_t k = 0; k < layout.sections; ++k) {
    sink.pad_to(layout.table[k].offset);
    sink.put(layout.data[k].data(), layout.data[k].size());
  }
  sink.pad_to(layout.checksum_offset);
  sink.finish_with_checksum();
}

/// Makes the complete temporary durable and renames it over `path`.
void commit(TempFile& temp, const std::string& path) {
  if (::fsync(temp.fd) != 0) throw_write_error(path, "fsync", errno);
#if defined(POSIX_FADV_DONTNEED)
  // The written pages, clean now, leave the page cache: whoever maps the file next (a daemon
  // serving the graph it has just built) reads it back through readahead, and the graph's
  // random reads run faster on those pages than on the ones write() left (docs/graph_file.md).
  (void)::posix_fadvise(temp.fd, 0, 0, POSIX_FADV_DONTNEED);
#endif
  // Renamed while still open and locked (a cleaner could otherwise remove it in between);
  // closing after the fsync cannot lose data.
  if (::rename(temp.name.c_str(), path.c_str()) != 0) {
    throw_write_error(path, "renaming " + temp.name, errno);
  }
  temp.committed = true;

  // Make the rename itself durable (best effort: the file is complete under its name already).
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  const std::string dir = parent.empty() ? std::string(".") : parent.string();
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    (void)::fsync(dir_fd);
    ::close(dir_fd);
  }
}

}  // namespace

void write_graph_file(const std::string& path, const TriangleMesh& mesh,
                      const IntrinsicGeometry& geometry, const ProximityGraph& graph,
                      const GraphFileMetadata& metadata) {
  // A graph built on a refinement is over the refined mesh; `mesh` is the one it refines.
  const TriangleMesh& graph_mesh = graph.refined ? graph.refined->mesh() : mesh;
  const IntrinsicGeometry& graph_geometry = graph.refined ? graph.refined->geometry() : geometry;
  std::optional<RefinementToWrite> refinement;
  if (graph.refined) {
    if (&graph.refined->input() != &mesh) {
      throw InvalidInput(ErrorCode::InvalidGraph,
                         "refusing to write graph file '" + path +
                             "': the graph was built on a refinement of another mesh object");
    }
    refinement = refinement_to_write(mesh, geometry, *graph.refined);
  }
  std::vector<std::uint32_t> zero_cover_offsets;
  const GraphArrays arrays =
      arrays_to_write(graph_mesh, graph_geometry, graph, zero_cover_offsets);
  check_writable(path, graph_mesh, graph, arrays);
  const FileLayout layout =
      lay_out(header_of(graph_mesh, graph_geometry, graph, metadata, arrays), arrays,
              refinement ? &*refinement : nullptr);
  TempFile temp;
  create_locked_temporary(path, temp);
  write_contents(temp.fd, path, layout);
  commit(temp, path);
}

std::vector<std::string> remove_stale_graph_temporaries(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  const std::string prefix = target.filename().string() + ".tmp-";
  const std::size_t random_chars = std::strlen(kTemporarySuffix) - std::strlen(".tmp-");
  std::vector<fs::path> candidates;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() == prefix.size() + random_chars && name.starts_with(prefix) &&
        std::all_of(name.begin() + static_cast<std::ptrdiff_t>(prefix.size()), name.end(),
                    [](char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0; })) {
      candidates.push_back(it->path());
    }
  }
  std::vector<std::string> removed;
  for (const fs::path& candidate : candidates) {
    const int fd = ::open(candidate.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
    if (fd < 0) continue;
    // Unlocked means its writer is gone (the lock dies with the process, even on SIGKILL).
    // Unlink only the file that was locked, not one renamed to that name meanwhile.
    struct stat by_fd {
    }, by_name{};
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0 && ::fstat(fd, &by_fd) == 0 && S_ISREG(by_fd.st_mode) &&
        ::lstat(candidate.c_str(), &by_name) == 0 && by_fd.st_dev == by_name.st_dev &&
        by_fd.st_ino == by_name.st_ino && ::unlink(candidate.c_str()) == 0) {
      removed.push_back(candidate.string());
    }
    ::close(fd);
  }
  return removed;
}

}  // namespace geoprox
