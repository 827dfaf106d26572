#include "core/graph/graph_file.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cctype>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <istream>
#include <limits>
#include <ostream>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/base/errors.h"

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

namespace {

// ---------------------------------------------------------------------------------------------
// Hash: four independent lanes (so the multiplies overlap), one 8-byte word per lane per step.

constexpr std::uint64_t kMulA = 0x9E3779B97F4A7C15ull;
constexpr std::uint64_t kMulB = 0xD6E8FEB86659FD93ull;
constexpr std::uint64_t kMulC = 0xBF58476D1CE4E5B9ull;
constexpr std::uint64_t kMulD = 0x94D049BB133111EBull;
constexpr std::uint64_t kChecksumSeed = kGraphFileChecksumSeed;
constexpr std::uint64_t kFingerprintSeed = kMeshFingerprintSeed;

inline std::uint64_t load64(const unsigned char* p) {
  std::uint64_t w;
  std::memcpy(&w, p, 8);
  return w;
}

inline std::uint64_t lane_step(std::uint64_t lane, std::uint64_t word) {
  return std::rotl(lane + word * kMulB, 29) * kMulA;
}

class StreamHash {
 public:
  explicit StreamHash(std::uint64_t seed)
      : lanes_{seed + kMulA, seed ^ kMulB, seed - kMulC, ~seed + kMulD} {}

  void update(const void* data, std::size_t size) {
    if (size == 0) return;  // data may be null (empty arrays)
    const auto* p = static_cast<const unsigned char*>(data);
    total_ += size;
    if (buffered_ > 0) {
      const std::size_t take = std::min(size, sizeof(buffer_) - buffered_);
      std::memcpy(buffer_ + buffered_, p, take);
      buffered_ += take;
      p += take;
      size -= take;
      if (buffered_ < sizeof(buffer_)) return;
      blocks(buffer_, 1);
      buffered_ = 0;
    }
    const std::size_t full = size / 32;
    blocks(p, full);
    p += full * 32;
    size -= full * 32;
    std::memcpy(buffer_, p, size);
    buffered_ = size;
  }

  std::uint64_t finish() {
    if (buffered_ > 0) {  // zero-padded last block; the total length disambiguates
      std::memset(buffer_ + buffered_, 0, sizeof(buffer_) - buffered_);
      blocks(buffer_, 1);
      buffered_ = 0;
    }
    std::uint64_t h = lanes_[0];
    h = (h ^ std::rotl(lanes_[1], 17)) * kMulC;
    h = (h ^ std::rotl(lanes_[2], 31)) * kMulD;
    h = (h ^ std::rotl(lanes_[3], 47)) * kMulA;
    h ^= total_ * kMulB;
    h ^= h >> 30;
    h *= kMulC;
    h ^= h >> 27;
    h *= kMulD;
    h ^= h >> 31;
    return h;
  }

 private:
  void blocks(const unsigned char* p, std::size_t count) {
    std::uint64_t l0 = lanes_[0], l1 = lanes_[1], l2 = lanes_[2], l3 = lanes_[3];
    for (std::size_t i = 0; i < count; ++i, p += 32) {
      l0 = lane_step(l0, load64(p));
      l1 = lane_step(l1, load64(p + 8));
      l2 = lane_step(l2, load64(p + 16));
      l3 = lane_step(l3, load64(p + 24));
    }
    lanes_[0] = l0;
    lanes_[1] = l1;
    lanes_[2] = l2;
    lanes_[3] = l3;
  }

  std::uint64_t lanes_[4];
  unsigned char buffer_[32] = {};
  std::size_t buffered_ = 0;
  std::uint64_t total_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Small helpers

std::string errno_text(int error) { return std::generic_category().message(error); }

std::string hex64(std::uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "0x%016" PRIx64, v);
  return buf;
}

std::string fmt_double(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

constexpr std::uint64_t align_up(std::uint64_t v, std::uint64_t a) { return (v + a - 1) / a * a; }

constexpr std::uint64_t kFixedHeaderSize = sizeof(GraphFileHeader);
constexpr std::uint64_t kMaxSections = 1024;

struct SectionSpec {
  GraphFileSectionId id;
  std::uint32_t element_size;
  const char* name;
};

constexpr SectionSpec kSections[kGraphFileSectionCount] = {
    {GraphFileSectionId::Faces, 12, "faces"},
    {GraphFileSectionId::Positions, 24, "positions"},
    {GraphFileSectionId::EdgeLengths, 8, "edge_lengths"},
    {GraphFileSectionId::SampleVertex, 4, "sample_vertex"},
    {GraphFileSectionId::EdgeOffsets, 4, "edge_offsets"},
    {GraphFileSectionId::EdgeTarget, 4, "edge_target"},
    {GraphFileSectionId::EdgeDistance, 8, "edge_distance"},
    {GraphFileSectionId::EdgeDirection, 12, "edge_direction"},
    {GraphFileSectionId::CoverOffsets, 4, "cover_offsets"},
    {GraphFileSectionId::CoverSample, 4, "cover_sample"},
    {GraphFileSectionId::CoverDistance, 4, "cover_distance"},
};

/// Index of a known section id in kSections, or -1.
int section_index(std::uint32_t id) {
  return id >= 1 && id <= kGraphFileSectionCount ? static_cast<int>(id) - 1 : -1;
}

// ---------------------------------------------------------------------------------------------
// Validation shared by the writer (before anything is created) and the reader (on the mapping).

struct GraphArrays {
  std::uint64_t num_vertices = 0, num_faces = 0, num_edges = 0;
  double longest_edge = 0, covering_radius = 0, link_radius = 0;
  std::span<const Triangle> faces;
  std::span<const Vec3> positions;
  std::span<const double> edge_lengths;
  std::span<const std::uint32_t> sample_vertex, edge_offsets, edge_target;
  std::span<const double> edge_distance;
  std::span<const GraphDirection> edge_direction;
  std::span<const std::uint32_t> cover_offsets, cover_sample;
  std::span<const float> cover_distance;
  /// The checks of single values (ValueChecks below) already ran on the file's bytes.
  bool values_checked = false;
};

// Checks of single values that need no other array (ids in range, finite or finite and
// non-negative numbers), over a run of one section's scalars that starts at scalar `first`.
// The writer runs them on whole arrays; the reader on the file's bytes as they stream through
// the checksum, so that opening need not fault in the pages of the mapping that hold them.
// Each first asks whether there is any offender (a branch-free scan the compiler vectorizes)
// and looks for the first one only when there is.

constexpr std::uint64_t kDoubleInfinityBits = 0x7ff0000000000000ull;
constexpr std::uint32_t kFloatInfinityBits = 0x7f800000u;

/// Whether the bits of any value, as an unsigned integer, are >= limit (after `shift` left).
template <class Bits, class T>
bool any_bits_at_or_above(std::span<const T> values, Bits limit, int shift = 0) {
  static_assert(sizeof(Bits) == sizeof(T));
  const T* data = values.data();
  Bits any = 0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    Bits bits;
    std::memcpy(&bits, data + i, sizeof bits);  // (a load the vectorizer sees through)
    any |= static_cast<Bits>((bits << shift) >= limit);
  }
  return any != 0;
}

template <class T>
std::uint64_t first_index_where(std::span<const T> values, auto&& bad) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (bad(values[i])) return i;
  }
  return values.size();
}

