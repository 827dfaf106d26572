// The byte layout of graph files (core/graph/graph_file.h), for the reader, the writer, tests and
// other readers of the format. Callers of the API do not need it.
//
// Binary layout, versions 2 and 3 (all integers and IEEE doubles/floats little-endian):
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
//   112     8     mesh fingerprint (mesh_fingerprint)
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
//                 version 3 only, after them: refined from (one GraphFileRefinement), source
//                 face (uint32 per face), source barycentrics (3 x 3 doubles per face)
//   file_size-8 8 checksum: graph_file_hash(bytes [0, file_size - 8), kGraphFileChecksumSeed)
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <type_traits>

#include "core/graph/graph_file.h"

namespace geoprox {

inline constexpr char kGraphFileMagic[8] = {'G', 'E', 'O', 'P', 'R', 'O', 'X', 'G'};
inline constexpr std::uint32_t kGraphFileEndianMarker = 0x01020304u;
inline constexpr std::size_t kGraphFileAlignment = 64;
/// A section table longer than this is refused as corrupt (unknown sections are skipped).
inline constexpr std::uint64_t kGraphFileMaxSections = 1024;

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
  // Version 3: the graph was built on a refinement of the mesh queries are given in (the
  // sections above describe the refined mesh; core/graph/refined_surface.h).
  RefinedFrom = 12,    ///< one GraphFileRefinement
  SourceFace = 13,     ///< uint32 per face: the input face it lies in
  SourceBary = 14,     ///< 3 x 3 doubles per face: its corners' barycentrics in that face
};
/// Sections every file has (ids 1 to 11), and those only version 3 has (ids 12 to 14).
inline constexpr std::uint32_t kGraphFileSectionCount = 11;
inline constexpr std::uint32_t kGraphFileRefinementSectionCount = 3;

/// The mesh a version-3 file answers for (the input of its refinement), exactly as on disk.
struct GraphFileRefinement {
  std::uint64_t input_vertices;
  std::uint64_t input_faces;
  std::uint64_t input_edges;
  std::uint64_t input_fingerprint;  ///< mesh_fingerprint of the input and its lengths
  double max_edge_length;           ///< no edge of the refined mesh is longer (mesh units)
  std::uint64_t reserved[3];        ///< zero
};
static_assert(sizeof(GraphFileRefinement) == 64);
static_assert(std::is_trivially_copyable_v<GraphFileRefinement>);

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

/// 64-bit hash used by the file (checksum and fingerprint). Not cryptographic. Definition:
/// with A = 0x9E3779B97F4A7C15, B = 0xD6E8FEB86659FD93, C = 0xBF58476D1CE4E5B9,
/// D = 0x94D049BB133111EB, lanes start at (seed + A, seed ^ B, seed - C, ~seed + D); the input,
/// zero-padded to a multiple of 32 bytes, is read as little-endian 64-bit words w, word i going
/// to lane i % 4 as lane = rotl(lane + w * B, 29) * A; then h = lane0,
/// h = (h ^ rotl(lane1, 17)) * C, h = (h ^ rotl(lane2, 31)) * D, h = (h ^ rotl(lane3, 47)) * A,
/// h ^= length_in_bytes * B, and finally h ^= h >> 30, h *= C, h ^= h >> 27, h *= D,
/// h ^= h >> 31 (all mod 2^64).
std::uint64_t graph_file_hash(const void* data, std::size_t size, std::uint64_t seed = 0);
/// Seeds: the file checksum is graph_file_hash(file, file_size - 8, kGraphFileChecksumSeed).
inline constexpr std::uint64_t kGraphFileChecksumSeed = 0x47656f50726f7843ull;  // "GeoProxC"
/// mesh_fingerprint is graph_file_hash with this seed of the counts (vertices, faces, edges as
/// three uint64), then the face vertex ids (3 x uint32 per face) and the IEEE bits of the
/// intrinsic edge lengths.
inline constexpr std::uint64_t kMeshFingerprintSeed = 0x47656f50726f784dull;  // "GeoProxM"

}  // namespace geoprox
