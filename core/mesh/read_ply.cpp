// PLY reader: ascii, binary_little_endian and binary_big_endian, version 1.0. The header is
// read line by line and must be exactly well-formed; then every value of the body is read in
// header order, so that elements and properties geoprox does not use (normals, colours, edges,
// materials, lists of any kind) are stepped over exactly. Faces come from element `face` (list
// `vertex_indices` or `vertex_index`, of 3 or more corners) or element `tristrips`, unrolled by
// the rule of core/mesh/mesh_io.h.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "core/base/tuning.h"
#include "core/mesh/mesh_reader_support.h"

namespace geoprox::mesh_reading {
namespace {

enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64, Unknown };

PlyType ply_type(std::string_view name) {
  if (name == "char" || name == "int8") return PlyType::Int8;
  if (name == "uchar" || name == "uint8") return PlyType::UInt8;
  if (name == "short" || name == "int16") return PlyType::Int16;
  if (name == "ushort" || name == "uint16") return PlyType::UInt16;
  if (name == "int" || name == "int32") return PlyType::Int32;
  if (name == "uint" || name == "uint32") return PlyType::UInt32;
  if (name == "float" || name == "float32") return PlyType::Float32;
  if (name == "double" || name == "float64") return PlyType::Float64;
  return PlyType::Unknown;
}

std::size_t ply_type_size(PlyType type) {
  switch (type) {
    case PlyType::Int8:
    case PlyType::UInt8:
      return 1;
    case PlyType::Int16:
    case PlyType::UInt16:
      return 2;
    case PlyType::Int32:
    case PlyType::UInt32:
    case PlyType::Float32:
      return 4;
    case PlyType::Float64:
      return 8;
    case PlyType::Unknown:
      break;
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  bool is_list = false;
  PlyType type = PlyType::Unknown;        ///< of the value (of each item for a list)
  PlyType count_type = PlyType::Unknown;  ///< of a list's length
};
struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
  std::size_t line = 0;  ///< of its `element` header line
};

struct PlyHeader {
  std::string format;  ///< ascii, binary_little_endian or binary_big_endian
  std::vector<PlyElement> elements;
  std::size_t lines = 0;        ///< the number of header lines (end_header included)
  std::size_t body_offset = 0;  ///< of the first byte after end_header's line
};

/// The elements geoprox reads; the others are stepped over.
struct PlyLayout {
  const PlyElement* vertices = nullptr;
  const PlyElement* faces = nullptr;
  const PlyElement* strips = nullptr;
};

bool is_face_index_list(const PlyProperty& property) {
  return property.is_list && (property.name == "vertex_indices" || property.name == "vertex_index");
}

/// A list length or index written as a real must be an integer below this (doubles hold every
/// integer up to 2^53).
constexpr double kLargestIntegerValue = 1e15;

// ---- Header

/// Reads line 2, "format <ascii|binary_little_endian|binary_big_endian> 1.0".
std::string read_ply_format_line(std::string_view line, std::size_t line_number,
                                 const std::string& path) {
  const std::vector<std::string_view> tokens = split_tokens(line);
  if (tokens.size() != 3 || tokens[0] != "format" || !parse_real(tokens[2])) {
    throw_parse_error(path, line_number,
                      "the second line of a PLY file must be 'format "
                      "<ascii|binary_little_endian|binary_big_endian> <version>'");
  }
  std::string format(tokens[1]);
  if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian") {
    throw_parse_error(path, line_number, "unknown PLY format '" + format + "'");
  }
  // PLY has one version, 1.0; any other number is refused rather than guessed at.
  if (*parse_real(tokens[2]) != 1.0) {
    const std::string_view version = tokens[2].substr(0, 32);
    throw_parse_error(path, line_number,
                      "unsupported PLY version '" + std::string(version) +
                          (version.size() < tokens[2].size() ? "...'" : "'") +
                          " (only 1.0 exists)");
  }
  return format;
}