std::string face_ids_problem(std::span<const std::uint32_t> ids, std::uint64_t first,
                             std::uint64_t nv, std::span<const Triangle> faces) {
  if (!any_bits_at_or_above(ids, static_cast<std::uint32_t>(nv))) return {};
  const std::uint64_t f =
      (first + first_index_where(ids, [&](std::uint32_t id) { return id >= nv; })) / 3;
  const Triangle& t = faces[f];
  return "face " + std::to_string(f) + " has a vertex id out of range (" + std::to_string(t[0]) +
         ", " + std::to_string(t[1]) + ", " + std::to_string(t[2]) + "; " + std::to_string(nv) +
         " vertices)";
}

std::string coordinates_problem(std::span<const double> coords, std::uint64_t first) {
  if (!any_bits_at_or_above(coords, kDoubleInfinityBits << 1, 1)) return {};  // sign shifted out
  const std::uint64_t k =
      first + first_index_where(coords, [](double c) { return !std::isfinite(c); });
  return "vertex " + std::to_string(k / 3) + " has a non-finite coordinate";
}

/// Finite and >= 0 (-0.0 included): as bits, below infinity's (the fast path sends -0.0 to the
/// exact scan, which accepts it).
template <class Float>
std::uint64_t first_negative_or_non_finite(std::span<const Float> values) {
  using Bits = std::conditional_t<sizeof(Float) == 8, std::uint64_t, std::uint32_t>;
  constexpr Bits infinity =
      sizeof(Float) == 8 ? Bits(kDoubleInfinityBits) : Bits(kFloatInfinityBits);
  if (!any_bits_at_or_above(values, infinity)) return values.size();
  return first_index_where(values, [](Float v) { return !(std::isfinite(v) && v >= 0); });
}

std::string edge_lengths_problem(std::span<const double> lengths, std::uint64_t first) {
  const std::uint64_t k = first_negative_or_non_finite(lengths);
  if (k == lengths.size()) return {};
  return "edge " + std::to_string(first + k) + " has length " + fmt_double(lengths[k]);
}

std::string edge_distances_problem(std::span<const double> distances, std::uint64_t first) {
  const std::uint64_t k = first_negative_or_non_finite(distances);
  if (k == distances.size()) return {};
  return "graph edge " + std::to_string(first + k) + " has distance " + fmt_double(distances[k]);
}

std::string cover_samples_problem(std::span<const std::uint32_t> samples, std::uint64_t first,
                                  std::uint64_t ns) {
  if (!any_bits_at_or_above(samples, static_cast<std::uint32_t>(ns))) return {};
  const std::uint64_t k = first_index_where(samples, [&](std::uint32_t j) { return j >= ns; });
  return "cover entry " + std::to_string(first + k) + " names sample " +
         std::to_string(samples[k]) + " of " + std::to_string(ns);
}

std::string cover_distances_problem(std::span<const float> distances, std::uint64_t first) {
  const std::uint64_t k = first_negative_or_non_finite(distances);
  if (k == distances.size()) return {};
  return "cover entry " + std::to_string(first + k) + " has distance " + fmt_double(distances[k]);
}

std::string size_problem(const char* what, std::size_t got, std::uint64_t want) {
  return std::string(what) + " has " + std::to_string(got) + " entries, expected " +
         std::to_string(want);
}

/// Checks one CSR offset array against `rows` rows and `entries` entries.
std::string csr_problem(const char* what, std::span<const std::uint32_t> offsets,
                        std::uint64_t rows, std::size_t entries) {
  if (offsets.size() != rows + 1) return size_problem(what, offsets.size(), rows + 1);
  if (offsets[0] != 0)
    return std::string(what) + "[0] is " + std::to_string(offsets[0]) + ", not 0";
  for (std::size_t i = 0; i < rows; ++i) {
    if (offsets[i + 1] < offsets[i]) {
      return std::string(what) + " decrease at row " + std::to_string(i) + " (" +
             std::to_string(offsets[i]) + " then " + std::to_string(offsets[i + 1]) + ")";
    }
  }
  if (offsets[rows] != entries) {
    return std::string(what) + " end at " + std::to_string(offsets[rows]) + " but there are " +
           std::to_string(entries) + " entries";
  }
  return {};
}

/// Empty string if consistent, else a description of the first problem.
std::string arrays_problem(const GraphArrays& a) {
  const std::uint64_t nv = a.num_vertices, nf = a.num_faces;
  if (nv > std::numeric_limits<std::uint32_t>::max() ||
      nf > std::numeric_limits<std::uint32_t>::max()) {
    return "more than 2^32 vertices or faces";
  }
  if (a.positions.size() != nv) return size_problem("positions", a.positions.size(), nv);
  if (a.faces.size() != nf) return size_problem("faces", a.faces.size(), nf);
  if (a.edge_lengths.size() != a.num_edges) {
    return size_problem("edge_lengths", a.edge_lengths.size(), a.num_edges);
  }
  if (!a.values_checked) {  // the mesh's single values, before anything indexes with them
    const std::span<const std::uint32_t> ids(
        reinterpret_cast<const std::uint32_t*>(a.faces.data()), 3 * a.faces.size());
    if (std::string p = face_ids_problem(ids, 0, nv, a.faces); !p.empty()) return p;
    const std::span<const double> coords(reinterpret_cast<const double*>(a.positions.data()),
                                         3 * a.positions.size());
    if (std::string p = coordinates_problem(coords, 0); !p.empty()) return p;
    if (std::string p = edge_lengths_problem(a.edge_lengths, 0); !p.empty()) return p;
  }
  if (!(std::isfinite(a.longest_edge) && a.longest_edge >= 0)) {
    return "R (longest edge) is " + fmt_double(a.longest_edge);
  }
  if (!(std::isfinite(a.covering_radius) && a.covering_radius >= 0)) {
    return "r (covering radius) is " + fmt_double(a.covering_radius);
  }
  if (!(std::isfinite(a.link_radius) && a.link_radius >= 0)) {
    return "the link radius is " + fmt_double(a.link_radius);
  }

  // Samples: distinct vertices.
  const std::uint64_t ns = a.sample_vertex.size();
  std::vector<std::uint8_t> is_sample(nv, 0);
  for (std::size_t i = 0; i < ns; ++i) {
    const std::uint32_t v = a.sample_vertex[i];
    if (v >= nv) {
      return "sample " + std::to_string(i) + " is at vertex " + std::to_string(v) + " of " +
             std::to_string(nv);
    }
    if (is_sample[v]) {
      return "sample " + std::to_string(i) + " repeats vertex " + std::to_string(v);
    }
    is_sample[v] = 1;
  }

  // Graph edges.
  const std::size_t ne = a.edge_target.size();
  if (std::string p = csr_problem("edge_offsets", a.edge_offsets, ns, ne); !p.empty()) return p;
  if (a.edge_distance.size() != ne)
    return size_problem("edge_distance", a.edge_distance.size(), ne);
  if (a.edge_direction.size() != ne) {
    return size_problem("edge_direction", a.edge_direction.size(), ne);
  }
  for (std::uint32_t i = 0; i < ns; ++i) {
    const std::uint32_t v = a.sample_vertex[i];
    for (std::uint32_t k = a.edge_offsets[i]; k < a.edge_offsets[i + 1]; ++k) {
      const std::uint32_t j = a.edge_target[k];
      const auto edge = [k] { return "graph edge " + std::to_string(k); };  // only on failure
      if (j >= ns) {
        return edge() + " (from sample " + std::to_string(i) + ") targets sample " +
               std::to_string(j) + " of " + std::to_string(ns);
      }
      if (j == i) return edge() + " is a loop at sample " + std::to_string(i);
      const GraphDirection& dir = a.edge_direction[k];
      if (dir.face >= nf) {
        return edge() + " has its direction in face " + std::to_string(dir.face) + " of " +
               std::to_string(nf);
      }
      if (!std::isfinite(dir.x) || !std::isfinite(dir.y)) {
        return edge() + " has a non-finite direction";
      }
      const Triangle& t = a.faces[dir.face];
      if (t[0] != v && t[1] != v && t[2] != v) {
        return edge() + " has its direction in face " + std::to_string(dir.face) +
               ", which does not touch its sample's vertex " + std::to_string(v);
      }
    }
  }

  // Cover table.
  const std::size_t nc = a.cover_sample.size();
  if (std::string p = csr_problem("cover_offsets", a.cover_offsets, nv, nc); !p.empty()) return p;
  if (a.cover_distance.size() != nc) {
    return size_problem("cover_distance", a.cover_distance.size(), nc);
  }

  if (!a.values_checked) {  // the rest of the single values
    if (std::string p = edge_distances_problem(a.edge_distance, 0); !p.empty()) return p;
    if (std::string p = cover_samples_problem(a.cover_sample, 0, a.sample_vertex.size());
        !p.empty()) {
      return p;
    }
    if (std::string p = cover_distances_problem(a.cover_distance, 0); !p.empty()) return p;
  }
  return {};
}

