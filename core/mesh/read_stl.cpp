// STL reader, binary or ascii. A file is binary exactly when its size is 84 + 50 x the facet
// count in its header (bytes 80 to 83); otherwise it must be ascii and start with "solid".
// STL stores each facet's three corners as 32-bit floats: corners weld into one vertex exactly
// when they are equal as floats (bit-identical, plus +0 == -0), numbered in order of first
// use. A facet with two welded corners is refused naming the facet, not dropped.
#include <bit>
#include <cmath>
#include <unordered_map>

#include "core/mesh/mesh_reader_support.h"

namespace geoprox::mesh_reading {
namespace {

struct FloatCorner {
  float xyz[3];
};

class StlWelder {
 public:
  explicit StlWelder(const std::string& path) : path_(path) {}

  /// Adds one facet; throws for non-finite corners and corners that weld together.
  void add_facet(const FloatCorner (&corners)[3], std::size_t line, FileScan& scan) {
    const std::size_t facet = scan.faces.size();
    Triangle t{};
    for (int i = 0; i < 3; ++i) {
      const float* p = corners[i].xyz;
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
        throw_mesh_error(ErrorCode::NonFiniteCoordinate, path_, line,
                         "corner " + std::to_string(i) + " of STL facet " + std::to_string(facet) +
                             " has a non-finite coordinate " + describe_point(p[0], p[1], p[2]));
      }
      t[i] = vertex_id(p, scan);
    }
    if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) {
      const std::uint32_t repeated = t[0] == t[1] || t[0] == t[2] ? t[0] : t[1];
      const Vec3& p = scan.positions[repeated];
      throw_mesh_error(ErrorCode::DegenerateFaceIndices, path_, line,
                       "STL facet " + std::to_string(facet) +
                           " has two corners at the same point " + describe_point(p.x, p.y, p.z) +
                           " = vertex " + std::to_string(repeated) +
                           "; a triangle needs 3 distinct corners");
    }
    scan.faces.push_back(t);
    scan.face_lines.push_back(line);
  }

 private:
  struct Key {
    std::uint32_t bits[3];
    bool operator==(const Key&) const = default;
  };
  struct KeyHash {
    std::size_t operator()(const Key& k) const {
      std::uint64_t h = 0x9E3779B97F4A7C15ull;
      for (std::uint32_t b : k.bits) h = (h ^ b) * 0x100000001B3ull;
      return static_cast<std::size_t>(h ^ (h >> 29));
    }
  };

  std::uint32_t vertex_id(const float* p, FileScan& scan) {
    Key key{};
    for (int i = 0; i < 3; ++i) {
      key.bits[i] = std::bit_cast<std::uint32_t>(p[i] == 0.0f ? 0.0f : p[i]);  // -0 welds to +0
    }
    const auto [it, inserted] =
        ids_.try_emplace(key, static_cast<std::uint32_t>(scan.positions.size()));
    if (inserted) scan.positions.push_back({p[0], p[1], p[2]});
    return it->second;
  }

  const std::string& path_;
  std::unordered_map<Key, std::uint32_t, KeyHash> ids_;
};

std::uint32_t read_le32(const char* bytes) {
  std::uint32_t value = 0;
  for (int i = 3; i >= 0; --i) value = (value << 8) | static_cast<unsigned char>(bytes[i]);
  return value;
}

constexpr std::size_t kBinaryHeaderBytes = 84;  ///< 80 bytes of text, then the facet count
constexpr std::size_t kBinaryFacetBytes = 50;   ///< normal, 3 corners, 2 attribute bytes

void read_binary_stl(std::string_view text, std::size_t facets, StlWelder& welder,
                     FileScan& scan) {
  for (std::size_t f = 0; f < facets; ++f) {
    const char* record = text.data() + kBinaryHeaderBytes + kBinaryFacetBytes * f;
    FloatCorner corners[3];
    for (int c = 0; c < 3; ++c) {
      for (int i = 0; i < 3; ++i) {
        corners[c].xyz[i] = std::bit_cast<float>(read_le32(record + 12 + 12 * c + 4 * i));
      }
    }
    welder.add_facet(corners, 0, scan);
  }
}

/// A line containing "outer" (or "OUTER") starts a facet; the next three lines are its
/// corners, "vertex x y z" (any first word).
void read_ascii_stl(std::string_view text, const std::string& path, StlWelder& welder,
                    FileScan& scan) {
  LineReader lines(text);
  std::string_view line;
  while (lines.next(line)) {
    if (line.find("outer") == std::string_view::npos &&
        line.find("OUTER") == std::string_view::npos) {
      continue;
    }
    const std::size_t facet_line = lines.line();
    FloatCorner corners[3];
    for (FloatCorner& corner : corners) {
      const std::vector<std::string_view> tokens =
          lines.next(line) ? split_tokens(line) : std::vector<std::string_view>{};
      if (tokens.size() < 4) {
        throw_parse_error(path, lines.line(),
                          "STL facet " + std::to_string(scan.faces.size()) + " (from line " +
                              std::to_string(facet_line) + ") needs three 'vertex x y z' lines");
      }
      for (int i = 0; i < 3; ++i) {
        const std::string_view token = strip_plus(tokens[1 + i]);
        float value = 0;
        const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
        if (error != std::errc() || end != token.data() + token.size()) {
          throw_parse_error(path, lines.line(),
                            "STL facet " + std::to_string(scan.faces.size()) + ": '" +
                                std::string(tokens[1 + i]) + "' is not a float coordinate");
        }
        corner.xyz[i] = value;
      }
    }
    welder.add_facet(corners, facet_line, scan);
  }
}

}  // namespace

FileScan scan_stl(std::string_view text, const std::string& path) {
  FileScan scan;
  StlWelder welder(path);
  const std::size_t binary_facets =
      text.size() >= kBinaryHeaderBytes ? read_le32(text.data() + 80) : 0;
  if (text.size() >= kBinaryHeaderBytes &&
      text.size() == kBinaryHeaderBytes + kBinaryFacetBytes * binary_facets) {
    read_binary_stl(text, binary_facets, welder, scan);
  } else {
    if (!trim(text.substr(0, 512)).starts_with("solid")) {
      throw_parse_error(path, 0,
                        "neither a binary STL (" + std::to_string(text.size()) +
                            " bytes, but 84 + 50 x " + std::to_string(binary_facets) +
                            " expected from its header) nor an ascii one (no 'solid')");
    }
    read_ascii_stl(text, path, welder, scan);
  }
  return scan;
}

}  // namespace geoprox::mesh_reading