/// A `property` line: "property TYPE NAME" or "property list COUNT_TYPE TYPE NAME".
PlyProperty read_ply_property(const std::vector<std::string_view>& tokens,
                              std::size_t line_number, const std::string& path) {
  if (tokens.size() == 5 && tokens[1] == "list") {
    PlyProperty property{std::string(tokens[4]), true, ply_type(tokens[3]), ply_type(tokens[2])};
    // The list length types supported; the others are refused rather than guessed at.
    const bool known_count = tokens[2] == "uchar" || tokens[2] == "uint8" ||
                             tokens[2] == "uint16" || tokens[2] == "int";
    if (property.type == PlyType::Unknown || !known_count) {
      throw_parse_error(path, line_number,
                        "unsupported PLY list types '" + std::string(tokens[2]) + " " +
                            std::string(tokens[3]) + "' (lengths: uchar, uint8, uint16, int)");
    }
    return property;
  }
  if (tokens.size() == 3) {
    PlyProperty property{std::string(tokens[2]), false, ply_type(tokens[1]), PlyType::Unknown};
    if (property.type == PlyType::Unknown) {
      throw_parse_error(path, line_number,
                        "unknown PLY property type '" + std::string(tokens[1]) + "'");
    }
    return property;
  }
  throw_parse_error(path, line_number, "malformed PLY property line");
}

/// Reads one header line after the format line into `header`; returns whether it was
/// end_header.
bool read_ply_header_line(std::string_view line, std::size_t line_number, PlyHeader& header,
                          const std::string& path) {
  const std::vector<std::string_view> tokens = split_tokens(line);
  if (tokens.empty() || tokens[0] == "comment") return false;
  if (tokens[0] == "obj_info") {
    // Readers that take the header token by token would read these words as keywords, and
    // see another file than this one.
    for (std::string_view word : tokens) {
      if (word == "element" || word == "property" || word == "end_header") {
        throw_parse_error(path, line_number,
                          "an obj_info line containing '" + std::string(word) +
                              "' would be read as a header keyword by PLY readers that read "
                              "the header token by token");
      }
    }
    return false;
  }
  if (tokens[0] == "end_header" && tokens.size() == 1) return true;
  if (tokens[0] == "element" && tokens.size() == 3) {
    const std::optional<long long> count = parse_integer(tokens[2]);
    if (!count || *count < 0 || *count > static_cast<long long>(UINT32_MAX)) {
      throw_parse_error(path, line_number, "bad element count '" + std::string(tokens[2]) + "'");
    }
    header.elements.push_back(
        {std::string(tokens[1]), static_cast<std::size_t>(*count), {}, line_number});
    return false;
  }
  if (tokens[0] == "property" && !header.elements.empty()) {
    header.elements.back().properties.push_back(read_ply_property(tokens, line_number, path));
    return false;
  }
  throw_parse_error(path, line_number,
                    "unexpected PLY header line '" + std::string(trim(line)) + "'");
}

/// Binary data starts right after end_header's line, but readers that locate it by a byte
/// offset from the last property token read it shifted when a comment or blanks come between:
/// such files are refused, so that every reader sees the same values.
void check_binary_data_start(std::string_view previous_line, std::string_view end_line,
                             std::size_t line_number, const std::string& path) {
  const std::string_view before = previous_line.substr(0, previous_line.find_last_not_of('\r') + 1);
  const bool blank_before =
      previous_line.find_last_not_of('\r') == std::string_view::npos || is_space(before.back());
  const std::vector<std::string_view> previous_tokens = split_tokens(previous_line);
  if (blank_before || previous_tokens.empty() || previous_tokens[0] == "comment" ||
      (end_line != "end_header" && end_line != "end_header\r")) {
    throw_parse_error(path, line_number,
                      "end_header must follow a property line directly, with no comment or "
                      "blanks around it, so that every reader finds the binary data at the "
                      "same place");
  }
}