// ---------------------------------------------------------------------------------------------
// Writing

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
  ~TempFile() {
    if (fd >= 0) ::close(fd);
    if (!committed && !name.empty()) ::unlink(name.c_str());
  }
};

/// Buffered sequential writer that hashes everything it writes.
class Sink {
 public:
  Sink(int fd, const std::string& path) : fd_(fd), path_(path), hash_(kChecksumSeed) {
    buffer_.resize(1 << 20);
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

template <typename T>
std::span<const std::byte> bytes_of(std::span<const T> s) {
  return std::as_bytes(s);
}

// ---------------------------------------------------------------------------------------------
// Reading

[[noreturn]] void throw_open_error(ErrorCode code, const std::string& path,
                                   const std::string& what) {
  throw FileError(code, "graph file '" + path + "': " + what);
}

template <typename T>
std::span<const T> section_span(const unsigned char* base, const GraphFileSection& s) {
  return {reinterpret_cast<const T*>(base + s.offset), static_cast<std::size_t>(s.count)};
}

}  // namespace

// ---------------------------------------------------------------------------------------------

std::string_view graph_file_section_name(std::uint32_t id) {
  const int k = section_index(id);
  return k < 0 ? std::string_view("unknown") : std::string_view(kSections[k].name);
}

namespace {

struct FileDescriptorCloser {
  int fd;
  ~FileDescriptorCloser() { ::close(fd); }
};

/// arrays_problem's single-value checks, run on pieces of the file's bytes (split anywhere at
/// multiples of 8 bytes) as they stream through the checksum; keeps the first problem found.
class ValueChecks {
 public:
  ValueChecks(const GraphFileSection* const* found, const GraphFileHeader& h,
              std::span<const Triangle> faces)
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
    if (auto j = piece<std::uint32_t>(Id::CoverSample, chunk, first);
        p.empty() && !j.empty())
      p = cover_samples_problem(j, first, h_.num_samples);
    if (auto d = piece<float>(Id::CoverDistance, chunk, first); p.empty() && !d.empty())
      p = cover_distances_problem(d, first);
    problem_ = std::move(p);
  }

  const std::string& problem() const { return problem_; }

 private:
  /// The part of section `id` inside `chunk`, as values of type T;
  /// `first` gets the index of its first value in the section.
  struct Chunk {  // bytes [offset, offset + size) of the file
    std::uint64_t offset;
    const unsigned char* bytes;
    std::size_t size;
  };
  template <class T>
  std::span<const T> piece(GraphFileSectionId id, const Chunk& chunk, std::uint64_t& first) const {
    const GraphFileSection& s = *found_[static_cast<std::uint32_t>(id) - 1];
    const std::uint64_t lo = std::max(chunk.offset, s.offset),
                        hi = std::min(chunk.offset + chunk.size, s.offset + s.size);
    if (lo >= hi) return {};
    first = (lo - s.offset) / sizeof(T);
    return {reinterpret_cast<const T*>(chunk.bytes + (lo - chunk.offset)), (hi - lo) / sizeof(T)};
  }

