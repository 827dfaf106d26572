// What the graph-file sources share (core/graph/graph_file*.cpp): the streaming hash, the
// section table's known rows, the consistency checks that the writer runs before it creates
// anything and the reader runs on the mapping, and message formatting. Not for callers.
#pragma once

#include <algorithm>
#include <bit>
#include <cinttypes>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <span>
#include <string>
#include <system_error>

#include "core/graph/graph_file_format.h"

namespace geoprox::graph_file_detail {

// ---------------------------------------------------------------------------------------------
// Hash (graph_file_hash): four independent lanes (so the multiplies overlap), one 8-byte word
// per lane per step.

inline constexpr std::uint64_t kMulA = 0x9E3779B97F4A7C15ull;
inline constexpr std::uint64_t kMulB = 0xD6E8FEB86659FD93ull;
inline constexpr std::uint64_t kMulC = 0xBF58476D1CE4E5B9ull;
inline constexpr std::uint64_t kMulD = 0x94D049BB133111EBull;

inline std::uint64_t load64(const unsigned char* p) {
  std::uint64_t w;
  std::memcpy(&w, p, 8);
  return w;
}

inline std::uint64_t lane_step(std::uint64_t lane, std::uint64_t word) {
  return std::rotl(lane + word * kMulB, 29) * kMulA;
}

/// graph_file_hash over input given in pieces of any size.
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
// Layout

inline constexpr std::uint64_t kFixedHeaderSize = sizeof(GraphFileHeader);

constexpr std::uint64_t align_up(std::uint64_t v, std::uint64_t a) { return (v + a - 1) / a * a; }

struct SectionSpec {
  GraphFileSectionId id;
  std::uint32_t element_size;
  const char* name;
};

/// The known sections, in file order (index = id - 1).
inline constexpr SectionSpec kSections[kGraphFileSectionCount] = {
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

/// The refinement sections of version 3, in file order after kSections.
inline constexpr SectionSpec kRefinementSections[kGraphFileRefinementSectionCount] = {
    {GraphFileSectionId::RefinedFrom, 64, "refined_from"},
    {GraphFileSectionId::SourceFace, 4, "source_face"},
    {GraphFileSectionId::SourceBary, 72, "source_bary"},
};

/// Index of a refinement section id in kRefinementSections, or -1.
inline int refinement_section_index(std::uint32_t id) {
  return id > kGraphFileSectionCount && id <= kGraphFileSectionCount + kGraphFileRefinementSectionCount
             ? static_cast<int>(id - kGraphFileSectionCount) - 1
             : -1;
}

/// Index of a known section id in kSections, or -1.
inline int section_index(std::uint32_t id) {
  return id >= 1 && id <= kGraphFileSectionCount ? static_cast<int>(id) - 1 : -1;
}

// ---------------------------------------------------------------------------------------------
// Consistency checks (graph_file_checks.cpp), shared by the writer (before anything is created)
// and the reader (on the mapping). Each returns an empty string if all is well, else a
// description of the first problem.

/// Everything a graph file holds, as spans over the writer's vectors or the reader's mapping.
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
  /// The checks of single values below already ran on the file's bytes.
  bool values_checked = false;
};

std::string arrays_problem(const GraphArrays& arrays);

// Checks of single values that need no other array (ids in range, finite or finite and
// non-negative numbers), over a run of one section's scalars that starts at scalar `first`.
// The writer runs them on whole arrays (through arrays_problem); the reader on the file's bytes
// as they stream through the checksum, so that opening need not fault in the pages of the
// mapping that hold them.
std::string face_ids_problem(std::span<const std::uint32_t> ids, std::uint64_t first,
                             std::uint64_t num_vertices, std::span<const Triangle> faces);
std::string coordinates_problem(std::span<const double> coords, std::uint64_t first);
std::string edge_lengths_problem(std::span<const double> lengths, std::uint64_t first);
std::string edge_distances_problem(std::span<const double> distances, std::uint64_t first);
std::string cover_samples_problem(std::span<const std::uint32_t> samples, std::uint64_t first,
                                  std::uint64_t num_samples);
std::string cover_distances_problem(std::span<const float> distances, std::uint64_t first);

// ---------------------------------------------------------------------------------------------
// Messages

inline std::string errno_text(int error) { return std::generic_category().message(error); }

inline std::string hex64(std::uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "0x%016" PRIx64, v);
  return buf;
}

inline std::string fmt_double(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace geoprox::graph_file_detail