PlyHeader read_ply_header(std::string_view text, const std::string& path) {
  LineReader lines(text);
  std::string_view line;
  if (!lines.next(line) || trim(line) != "ply") throw_parse_error(path, 1, "not a PLY file");
  if (!lines.next(line)) throw_parse_error(path, 2, "the PLY header ends after 'ply'");
  PlyHeader header;
  header.format = read_ply_format_line(line, lines.line(), path);
  bool ended = false;
  std::string_view previous_line;
  while (!ended) {
    previous_line = line;
    if (!lines.next(line)) break;
    ended = read_ply_header_line(line, lines.line(), header, path);
  }
  if (!ended) throw_parse_error(path, 0, "the PLY header has no end_header line");
  for (const PlyElement& element : header.elements) {
    // Records without properties take no bytes, so their count is not bounded by the file's
    // size, and they carry nothing: refuse them.
    if (element.count > 0 && element.properties.empty()) {
      throw_parse_error(path, element.line,
                        "PLY element '" + element.name + "' announces " +
                            std::to_string(element.count) + " records but has no properties");
    }
  }
  if (header.format != "ascii") check_binary_data_start(previous_line, line, lines.line(), path);
  header.lines = lines.line();
  header.body_offset =
      std::min(static_cast<std::size_t>(line.data() + line.size() - text.data()) + 1, text.size());
  return header;
}

/// Finds the vertex, face and tristrips elements and checks that geoprox can read them.
PlyLayout find_ply_layout(const PlyHeader& header, const std::string& path) {
  PlyLayout layout;
  for (const PlyElement& element : header.elements) {
    const PlyElement** slot = element.name == "vertex"      ? &layout.vertices
                              : element.name == "face"      ? &layout.faces
                              : element.name == "tristrips" ? &layout.strips
                                                            : nullptr;
    if (!slot) continue;
    if (*slot) {
      throw_parse_error(path, element.line,
                        "a second PLY element '" + element.name + "' (a file has one of each)");
    }
    *slot = &element;
  }
  if (!layout.vertices) throw_parse_error(path, 0, "the PLY file has no vertex element");
  for (const char* axis : {"x", "y", "z"}) {
    if (std::none_of(layout.vertices->properties.begin(), layout.vertices->properties.end(),
                     [&](const PlyProperty& p) { return !p.is_list && p.name == axis; })) {
      throw_parse_error(path, 0,
                        std::string("the PLY vertex element has no '") + axis + "' property");
    }
  }
  if (layout.faces && layout.strips) {
    throw FileError(ErrorCode::UnsupportedFormat,
                    path +
                        ": the PLY file has both faces and triangle strips (elements face "
                        "and tristrips); keep one of them");
  }
  for (const PlyElement* element : {layout.faces, layout.strips}) {
    if (element && element->count > 0 &&
        std::none_of(element->properties.begin(), element->properties.end(),
                     is_face_index_list)) {
      throw_parse_error(path, 0,
                        "the PLY " + element->name + " element has no vertex_indices list");
    }
  }
  if (layout.strips) {
    // Readers that do not know tristrips step over it by one value per property, not by whole
    // lists: strips before the vertices would shift where those readers find them.
    if (layout.strips < layout.vertices) {
      throw_parse_error(path, layout.strips->line,
                        "the tristrips element must come after the vertex element");
    }
    if (std::count_if(layout.strips->properties.begin(), layout.strips->properties.end(),
                      is_face_index_list) > 1) {
      throw_parse_error(path, layout.strips->line,
                        "the PLY tristrips element has more than one vertex index list");
    }
  }
  return layout;
}

// ---- Body

/// PLY triangle strips unrolled one vertex at a time, by the rule of core/mesh/mesh_io.h.
class TriangleStrip {
 public:
  /// Starts a new strip (-1, or a new record).
  void restart() { length_ = 0; }
  /// Appends v; returns the triangle it completes unless there is none or it repeats a vertex.
  std::optional<Triangle> append(std::uint32_t v) {
    std::optional<Triangle> kept;
    if (length_ >= 2) {
      Triangle t{last_[0], last_[1], v};
      if (length_ % 2 == 1) std::swap(t[0], t[1]);  // the strip's triangle length_ - 2 is odd
      if (t[0] != t[1] && t[1] != t[2] && t[2] != t[0]) kept = t;
    }
    last_[0] = last_[1];
    last_[1] = v;
    ++length_;
    return kept;
  }

 private:
  std::size_t length_ = 0;
  std::uint32_t last_[2] = {0, 0};
};

/// The values of a PLY body, one at a time: tokens of an ascii body, or numbers decoded from a
/// binary one.
class PlyValueReader {
 public:
  enum class Result { Number, NotANumber, End };