  const GraphFileSection* const* found_;
  const GraphFileHeader& h_;
  std::span<const Triangle> faces_;  // the mapping's, for messages only
  std::string problem_;
};

/// graph_file_hash of the file's first `size` bytes, read with pread through one reused buffer;
/// `each_piece(offset, bytes, size)` sees every piece read (pieces are multiples of 8 bytes).
std::uint64_t hash_file_prefix(int fd, const std::string& path, std::uint64_t size,
                               std::uint64_t seed, auto&& each_piece) {
  constexpr std::size_t kChunk = 256 * 1024;  // fits in L2: each byte is copied, then hashed
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

}  // namespace

std::uint64_t graph_file_hash(const void* data, std::size_t size, std::uint64_t seed) {
  StreamHash h(seed);
  h.update(data, size);
  return h.finish();
}

std::uint64_t mesh_fingerprint(const TriangleMesh& mesh, const IntrinsicGeometry& geometry) {
  StreamHash h(kFingerprintSeed);
  const std::uint64_t counts[3] = {mesh.num_vertices(), mesh.num_faces(),
                                   geometry.edge_lengths().size()};
  h.update(counts, sizeof counts);
  h.update(mesh.faces().data(), mesh.faces().size() * sizeof(Triangle));
  h.update(geometry.edge_lengths().data(), geometry.edge_lengths().size() * sizeof(double));
  return h.finish();
}

void write_graph_file(const std::string& path, const TriangleMesh& mesh,
                      const IntrinsicGeometry& geometry, const ProximityGraph& graph,
                      const GraphFileMetadata& metadata) {
  // An empty cover table (e.g. from import_paper_text without offsets) is written as all-zero
  // offsets.
  std::vector<std::uint32_t> zero_cover_offsets;
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
  std::string problem;
  if (graph.num_vertices != mesh.num_vertices()) {
    problem = "the graph was built for " + std::to_string(graph.num_vertices) +
              " vertices, the mesh has " + std::to_string(mesh.num_vertices());
  } else {
    problem = arrays_problem(a);
  }
  if (!problem.empty()) {
    throw InvalidInput(ErrorCode::InvalidGraph, "refusing to write graph file '" + path + "': " + problem);
  }

  // Layout.
  GraphFileHeader header{};
  std::memcpy(header.magic, kGraphFileMagic, sizeof header.magic);
  header.version = kGraphFileVersion;
  header.endian_marker = kGraphFileEndianMarker;
  header.section_count = kGraphFileSectionCount;
  header.header_size = static_cast<std::uint32_t>(align_up(
      kFixedHeaderSize + kGraphFileSectionCount * sizeof(GraphFileSection), kGraphFileAlignment));
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

  const std::span<const std::byte> data[kGraphFileSectionCount] = {
      bytes_of(a.faces),         bytes_of(a.positions),      bytes_of(a.edge_lengths),
      bytes_of(a.sample_vertex), bytes_of(a.edge_offsets),   bytes_of(a.edge_target),
      bytes_of(a.edge_distance), bytes_of(a.edge_direction), bytes_of(a.cover_offsets),
      bytes_of(a.cover_sample),  bytes_of(a.cover_distance)};
  GraphFileSection table[kGraphFileSectionCount];
  std::uint64_t offset = header.header_size;
  for (std::uint32_t k = 0; k < kGraphFileSectionCount; ++k) {
    offset = align_up(offset, kGraphFileAlignment);
    table[k].id = static_cast<std::uint32_t>(kSections[k].id);
    table[k].element_size = kSections[k].element_size;
    table[k].offset = offset;
    table[k].size = data[k].size();
    table[k].count = data[k].size() / kSections[k].element_size;
    offset += data[k].size();
  }
  const std::uint64_t checksum_offset = align_up(offset, 8);
  header.file_size = checksum_offset + 8;

  // Temporary next to the target, so the rename stays within one file system. It is locked
  // until renamed: remove_stale_graph_temporaries leaves a locked temporary alone. If such a
  // cleaner locked and unlinked it between mkostemp and flock, make another one.
  TempFile temp;
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

  Sink sink(temp.fd, path);
  sink.put(&header, sizeof header);
  sink.put(table, sizeof table);
  for (std::uint32_t k = 0; k < kGraphFileSectionCount; ++k) {
    sink.pad_to(table[k].offset);
    sink.put(data[k].data(), data[k].size());
  }
  sink.pad_to(checksum_offset);
  sink.finish_with_checksum();

  if (::fsync(temp.fd) != 0) throw_write_error(path, "fsync", errno);
  // Renamed while still open and locked (a cleaner could otherwise remove it in between);
  // closing after the fsync cannot lose data.
  if (::rename(temp.name.c_str(), path.c_str()) != 0) {
    throw_write_error(path, "renaming " + temp.name, errno);
  }
  temp.committed = true;

  // Make the rename itself durable (best effort: the file is complete under its name already).
  std::string dir = std::filesystem::path(path).parent_path().string();
  if (dir.empty()) dir = ".";
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    (void)::fsync(dir_fd);
    ::close(dir_fd);
  }
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
    struct stat by_fd {}, by_name {};
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0 && ::fstat(fd, &by_fd) == 0 &&
        S_ISREG(by_fd.st_mode) && ::lstat(candidate.c_str(), &by_name) == 0 &&
        by_fd.st_dev == by_name.st_dev && by_fd.st_ino == by_name.st_ino &&
        ::unlink(candidate.c_str()) == 0) {
      removed.push_back(candidate.string());
    }
    ::close(fd);
  }
  return removed;
}

// ---------------------------------------------------------------------------------------------

MappedGraphFile::MappedGraphFile(MappedGraphFile&& other) noexcept { *this = std::move(other); }

MappedGraphFile& MappedGraphFile::operator=(MappedGraphFile&& other) noexcept {
  if (this != &other) {
    release();
    path_ = std::move(other.path_);
    base_ = std::exchange(other.base_, nullptr);
    size_ = std::exchange(other.size_, 0);
    header_ = std::exchange(other.header_, GraphFileHeader{});
    checksum_ = std::exchange(other.checksum_, 0);
    sections_ = std::exchange(other.sections_, {});
    faces_ = std::exchange(other.faces_, {});
    positions_ = std::exchange(other.positions_, {});
    edge_lengths_ = std::exchange(other.edge_lengths_, {});
    view_ = std::exchange(other.view_, ProximityGraphView{});
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

GraphFileParams MappedGraphFile::params() const {
  return {header_.param_samples, header_.param_neighbors,
          static_cast<SamplingMethod>(header_.param_sampling)};
}

GraphFileCounts MappedGraphFile::counts() const {
  return {header_.num_vertices, header_.num_faces,       header_.num_edges,
          header_.num_samples,  header_.num_graph_edges, header_.num_covers};
}

std::string_view MappedGraphFile::source_mesh() const {
  return {header_.source_mesh, ::strnlen(header_.source_mesh, sizeof header_.source_mesh)};
}

MappedGraphFile MappedGraphFile::open(const std::string& path, const OpenOptions& options) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int error = errno;
    if (error == ENOENT || error == ENOTDIR) throw_open_error(ErrorCode::FileNotFound, path, "no such file");
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
  const auto actual = static_cast<std::uint64_t>(st.st_size);
  if (actual == 0) {
    ::close(fd);
    throw_open_error(ErrorCode::EmptyFile, path, "is empty (0 bytes), not a graph file");
  }
  // No MAP_POPULATE: the checksum below reads the file through a small buffer, and the mapping's
  // pages are faulted in by the queries that need them. Faulting every page of a 20 MiB file at
  // open costs 10 to 20 ms on a VM (about 2.5 us per page), reading it through 256 KiB a quarter
  // of that. The descriptor stays open until the checksum has been read.
  void* map = ::mmap(nullptr, static_cast<std::size_t>(actual), PROT_READ, MAP_PRIVATE, fd, 0);
  const int map_error = errno;
  const FileDescriptorCloser fd_closer{fd};
  if (map == MAP_FAILED)
    throw_open_error(ErrorCode::ReadError, path, "cannot mmap: " + errno_text(map_error));

  MappedGraphFile file;  // unmaps on any throw below
  file.path_ = path;
  file.base_ = static_cast<const unsigned char*>(map);
  file.size_ = static_cast<std::size_t>(actual);
  const unsigned char* base = file.base_;

  // Magic (a shorter file that starts like the magic is a truncated graph file).
  if (actual < sizeof kGraphFileMagic) {
    if (std::memcmp(base, kGraphFileMagic, actual) == 0) {
      throw_open_error(ErrorCode::Truncated, path,
                       "truncated to " + std::to_string(actual) + " bytes, inside the header");
    }
    throw_open_error(ErrorCode::ForeignFile, path, "not a geoprox graph file (no GEOPROXG magic)");
  }
  if (std::memcmp(base, kGraphFileMagic, sizeof kGraphFileMagic) != 0) {
    throw_open_error(ErrorCode::ForeignFile, path, "not a geoprox graph file (no GEOPROXG magic)");
  }
  if (actual < kFixedHeaderSize) {
    throw_open_error(ErrorCode::Truncated, path,
                     "truncated to " + std::to_string(actual) + " bytes, inside the " +
                         std::to_string(kFixedHeaderSize) + "-byte header");
  }
  GraphFileHeader& h = file.header_;
  std::memcpy(&h, base, sizeof h);
  if (h.endian_marker != kGraphFileEndianMarker) {
    if (h.endian_marker == __builtin_bswap32(kGraphFileEndianMarker)) {
      throw_open_error(ErrorCode::WrongEndianness, path, "written with the other byte order (big-endian)");
    }
    throw_open_error(ErrorCode::CorruptHeader, path, "bad endianness marker " + hex64(h.endian_marker));
  }
  if (h.version != kGraphFileVersion) {
    throw_open_error(ErrorCode::UnsupportedVersion, path,
                     "format version " + std::to_string(h.version) +
                         (h.version > kGraphFileVersion ? " is newer than" : " is not") +
                         " the version this build reads (" + std::to_string(kGraphFileVersion) +
                         "); rebuild the graph with this geoprox");
  }

  // Header geometry: sizes must be self-consistent before they are compared with the file.
  const std::uint64_t table_end =
      kFixedHeaderSize + std::uint64_t{h.section_count} * sizeof(GraphFileSection);
  if (h.section_count < kGraphFileSectionCount || h.section_count > kMaxSections ||
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
  if (actual < h.file_size) {
    throw_open_error(ErrorCode::Truncated, path,
                     "truncated: " + std::to_string(actual) + " bytes, the header says " +
                         std::to_string(h.file_size));
  }
  if (actual > h.file_size) {
    throw_open_error(ErrorCode::CorruptHeader, path,
                     std::to_string(actual - h.file_size) +
                         " bytes of trailing data after the end recorded in the header (" +
                         std::to_string(h.file_size) + " bytes)");
  }
  if (h.param_sampling > static_cast<std::uint32_t>(SamplingMethod::Exact) ||
      h.param_samples != h.num_samples) {
    throw_open_error(ErrorCode::CorruptHeader, path, "inconsistent build parameters in the header");
  }
  const std::uint64_t u32max = std::numeric_limits<std::uint32_t>::max();
  if (h.num_vertices >= u32max || h.num_faces >= u32max || h.num_edges >= u32max ||
      h.num_samples >= u32max || h.num_graph_edges > u32max || h.num_covers > u32max) {
    throw_open_error(ErrorCode::CorruptHeader, path, "counts in the header exceed 32-bit ids");
  }

  // Section table.
  const std::uint64_t data_end = h.file_size - 8;
  file.sections_ = {reinterpret_cast<const GraphFileSection*>(base + kFixedHeaderSize),
                    h.section_count};
  const std::uint64_t expected_count[kGraphFileSectionCount] = {
      h.num_faces,        h.num_vertices,    h.num_edges,       h.num_samples,
      h.num_samples + 1,  h.num_graph_edges, h.num_graph_edges, h.num_graph_edges,
      h.num_vertices + 1, h.num_covers,      h.num_covers};
  const GraphFileSection* found[kGraphFileSectionCount] = {};
  std::vector<std::pair<std::uint64_t, std::uint64_t>> extents;  // offset, end
  for (const GraphFileSection& s : file.sections_) {
    const std::string name = "section " + std::string(graph_file_section_name(s.id)) + " (id " +
                             std::to_string(s.id) + ")";
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
    extents.emplace_back(s.offset, s.offset + s.size);
    const int k = section_index(s.id);
    if (k < 0) continue;  // unknown sections are skipped (bounds checked above)
    if (found[k] != nullptr) throw_open_error(ErrorCode::CorruptHeader, path, name + " appears twice");
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
    found[k] = &s;
  }
  for (std::uint32_t k = 0; k < kGraphFileSectionCount; ++k) {
    if (found[k] == nullptr) {
      throw_open_error(ErrorCode::CorruptHeader, path,
                       std::string("section ") + kSections[k].name + " is missing");
    }
  }
  std::sort(extents.begin(), extents.end());
  for (std::size_t k = 1; k < extents.size(); ++k) {
    if (extents[k].first < extents[k - 1].second) {
      throw_open_error(ErrorCode::CorruptHeader, path,
                       "sections overlap at offset " + std::to_string(extents[k].first));
    }
  }

  // Checksum.
  file.checksum_ = load64(base + data_end);
  bool values_checked = false;
  if (options.verify_checksum) {
    const GraphFileSection& faces =
        *found[static_cast<std::uint32_t>(GraphFileSectionId::Faces) - 1];
    ValueChecks checks(found, h, section_span<Triangle>(base, faces));
    const std::uint64_t computed =
        hash_file_prefix(fd, path, data_end, kChecksumSeed,
                         [&](std::uint64_t offset, const unsigned char* bytes, std::size_t size) {
                           checks.run(offset, bytes, size);
                         });
    if (computed != file.checksum_) {
      throw_open_error(ErrorCode::ChecksumMismatch, path,
                       "checksum mismatch (stored " + hex64(file.checksum_) + ", computed " +
                           hex64(computed) + "): the file is corrupted");
    }
    if (!checks.problem().empty()) {
      throw_open_error(ErrorCode::CorruptGraph, path, "corrupt contents: " + checks.problem());
    }
    values_checked = true;
  }

  // Arrays, in place.
  using Id = GraphFileSectionId;
  auto sec = [&](Id id) -> const GraphFileSection& {
    return *found[static_cast<std::uint32_t>(id) - 1];
  };
  file.faces_ = section_span<Triangle>(base, sec(Id::Faces));
  file.positions_ = section_span<Vec3>(base, sec(Id::Positions));
  file.edge_lengths_ = section_span<double>(base, sec(Id::EdgeLengths));
  ProximityGraphView& v = file.view_;
  v.num_vertices = static_cast<std::uint32_t>(h.num_vertices);
  v.num_samples = static_cast<std::uint32_t>(h.num_samples);
  v.neighbors = h.param_neighbors;
  v.longest_edge = h.longest_edge;
  v.covering_radius = h.covering_radius;
  v.link_radius = h.link_radius;
  v.sample_vertex = section_span<std::uint32_t>(base, sec(Id::SampleVertex));
  v.edge_offsets = section_span<std::uint32_t>(base, sec(Id::EdgeOffsets));
  v.edge_target = section_span<std::uint32_t>(base, sec(Id::EdgeTarget));
  v.edge_distance = section_span<double>(base, sec(Id::EdgeDistance));
  v.edge_direction = section_span<GraphDirection>(base, sec(Id::EdgeDirection));
  v.cover_offsets = section_span<std::uint32_t>(base, sec(Id::CoverOffsets));
  v.cover_sample = section_span<std::uint32_t>(base, sec(Id::CoverSample));
  v.cover_distance = section_span<float>(base, sec(Id::CoverDistance));

  GraphArrays a;
  a.num_vertices = h.num_vertices;
  a.num_faces = h.num_faces;
  a.num_edges = h.num_edges;
  a.longest_edge = h.longest_edge;
  a.covering_radius = h.covering_radius;
  a.link_radius = h.link_radius;
  a.faces = file.faces_;
  a.positions = file.positions_;
  a.edge_lengths = file.edge_lengths_;
  a.sample_vertex = v.sample_vertex;
  a.edge_offsets = v.edge_offsets;
  a.edge_target = v.edge_target;
  a.edge_distance = v.edge_distance;
  a.edge_direction = v.edge_direction;
  a.cover_offsets = v.cover_offsets;
  a.cover_sample = v.cover_sample;
  a.cover_distance = v.cover_distance;
  a.values_checked = values_checked;
  if (std::string problem = arrays_problem(a); !problem.empty()) {
    throw_open_error(ErrorCode::CorruptGraph, path, "corrupt contents: " + problem);
  }
  return file;
}

void MappedGraphFile::verify_mesh(const TriangleMesh& mesh,
                                  const IntrinsicGeometry& geometry) const {
  const std::string prefix = "graph file '" + path_ + "' was built for another mesh: ";
  const std::uint64_t nv = mesh.num_vertices(), nf = mesh.num_faces(),
                      ne = geometry.edge_lengths().size();
  if (nv != header_.num_vertices || nf != header_.num_faces || ne != header_.num_edges) {
    throw FileError(ErrorCode::MeshMismatch, prefix + "it has " + std::to_string(header_.num_vertices) +
                                        " vertices, " + std::to_string(header_.num_faces) +
                                        " faces, " + std::to_string(header_.num_edges) +
                                        " edges; the mesh has " + std::to_string(nv) +
                                        " vertices, " + std::to_string(nf) + " faces, " +
                                        std::to_string(ne) + " edges");
  }
  const std::uint64_t fp = mesh_fingerprint(mesh, geometry);
  if (fp == header_.mesh_fingerprint) return;
  // Say what differs, from the arrays the bundle carries.
  for (std::size_t f = 0; f < faces_.size(); ++f) {
    if (faces_[f] != mesh.face(static_cast<std::uint32_t>(f))) {
      const Triangle& a = faces_[f];
      const Triangle& b = mesh.face(static_cast<std::uint32_t>(f));
      throw FileError(ErrorCode::MeshMismatch,
                      prefix + "same counts but different connectivity: face " + std::to_string(f) +
                          " is (" + std::to_string(a[0]) + ", " + std::to_string(a[1]) + ", " +
                          std::to_string(a[2]) + ") in the file and (" + std::to_string(b[0]) +
                          ", " + std::to_string(b[1]) + ", " + std::to_string(b[2]) +
                          ") in the mesh (fingerprint " + hex64(header_.mesh_fingerprint) + " vs " +
                          hex64(fp) + ")");
    }
  }
  for (std::size_t e = 0; e < edge_lengths_.size(); ++e) {
    const double a = edge_lengths_[e], b = geometry.edge_length(static_cast<std::uint32_t>(e));
    if (std::bit_cast<std::uint64_t>(a) != std::bit_cast<std::uint64_t>(b)) {
      throw FileError(ErrorCode::MeshMismatch,
                      prefix + "same connectivity but different edge lengths: edge " +
                          std::to_string(e) + " is " + fmt_double(a) + " in the file and " +
                          fmt_double(b) + " in the mesh (fingerprint " +
                          hex64(header_.mesh_fingerprint) + " vs " + hex64(fp) + ")");
    }
  }
  throw FileError(ErrorCode::MeshMismatch, prefix + "mesh fingerprint " + hex64(fp) +
                                      " differs from the file's " +
                                      hex64(header_.mesh_fingerprint));
}

TriangleMesh MappedGraphFile::make_mesh() const {
  return TriangleMesh(std::vector<Vec3>(positions_.begin(), positions_.end()),
                      std::vector<Triangle>(faces_.begin(), faces_.end()));
}

IntrinsicGeometry MappedGraphFile::make_geometry(const TriangleMesh& mesh) const {
  return IntrinsicGeometry(mesh, std::vector<double>(edge_lengths_.begin(), edge_lengths_.end()));
}

// ---------------------------------------------------------------------------------------------
// Directions

namespace {

Vec3 normalized_or_zero(const Vec3& v) {
  const double n = norm(v);
  return n > 0 && std::isfinite(n) ? (1.0 / n) * v : Vec3{};
}

/// Orthonormal in-plane frame of face f from the positions (fallback for degenerate layouts).
Vec3 orthonormal_direction(const TriangleMesh& mesh, std::uint32_t f, double x, double y) {
  const Triangle& t = mesh.face(f);
  const Vec3 p0 = mesh.position(t[0]);
  const Vec3 ex = normalized_or_zero(mesh.position(t[1]) - p0);
  const Vec3 w = mesh.position(t[2]) - p0;
  const Vec3 ey = normalized_or_zero(w - dot(w, ex) * ex);
  return normalized_or_zero(x * ex + y * ey);
}

}  // namespace

Vec3 graph_direction_to_3d(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                           const GraphDirection& direction) {
  const std::uint32_t f = direction.face;
  if (f >= mesh.num_faces()) {
    throw InvalidInput(ErrorCode::FaceOutOfRange, "direction in face " + std::to_string(f) + " of " +
                                             std::to_string(mesh.num_faces()));
  }
  const Vec2 c1 = geometry.face_corner(f, 1), c2 = geometry.face_corner(f, 2);
  const double det = c1.x * c2.y - c2.x * c1.y;
  const double scale = std::hypot(c1.x, c1.y) * std::hypot(c2.x, c2.y);
  const double x = direction.x, y = direction.y;
  if (std::abs(det) > 1e-12 * scale) {
    // (x, y) = a c1 + b c2  ->  a (P1 - P0) + b (P2 - P0).
    const double a = (x * c2.y - y * c2.x) / det;
    const double b = (c1.x * y - c1.y * x) / det;
    const Triangle& t = mesh.face(f);
    const Vec3 p0 = mesh.position(t[0]);
    const Vec3 d =
        normalized_or_zero(a * (mesh.position(t[1]) - p0) + b * (mesh.position(t[2]) - p0));
    if (norm(d) > 0) return d;
  }
  return orthonormal_direction(mesh, f, x, y);
}

GraphDirection graph_direction_from_3d(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                                       std::uint32_t vertex, const Vec3& direction) {
  if (vertex >= mesh.num_vertices()) {
    throw InvalidInput(ErrorCode::VertexOutOfRange, "vertex " + std::to_string(vertex) + " of " +
                                               std::to_string(mesh.num_vertices()));
  }
  const Vec3 d = normalized_or_zero(direction);
  if (!(norm(d) > 0)) {
    throw InvalidInput(ErrorCode::BadDirection, "direction is zero or not finite");
  }
  const auto halfedges = mesh.outgoing_halfedges(vertex);
  if (halfedges.empty()) {
    throw InvalidInput(ErrorCode::IsolatedVertex,
                       "vertex " + std::to_string(vertex) + " has no face to hold a direction");
  }
  // Best face: the corner wedge at `vertex` contains the direction (both edge coefficients
  // non-negative) and the direction lies in (or closest to) the face's plane.
  double best_score = std::numeric_limits<double>::infinity();
  GraphDirection best{TriangleMesh::face_of(halfedges[0]), 1, 0};
  for (const std::uint32_t h : halfedges) {
    const std::uint32_t f = TriangleMesh::face_of(h);
    const int k = static_cast<int>(h % 3);
    const Triangle& t = mesh.face(f);
    const Vec3 pv = mesh.position(t[k]);
    const Vec3 u = mesh.position(t[(k + 1) % 3]) - pv;
    const Vec3 w = mesh.position(t[(k + 2) % 3]) - pv;
    const double uu = dot(u, u), uw = dot(u, w), ww = dot(w, w);
    const double det = uu * ww - uw * uw;
    if (!(det > 1e-24 * uu * ww)) continue;  // degenerate face: no reliable plane
    const double du = dot(u, d), dw = dot(w, d);
    const double alpha = (ww * du - uw * dw) / det;
    const double beta = (uu * dw - uw * du) / det;
    const Vec3 in_plane = alpha * u + beta * w;
    const double residual = norm(d - in_plane);
    const double outside =
        std::max(0.0, -alpha * std::sqrt(uu)) + std::max(0.0, -beta * std::sqrt(ww));
    const double score = residual + outside;
    if (!(score < best_score)) continue;
    // Same combination of the face's edge vectors in its intrinsic frame.
    const Vec2 cv = geometry.face_corner(f, k);
    const Vec2 ca = geometry.face_corner(f, (k + 1) % 3);
    const Vec2 cb = geometry.face_corner(f, (k + 2) % 3);
    const double x = alpha * (ca.x - cv.x) + beta * (cb.x - cv.x);
    const double y = alpha * (ca.y - cv.y) + beta * (cb.y - cv.y);
    const double n = std::hypot(x, y);
    if (!(n > 0) || !std::isfinite(n)) continue;
    best_score = score;
    best = {f, static_cast<float>(x / n), static_cast<float>(y / n)};
  }
  return best;
}

// ---------------------------------------------------------------------------------------------
// Paper text format

void export_paper_text(std::ostream& out, const TriangleMesh& mesh,
                       const IntrinsicGeometry& geometry, const ProximityGraphView& graph) {
  const std::size_t ns = graph.sample_vertex.size();
  if (graph.edge_offsets.size() != ns + 1) {
    throw InvalidInput(ErrorCode::InvalidGraph, "edge_offsets has " +
                                           std::to_string(graph.edge_offsets.size()) +
                                           " entries for " + std::to_string(ns) + " samples");
  }
  const std::size_t ne = graph.edge_target.size();
  if (graph.edge_offsets[0] != 0 || graph.edge_offsets[ns] != ne ||
      graph.edge_distance.size() != ne || graph.edge_direction.size() != ne) {
    throw InvalidInput(ErrorCode::InvalidGraph, "edge arrays of inconsistent sizes");
  }
  for (std::size_t i = 0; i < ns; ++i) {
    if (graph.edge_offsets[i + 1] < graph.edge_offsets[i]) {
      throw InvalidInput(ErrorCode::InvalidGraph, "edge_offsets decrease at row " + std::to_string(i));
    }
  }
  std::string text;
  text.reserve(64 * (ns + ne) + 128);
  char line[256];
  text += "# The number of sample points\n";
  text += std::to_string(ns);
  text += "\n# The coordinates of sample points\n";
  for (std::size_t i = 0; i < ns; ++i) {
    const std::uint32_t v = graph.sample_vertex[i];
    if (v >= mesh.num_vertices()) {
      throw InvalidInput(ErrorCode::InvalidGraph, "sample " + std::to_string(i) + " is at vertex " +
                                             std::to_string(v) + " of " +
                                             std::to_string(mesh.num_vertices()));
    }
    const Vec3& p = mesh.position(v);
    std::snprintf(line, sizeof line, "%.17g %.17g %.17g\n", p.x, p.y, p.z);
    text += line;
  }
  text += "# ID1    ID2    Distance    End_direction\n";
  for (std::size_t i = 0; i < ns; ++i) {
    for (std::uint32_t k = graph.edge_offsets[i]; k < graph.edge_offsets[i + 1]; ++k) {
      const Vec3 d = graph_direction_to_3d(mesh, geometry, graph.edge_direction[k]);
      std::snprintf(line, sizeof line, "%zu %u %.17g %.17g %.17g %.17g\n", i + 1,
                    graph.edge_target[k] + 1, graph.edge_distance[k], d.x, d.y, d.z);
      text += line;
    }
    if (text.size() > (1u << 20)) {
      out.write(text.data(), static_cast<std::streamsize>(text.size()));
      text.clear();
    }
  }
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (!out) throw FileError(ErrorCode::WriteError, "cannot write the proximity graph text");
}

namespace {

[[noreturn]] void throw_parse_error(std::size_t line, const std::string& what) {
  throw FileError(ErrorCode::ParseError, "proximity graph text, line " + std::to_string(line) + ": " + what);
}

/// Whitespace-separated tokens of a line.
void split(std::string_view line, std::vector<std::string_view>& tokens) {
  tokens.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
}

bool parse_u64(std::string_view s, std::uint64_t& out) {
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size();
}

bool parse_double(std::string_view s, double& out) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size() && std::isfinite(out);
}

/// Finds the mesh vertex at a coordinate: exact match, else the nearest within `tolerance`.
class VertexLocator {
 public:
  explicit VertexLocator(const TriangleMesh& mesh) : mesh_(mesh) {
    const auto& pos = mesh.positions();
    Vec3 lo = pos[0], hi = pos[0];
    for (const Vec3& p : pos) {
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
    lo_ = lo;
    tolerance_ = 1e-9 * norm(hi - lo);
    cell_ = tolerance_ > 0 ? tolerance_ : 1.0;
    cells_.reserve(pos.size());
    for (std::uint32_t v = 0; v < pos.size(); ++v) {
      std::int64_t c[3] = {0, 0, 0};
      cell_of(pos[v], c);
      cells_.emplace(key(c[0], c[1], c[2]), v);
    }
  }

  double tolerance() const { return tolerance_; }

  /// Vertex within tolerance (nearest, lowest id on ties), or -1; `nearest` gets its distance.
  std::int64_t find(const Vec3& q) const {
    std::int64_t c[3] = {0, 0, 0};
    if (!cell_of(q, c)) return -1;
    std::int64_t best = -1;
    double best_distance = std::numeric_limits<double>::infinity();
    for (std::int64_t dx = -1; dx <= 1; ++dx) {
      for (std::int64_t dy = -1; dy <= 1; ++dy) {
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          const auto range = cells_.equal_range(key(c[0] + dx, c[1] + dy, c[2] + dz));
          for (auto it = range.first; it != range.second; ++it) {
            const std::uint32_t v = it->second;
            const double d = norm(mesh_.position(v) - q);
            if (d > tolerance_) continue;
            if (d < best_distance || (d == best_distance && v < best)) {
              best_distance = d;
              best = v;
            }
          }
        }
      }
    }
    return best;
  }

 private:
  bool cell_of(const Vec3& p, std::int64_t c[3]) const {
    const double r[3] = {(p.x - lo_.x) / cell_, (p.y - lo_.y) / cell_, (p.z - lo_.z) / cell_};
    for (int k = 0; k < 3; ++k) {
      if (!(std::abs(r[k]) < 0x1p60)) return false;
      c[k] = static_cast<std::int64_t>(std::floor(r[k]));
    }
    return true;
  }
  static std::uint64_t key(std::int64_t x, std::int64_t y, std::int64_t z) {
    std::uint64_t h = static_cast<std::uint64_t>(x) * kMulA;
    h = (h ^ static_cast<std::uint64_t>(y)) * kMulC;
    h = (h ^ static_cast<std::uint64_t>(z)) * kMulD;
    return h ^ (h >> 29);
  }

  const TriangleMesh& mesh_;
  Vec3 lo_;
  double tolerance_ = 0, cell_ = 1;
  std::unordered_multimap<std::uint64_t, std::uint32_t> cells_;
};

}  // namespace

ProximityGraph import_paper_text(std::istream& in, const TriangleMesh& mesh,
                                 const IntrinsicGeometry& geometry) {
  const VertexLocator locator(mesh);
  struct Row {
    std::uint32_t from, to;
    double distance;
    GraphDirection direction;
  };
  ProximityGraph graph;
  graph.num_vertices = static_cast<std::uint32_t>(mesh.num_vertices());
  std::vector<Row> rows;
  std::vector<std::int64_t> sample_of_vertex(mesh.num_vertices(), -1);

  enum class Stage { Count, Coordinates, Rows } stage = Stage::Count;
  std::uint64_t count = 0;
  std::string line;
  std::vector<std::string_view> tokens;
  std::size_t line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    split(line, tokens);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    switch (stage) {
      case Stage::Count:
        if (tokens.size() != 1 || !parse_u64(tokens[0], count)) {
          throw_parse_error(line_number,
                            "expected the number of sample points, got '" + line + "'");
        }
        if (count > mesh.num_vertices()) {
          throw_parse_error(line_number, std::to_string(count) + " samples but the mesh has only " +
                                             std::to_string(mesh.num_vertices()) + " vertices");
        }
        graph.sample_vertex.reserve(count);
        stage = count > 0 ? Stage::Coordinates : Stage::Rows;
        break;
      case Stage::Coordinates: {
        Vec3 p;
        if (tokens.size() != 3 || !parse_double(tokens[0], p.x) || !parse_double(tokens[1], p.y) ||
            !parse_double(tokens[2], p.z)) {
          throw_parse_error(line_number, "expected three finite coordinates of sample " +
                                             std::to_string(graph.sample_vertex.size() + 1) +
                                             ", got '" + line + "'");
        }
        const std::int64_t v = locator.find(p);
        if (v < 0) {
          throw_parse_error(line_number,
                            "sample " + std::to_string(graph.sample_vertex.size() + 1) + " at (" +
                                fmt_double(p.x) + ", " + fmt_double(p.y) + ", " + fmt_double(p.z) +
                                ") is not at a mesh vertex (tolerance " +
                                fmt_double(locator.tolerance()) + ")");
        }
        if (sample_of_vertex[v] >= 0) {
          throw_parse_error(line_number,
                            "sample " + std::to_string(graph.sample_vertex.size() + 1) +
                                " is at vertex " + std::to_string(v) + ", like sample " +
                                std::to_string(sample_of_vertex[v] + 1));
        }
        sample_of_vertex[v] = static_cast<std::int64_t>(graph.sample_vertex.size());
        graph.sample_vertex.push_back(static_cast<std::uint32_t>(v));
        if (graph.sample_vertex.size() == count) stage = Stage::Rows;
        break;
      }
      case Stage::Rows: {
        std::uint64_t id1 = 0, id2 = 0;
        double values[4];
        if (tokens.size() != 6 || !parse_u64(tokens[0], id1) || !parse_u64(tokens[1], id2) ||
            !parse_double(tokens[2], values[0]) || !parse_double(tokens[3], values[1]) ||
            !parse_double(tokens[4], values[2]) || !parse_double(tokens[5], values[3])) {
          throw_parse_error(line_number,
                            "expected 'ID1 ID2 Distance dx dy dz' (two sample ids and four finite "
                            "numbers), got '" +
                                line + "'");
        }
        if (id1 < 1 || id1 > count || id2 < 1 || id2 > count) {
          throw_parse_error(line_number, "sample id out of range 1.." + std::to_string(count));
        }
        if (id1 == id2) throw_parse_error(line_number, "edge from a sample to itself");
        if (values[0] < 0) throw_parse_error(line_number, "negative distance");
        const auto from = static_cast<std::uint32_t>(id1 - 1);
        Row row{from, static_cast<std::uint32_t>(id2 - 1), values[0], {}};
        try {
          row.direction = graph_direction_from_3d(mesh, geometry, graph.sample_vertex[from],
                                                  Vec3{values[1], values[2], values[3]});
        } catch (const InvalidInput& e) {
          throw_parse_error(line_number, std::string("bad end direction: ") + e.what());
        }
        rows.push_back(row);
        break;
      }
    }
  }
  if (in.bad()) throw FileError(ErrorCode::ReadError, "cannot read the proximity graph text");
  if (stage == Stage::Count) throw_parse_error(line_number, "no sample count (empty input)");
  if (stage == Stage::Coordinates) {
    throw_parse_error(line_number, "end of input after " +
                                       std::to_string(graph.sample_vertex.size()) + " of " +
                                       std::to_string(count) + " sample coordinates");
  }

  // CSR, rows grouped by ID1 in file order (counting sort, stable).
  const std::size_t ns = graph.sample_vertex.size();
  graph.edge_offsets.assign(ns + 1, 0);
  for (const Row& r : rows) ++graph.edge_offsets[r.from + 1];
  for (std::size_t i = 0; i < ns; ++i) graph.edge_offsets[i + 1] += graph.edge_offsets[i];
  if (rows.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw_parse_error(line_number, "more than 2^32 graph edges");
  }
  graph.edge_target.resize(rows.size());
  graph.edge_distance.resize(rows.size());
  graph.edge_direction.resize(rows.size());
  std::vector<std::uint32_t> cursor(graph.edge_offsets.begin(), graph.edge_offsets.end() - 1);
  for (const Row& r : rows) {
    const std::uint32_t k = cursor[r.from]++;
    graph.edge_target[k] = r.to;
    graph.edge_distance[k] = r.distance;
    graph.edge_direction[k] = r.direction;
    graph.longest_edge = std::max(graph.longest_edge, r.distance);
  }
  std::uint32_t min_row = 0;
  for (std::size_t i = 0; i < ns; ++i) {
    const std::uint32_t len = graph.edge_offsets[i + 1] - graph.edge_offsets[i];
    if (len > 0 && (min_row == 0 || len < min_row)) min_row = len;
  }
  graph.neighbors = min_row;
  graph.covering_radius = 0;
  graph.cover_offsets.assign(mesh.num_vertices() + 1, 0);
  return graph;
}

}  // namespace geoprox