  PlyValueReader(std::string_view body, std::size_t first_line)
      : tokens_(body, first_line), binary_(false) {}
  PlyValueReader(std::string_view body, bool big_endian)
      : tokens_({}, 0), body_(body), binary_(true), big_endian_(big_endian) {}

  /// Reads one value of `type` into `value`; `text` is its token (ascii) for messages.
  Result read(PlyType type, double& value, std::string& text) {
    if (!binary_) {
      const std::string_view token = tokens_.next();
      if (token.empty()) return Result::End;
      text = token;
      const std::optional<double> number = parse_real(token);
      if (!number) return Result::NotANumber;
      value = *number;
      return Result::Number;
    }
    const std::size_t size = ply_type_size(type);
    if (body_.size() - pos_ < size) return Result::End;
    unsigned char bytes[8];
    std::memcpy(bytes, body_.data() + pos_, size);
    pos_ += size;
    if (big_endian_ != (std::endian::native == std::endian::big)) std::reverse(bytes, bytes + size);
    value = decode(type, bytes);
    text.clear();  // formatted only for a message (see text_of)
    return Result::Number;
  }
  /// The token of an ascii value, the number of a binary one.
  static std::string text_of(double value, const std::string& text) {
    if (!text.empty()) return text;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g", value);
    return buf;
  }
  /// Line of the last ascii token; 0 for binary data.
  std::size_t line() const { return binary_ ? 0 : tokens_.line(); }

 private:
  static double decode(PlyType type, const unsigned char* bytes) {
    auto as = [bytes]<typename T>(T) {
      T v;
      std::memcpy(&v, bytes, sizeof v);
      return static_cast<double>(v);
    };
    switch (type) {
      case PlyType::Int8:
        return as(std::int8_t{});
      case PlyType::UInt8:
        return as(std::uint8_t{});
      case PlyType::Int16:
        return as(std::int16_t{});
      case PlyType::UInt16:
        return as(std::uint16_t{});
      case PlyType::Int32:
        return as(std::int32_t{});
      case PlyType::UInt32:
        return as(std::uint32_t{});
      case PlyType::Float32:
        return as(float{});
      case PlyType::Float64:
        return as(double{});
      case PlyType::Unknown:
        break;
    }
    return 0;
  }
  Tokenizer tokens_;
  std::string_view body_;
  std::size_t pos_ = 0;
  bool binary_;
  bool big_endian_ = false;
};

/// Reads the records of every element in header order into a FileScan.
class PlyBodyReader {
 public:
  PlyBodyReader(const PlyHeader& header, const PlyLayout& layout, std::string_view text,
                const std::string& path)
      : header_(header),
        layout_(layout),
        path_(path),
        values_(header.format == "ascii"
                    ? PlyValueReader(text.substr(header.body_offset), header.lines + 1)
                    : PlyValueReader(text.substr(header.body_offset),
                                     header.format == "binary_big_endian")) {
    reserve_announced(scan_.positions, layout.vertices->count, text.size(),
                      tuning::kSmallestVertexRecordBytes);
    reserve_announced(scan_.faces, layout.faces ? layout.faces->count : 0, text.size(),
                      tuning::kSmallestFaceRecordBytes);
  }

  FileScan read() && {
    for (const PlyElement& element : header_.elements) {
      for (std::size_t i = 0; i < element.count; ++i) read_record(element, i);
    }
    return std::move(scan_);
  }

 private:
  void read_record(const PlyElement& element, std::size_t i) {
    const bool is_vertex = &element == layout_.vertices;
    double xyz[3] = {0, 0, 0};
    std::size_t record_line = 0;
    for (const PlyProperty& property : element.properties) {
      if (!property.is_list) {
        const double number = next_value(property.type, element, i);
        if (record_line == 0) record_line = values_.line();
        if (is_vertex && property.name.size() == 1 && property.name[0] >= 'x' &&
            property.name[0] <= 'z') {
          xyz[property.name[0] - 'x'] = number;
        }
        continue;
      }
      const long long count = next_integer(property.count_type, element, i, "a list length");
      if (record_line == 0) record_line = values_.line();
      if (count < 0) {
        throw_parse_error(path_, values_.line(),
                          element.name + " " + std::to_string(i) + ": negative list length " +
                              PlyValueReader::text_of(value_, value_text_));
      }
      if (is_face_index_list(property) && &element == layout_.strips) {
        read_strip_list(property, element, i, count, record_line);
      } else if (is_face_index_list(property) && &element == layout_.faces) {
        read_face_list(property, element, i, count, record_line);
      } else {
        for (long long k = 0; k < count; ++k) next_value(property.type, element, i);
      }
    }
    if (is_vertex) scan_.positions.push_back(checked_position(xyz, i, path_, record_line));
  }

  void read_face_list(const PlyProperty& property, const PlyElement& element, std::size_t i,
                      long long count, std::size_t record_line) {
    check_corner_count(static_cast<std::size_t>(count), i, path_, values_.line());
    corners_.clear();
    for (long long k = 0; k < count; ++k) {
      const long long index = next_integer(property.type, element, i, "a vertex index");
      corners_.push_back(checked_index(index, i, path_, values_.line()));
    }
    scan_.add_face(corners_, record_line);
  }

  void read_strip_list(const PlyProperty& property, const PlyElement& element, std::size_t i,
                       long long count, std::size_t record_line) {
    const std::size_t vertex_count = layout_.vertices->count;
    TriangleStrip strip;
    for (long long k = 0; k < count; ++k) {
      const long long index = next_integer(property.type, element, i, "a vertex index");
      if (index == -1) {
        strip.restart();
        continue;
      }
      // Checked here, not only in the triangles kept: an index in a dropped triangle or a
      // strip of fewer than three is as wrong.
      if (index < 0 || index >= static_cast<long long>(vertex_count)) {
        throw_mesh_error(ErrorCode::VertexOutOfRange, path_, values_.line(),
                         "tristrips " + std::to_string(i) + ": vertex index " +
                             std::to_string(index) + " is out of range (the file has " +
                             std::to_string(vertex_count) + " vertices; only -1 ends a strip)");
      }
      const std::optional<Triangle> t = strip.append(static_cast<std::uint32_t>(index));
      if (!t) continue;
      // One byte of index can add a triangle: stop at the mesh's limit before holding more
      // than a mesh may have.
      if (scan_.faces.size() == TriangleMesh::kMaxFaces) {
        throw_mesh_error(ErrorCode::TooLarge, path_, values_.line(),
                         "the triangle strips give more than 2^30 triangles, the most a mesh "
                         "may have");
      }
      scan_.faces.push_back(*t);
      scan_.face_lines.push_back(record_line);
    }
  }

  double next_value(PlyType type, const PlyElement& element, std::size_t index) {
    switch (values_.read(type, value_, value_text_)) {
      case PlyValueReader::Result::End:
        throw_parse_error(path_, values_.line(),
                          "the file ends in " + element.name + " " + std::to_string(index) +
                              " of the " + std::to_string(element.count) + " its header announces");
      case PlyValueReader::Result::NotANumber:
        throw_parse_error(path_, values_.line(),
                          element.name + " " + std::to_string(index) + ": '" + value_text_ +
                              "' is not a number");
      case PlyValueReader::Result::Number:
        break;
    }
    return value_;
  }

  long long next_integer(PlyType type, const PlyElement& element, std::size_t index,
                         const char* what) {
    const double number = next_value(type, element, index);
    if (number != std::floor(number) || std::abs(number) > kLargestIntegerValue) {
      throw_parse_error(path_, values_.line(),
                        element.name + " " + std::to_string(index) + ": '" +
                            PlyValueReader::text_of(number, value_text_) + "' is not " + what);
    }
    return static_cast<long long>(number);
  }

  const PlyHeader& header_;
  const PlyLayout& layout_;
  const std::string& path_;
  PlyValueReader values_;
  FileScan scan_;
  std::vector<std::uint32_t> corners_;  ///< of the face record being read
  double value_ = 0;         ///< the last value read
  std::string value_text_;   ///< its ascii token (empty for binary data)
};

}  // namespace

FileScan scan_ply(std::string_view text, const std::string& path) {
  const PlyHeader header = read_ply_header(text, path);
  const PlyLayout layout = find_ply_layout(header, path);
  return PlyBodyReader(header, layout, text, path).read();
}

}  // namespace geoprox::mesh_reading
