// Mesh loading: OpenMesh parses, geoprox checks (see core/mesh/mesh_io.h for the contract).
//
// OpenMesh 9's readers are lenient in ways that would silently change a mesh (found by probing
// them with small bad files):
//  - OBJ drops a `v` line it cannot parse (nan, inf, a typo), which shifts every later vertex id;
//    it removes repeated corners from a face ("f 1 2 3 1" becomes a triangle) and drops faces
//    left with fewer than three corners.
//  - ascii OFF and PLY turn a bad number into zeros and then read uninitialised face indices.
//  - the PLY header parser loops forever (logging "Unsupported keyword") on a token it cannot
//    parse, and the binary PLY reader reads the data one byte off, reporting success, when the
//    last header line is a comment.
//  - STL drops facets with two identical corners, and a NaN corner breaks the ordering of its
//    weld map, so the corner is welded to some unrelated vertex.
//  - every reader narrows coordinates to 32-bit floats.
// So load_mesh first scans the file itself (FileScan: strict syntax, every vertex and face record
// in file order), refusing what OpenMesh would misread, then lets OpenMesh read it into
// RawMeshRecorder, and refuses the file if the two disagree on any record (coordinates to within
// a float's last bit). The mesh is built from the scan's copy, which keeps the file's precision:
// the decimal digits of OBJ, OFF and ascii PLY, binary PLY doubles (STL holds floats).
//
// STL welding: OpenMesh's STL reader itself merges corners whose coordinates compare equal,
// creating each vertex at its first use, so ids follow file order. Its tolerance is set to 0
// here (the default FLT_MIN would also merge distinct subnormal coordinates), so corners weld
// exactly when they are equal as floats: bit-identical, plus +0 == -0.
//
// A zero-byte file of any format is an EmptyMesh (MeshError), like a file with no faces.
#include "core/mesh/mesh_io.h"

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/IO/reader/STLReader.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <algorithm>
#include <bit>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <mutex>
#include <optional>
#include <sstream>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "core/base/errors.h"

namespace geoprox {
namespace {

enum class Format { Obj, Off, Ply, Stl };

const char* format_name(Format format) {
  switch (format) {
    case Format::Obj:
      return "OBJ";
    case Format::Off:
      return "OFF";
    case Format::Ply:
      return "PLY";
    case Format::Stl:
      return "STL";
  }
  return "?";
}

// ------------------------------------------------------------------------------------------------
// Error helpers. Every message starts with the path (and line, when known) so that a user with
// several meshes knows which file to fix.

std::string where(const std::string& path, std::size_t line) {
  return line == 0 ? path + ": " : path + ":" + std::to_string(line) + ": ";
}

[[noreturn]] void throw_parse_error(const std::string& path, std::size_t line,
                                    const std::string& what) {
  throw FileError(ErrorCode::ParseError, where(path, line) + what);
}

[[noreturn]] void throw_mesh_error(ErrorCode code, const std::string& path,
                                   std::size_t line, const std::string& what) {
  throw MeshError(code, where(path, line) + what);
}

std::string describe_point(double x, double y, double z) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.9g, %.9g, %.9g)", x, y, z);
  return buf;
}

std::string describe_face(std::size_t f, const Triangle& t) {
  return "face " + std::to_string(f) + " (vertices " + std::to_string(t[0]) + " " +
         std::to_string(t[1]) + " " + std::to_string(t[2]) + ")";
}

[[noreturn]] void throw_non_triangle(const std::string& path, std::size_t line, std::size_t face,
                                     std::size_t corners) {
  throw_mesh_error(ErrorCode::NonTriangleFace, path, line,
                   "face " + std::to_string(face) + " has " + std::to_string(corners) +
                       " corners; only triangles are supported (triangulate the mesh first)");
}

// ------------------------------------------------------------------------------------------------
// Strict number syntax: the whole token must be a number (a leading '+' is allowed).

std::string_view strip_plus(std::string_view token) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
  return token;
}

/// Accepts nan and inf (from_chars does), so that the caller can name the non-finite vertex.
std::optional<double> parse_real(std::string_view token) {
  token = strip_plus(token);
  double value = 0;
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (error != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

std::optional<long long> parse_integer(std::string_view token) {
  token = strip_plus(token);
  long long value = 0;
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (error != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split_tokens(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

/// Lines of a text, numbered from 1.
class LineReader {
 public:
  explicit LineReader(std::string_view text, std::size_t first_line = 1)
      : text_(text), next_line_(first_line) {}
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    const std::size_t end = std::min(text_.find('\n', pos_), text_.size());
    line = text_.substr(pos_, end - pos_);
    pos_ = end + 1;
    line_ = next_line_++;
    return true;
  }
  std::size_t line() const { return line_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t line_ = 0;
  std::size_t next_line_;
};

/// Whitespace-separated tokens with their line numbers: the reading model of `stream >> value`
/// that OpenMesh's OFF and ascii PLY readers use.
class Tokenizer {
 public:
  Tokenizer(std::string_view text, std::size_t first_line)
      : text_(text), cursor_line_(first_line) {}

  /// The next token, or an empty view at the end of the text; line() is then its line.
  std::string_view next() {
    skip_space();
    const std::size_t start = pos_;
    while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
    token_line_ = cursor_line_;
    return text_.substr(start, pos_ - start);
  }
  std::size_t line() const { return token_line_; }
  /// Whether another token follows on the line of the last token.
  bool more_on_this_line() const {
    std::size_t i = pos_;
    while (i < text_.size() && is_space(text_[i]) && text_[i] != '\n') ++i;
    return i < text_.size() && text_[i] != '\n';
  }
  /// Drops the rest of the line of the last token (what std::getline does after `>>`) and
  /// returns it.
  std::string_view skip_rest_of_line() {
    const std::size_t start = pos_;
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
    return text_.substr(start, pos_ - start);
  }

 private:
  void skip_space() {
    while (pos_ < text_.size() && is_space(text_[pos_])) {
      if (text_[pos_] == '\n') ++cursor_line_;
      ++pos_;
    }
  }

  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t cursor_line_;
  std::size_t token_line_ = 0;
};

// ------------------------------------------------------------------------------------------------
// FileScan: what the file holds according to geoprox's own strict reading.

struct FileScan {
  std::size_t vertex_count = 0;
  std::size_t face_count = 0;
  std::vector<Vec3> positions;  ///< as exact as the file: its digits, doubles, or STL's floats
  std::vector<Triangle> faces;
  std::vector<std::size_t> face_lines;  ///< line of each face record (0 if binary)
  /// The faces were unrolled from PLY triangle strips, which OpenMesh does not read: it is
  /// checked on the vertices only.
  bool faces_from_strips = false;
};

/// Refuses non-finite values (NonFiniteCoordinate, as TriangleMesh would, but naming the line)
/// and values OpenMesh cannot hold as float (ParseError).
Vec3 checked_position(const double (&values)[3], std::size_t vertex, const std::string& path,
                      std::size_t line) {
  for (double v : values) {
    if (!std::isfinite(v)) {
      throw_mesh_error(ErrorCode::NonFiniteCoordinate, path, line,
                       "vertex " + std::to_string(vertex) + " has a non-finite coordinate " +
                           describe_point(values[0], values[1], values[2]));
    }
  }
  for (double v : values) {
    if (std::abs(v) > FLT_MAX) {
      throw_parse_error(path, line,
                        "vertex " + std::to_string(vertex) +
                            " has a coordinate beyond the 32-bit float range that OpenMesh's "
                            "readers hold " +
                            describe_point(values[0], values[1], values[2]));
    }
  }
  return {values[0], values[1], values[2]};
}

/// Parses three coordinate tokens of vertex `vertex` (ParseError for a non-number).
Vec3 parse_coordinates(std::string_view x, std::string_view y, std::string_view z,
                       std::size_t vertex, const std::string& path, std::size_t line) {
  double values[3];
  const std::string_view tokens[3] = {x, y, z};
  for (int i = 0; i < 3; ++i) {
    const std::optional<double> value = parse_real(tokens[i]);
    if (!value) {
      throw_parse_error(path, line,
                        "vertex " + std::to_string(vertex) + ": '" + std::string(tokens[i]) +
                            "' is not a number");
    }
    values[i] = *value;
  }
  return checked_position(values, vertex, path, line);
}

/// Checks indices against the vertex count and repeated corners, in face order, as
/// TriangleMesh does, but naming the line (and reached before OpenMesh could drop the face).
void check_scanned_faces(const FileScan& scan, const std::string& path) {
  for (std::size_t f = 0; f < scan.faces.size(); ++f) {
    const Triangle& t = scan.faces[f];
    const std::size_t line = scan.face_lines.empty() ? 0 : scan.face_lines[f];
    for (std::uint32_t v : t) {
      if (v >= scan.vertex_count) {
        throw_mesh_error(ErrorCode::VertexOutOfRange, path, line,
                         describe_face(f, t) + " refers to vertex " + std::to_string(v) +
                             " but the file has " + std::to_string(scan.vertex_count) +
                             " vertices");
      }
    }
    if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) {
      throw_mesh_error(ErrorCode::DegenerateFaceIndices, path, line,
                       describe_face(f, t) + " repeats a vertex; a triangle needs 3 distinct ones");
    }
  }
}

/// A non-negative vertex index that fits a Triangle; otherwise VertexOutOfRange.
std::uint32_t checked_index(long long index, std::size_t face, const std::string& path,
                            std::size_t line) {
  if (index < 0 || index >= static_cast<long long>(UINT32_MAX)) {
    throw_mesh_error(ErrorCode::VertexOutOfRange, path, line,
                     "face " + std::to_string(face) + " refers to vertex " + std::to_string(index) +
                         ", which cannot exist");
  }
  return static_cast<std::uint32_t>(index);
}

// --- OBJ: line based, like OpenMesh's reader. Only `v` and `f` lines matter for geometry.
FileScan scan_obj(std::string_view text, const std::string& path) {
  FileScan scan;
  LineReader lines(text);
  std::string_view line;
  while (lines.next(line)) {
    std::vector<std::string_view> tokens = split_tokens(line);
    // A token starting with '#' comments out the rest of the line.
    const auto comment = std::find_if(tokens.begin(), tokens.end(),
                                      [](std::string_view t) { return t.front() == '#'; });
    tokens.erase(comment, tokens.end());
    if (tokens.empty()) continue;
    if (tokens[0] == "v") {
      if (tokens.size() < 4) {
        throw_parse_error(
            path, lines.line(),
            "vertex " + std::to_string(scan.positions.size()) + " needs three coordinates");
      }
      scan.positions.push_back(parse_coordinates(tokens[1], tokens[2], tokens[3],
                                                 scan.positions.size(), path, lines.line()));
    } else if (tokens[0] == "f") {
      const std::size_t face = scan.faces.size();
      std::vector<std::uint32_t> corners;
      for (std::size_t i = 1; i < tokens.size(); ++i) {
        // v, v/vt, v//vn or v/vt/vn: only the position index matters.
        const std::string_view position = tokens[i].substr(0, tokens[i].find('/'));
        const std::optional<long long> index = parse_integer(position);
        if (!index) {
          throw_parse_error(path, lines.line(),
                            "face " + std::to_string(face) + ": '" + std::string(tokens[i]) +
                                "' is not a vertex index");
        }
        if (*index == 0) {
          throw_mesh_error(
              ErrorCode::VertexOutOfRange, path, lines.line(),
              "face " + std::to_string(face) + " uses vertex index 0; OBJ indices start at 1");
        }
        // Negative indices count back from the last vertex read so far.
        const long long resolved =
            *index > 0 ? *index - 1 : static_cast<long long>(scan.positions.size()) + *index;
        corners.push_back(checked_index(resolved, face, path, lines.line()));
      }
      if (corners.size() != 3) throw_non_triangle(path, lines.line(), face, corners.size());
      scan.faces.push_back({corners[0], corners[1], corners[2]});
      scan.face_lines.push_back(lines.line());
    }
  }
  scan.vertex_count = scan.positions.size();
  scan.face_count = scan.faces.size();
  return scan;
}

/// OpenMesh's OFF reader classifies the colour of a C[OFF] record by the number of
/// space-separated items after the coordinates (minus 2 texture coordinates) and prints to
/// std::cerr, which geoprox cannot capture, unless there are 0 to 4. Refuse those records.
void check_off_colour(std::string_view extras, bool has_texcoords, const char* record,
                      std::size_t index, const std::string& path, std::size_t line) {
  extras = trim(extras);
  long items =
      extras.empty() ? 0 : 1 + static_cast<long>(std::count(extras.begin(), extras.end(), ' '));
  if (has_texcoords) items -= 2;
  if (items < 0 || items > 4) {
    throw_parse_error(path, line,
                      std::string(record) + " " + std::to_string(index) + " has " +
                          std::to_string(items) + " colour values (an OFF colour has 0 to 4)");
  }
}

// --- OFF (ascii). OpenMesh reads the first line as the header, then the counts and each
// vertex's three coordinates with `>>` and drops the rest of the vertex line; face records are
// read with `>>` only (the rest of the line is dropped only with a C[olour] header).
FileScan scan_off(std::string_view text, const std::string& path) {
  FileScan scan;
  const std::size_t header_end = std::min(text.find('\n'), text.size());
  const std::string_view header = trim(text.substr(0, header_end));
  std::string_view magic = header.substr(0, header.find_first_of(" \t"));
  const bool has_normals = magic.find('N') != std::string_view::npos;
  const bool has_colours = magic.find('C') != std::string_view::npos;
  const bool has_texcoords = magic.starts_with("ST");
  if (magic.size() < 3 || magic.substr(magic.size() - 3) != "OFF" ||
      magic.find_first_not_of("STCN4nOF") != std::string_view::npos) {
    throw_parse_error(path, 1,
                      "the first line must be an OFF header ([ST][C][N]OFF), not '" +
                          std::string(header.substr(0, 40)) + "'");
  }
  if (magic.find_first_of("4n") != std::string_view::npos) {
    throw_parse_error(path, 1,
                      "only 3D OFF files are supported (header '" + std::string(magic) + "')");
  }
  const std::string_view rest = trim(header.substr(magic.size()));
  if (rest.starts_with("BINARY")) {
    throw FileError(ErrorCode::UnsupportedFormat,
                    path + ": binary OFF is not supported; use ascii OFF or binary PLY");
  }
  if (!rest.empty()) {
    throw_parse_error(path, 1,
                      "OpenMesh's OFF reader expects the header alone on its line, "
                      "with the counts on the next line");
  }

  const std::string_view body = header_end < text.size() ? text.substr(header_end + 1) : "";
  {
    // OpenMesh's OFF reader has no comments: a '#' line would be read as numbers.
    LineReader lines(body, 2);
    std::string_view line;
    while (lines.next(line)) {
      if (trim(line).starts_with('#')) {
        throw_parse_error(path, lines.line(),
                          "comment lines are not supported in OFF files (OpenMesh's reader)");
      }
    }
  }
  Tokenizer tokens(body, 2);
  auto expect_count = [&](const char* what) {
    const std::string_view token = tokens.next();
    const std::optional<long long> value = parse_integer(token);
    if (!value || *value < 0) {
      throw_parse_error(
          path, tokens.line(),
          std::string("expected the number of ") + what + ", found '" + std::string(token) + "'");
    }
    return static_cast<std::size_t>(*value);
  };
  const std::size_t vertex_count = expect_count("vertices");
  const std::size_t counts_line = tokens.line();
  const std::size_t face_count = expect_count("faces");
  expect_count("edges");
  if (tokens.line() != counts_line) {
    // OpenMesh would take the first coordinate as the third count.
    throw_parse_error(path, counts_line,
                      "the counts line needs three numbers: vertices, faces, "
                      "edges");
  }
  // Do not trust the header's counts with memory before the records are there.
  scan.positions.reserve(std::min(vertex_count, text.size() / 6));
  scan.faces.reserve(std::min(face_count, text.size() / 8));

  for (std::size_t v = 0; v < vertex_count; ++v) {
    std::string_view xyz[3];
    for (std::string_view& token : xyz) {
      token = tokens.next();
      if (token.empty()) {
        throw_parse_error(path, tokens.line(),
                          "the file ends in vertex " + std::to_string(v) + " of the " +
                              std::to_string(vertex_count) + " its header announces");
      }
    }
    scan.positions.push_back(parse_coordinates(xyz[0], xyz[1], xyz[2], v, path, tokens.line()));
    if (has_normals) {
      for (int i = 0; i < 3; ++i) tokens.next();
    }
    const std::string_view extras = tokens.skip_rest_of_line();
    if (has_colours) check_off_colour(extras, has_texcoords, "vertex", v, path, tokens.line());
  }
  for (std::size_t f = 0; f < face_count; ++f) {
    const std::string_view count_token = tokens.next();
    if (count_token.empty()) {
      throw_parse_error(path, tokens.line(),
                        "the file ends before face " + std::to_string(f) + " of the " +
                            std::to_string(face_count) + " its header announces");
    }
    const std::size_t line = tokens.line();
    const std::optional<long long> corners = parse_integer(count_token);
    if (!corners || *corners < 0) {
      throw_parse_error(path, line,
                        "face " + std::to_string(f) +
                            ": expected its corner count, "
                            "found '" +
                            std::string(count_token) + "'");
    }
    if (*corners != 3) throw_non_triangle(path, line, f, static_cast<std::size_t>(*corners));
    Triangle t{};
    for (std::uint32_t& corner : t) {
      const std::string_view token = tokens.next();
      const std::optional<long long> index = parse_integer(token);
      if (!index) {
        throw_parse_error(
            path, tokens.line(),
            "face " + std::to_string(f) + ": '" + std::string(token) + "' is not a vertex index");
      }
      corner = checked_index(*index, f, path, tokens.line());
    }
    if (has_colours) {
      check_off_colour(tokens.skip_rest_of_line(), false, "face", f, path, tokens.line());
    } else if (tokens.more_on_this_line()) {
      throw_parse_error(path, tokens.line(),
                        "face " + std::to_string(f) +
                            " has values after its 3 corners; "
                            "face colours need a COFF header");
    }
    scan.faces.push_back(t);
    scan.face_lines.push_back(line);
  }
  scan.vertex_count = scan.positions.size();
  scan.face_count = scan.faces.size();
  return scan;
}

// --- PLY: the header, then every value of the body, ascii or binary (OpenMesh's binary reader
// finds the data by byte offsets from `end_header`, so a misplaced header shifts everything).
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

bool is_face_index_list(const PlyProperty& property) {
  return property.is_list && (property.name == "vertex_indices" || property.name == "vertex_index");
}

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

FileScan scan_ply(std::string_view text, const std::string& path) {
  // OpenMesh reads the header token by token and only stops on a hard I/O error: a token that
  // fails to parse (a version or count that is not a number, a missing end_header) makes it
  // log "Unsupported keyword" forever. So every header line must be exactly well-formed here.
  LineReader lines(text);
  std::string_view line;
  std::vector<PlyElement> elements;
  std::string format;
  bool ended = false;
  std::string_view previous_line;
  if (!lines.next(line) || trim(line) != "ply") throw_parse_error(path, 1, "not a PLY file");
  if (!lines.next(line)) throw_parse_error(path, 2, "the PLY header ends after 'ply'");
  {
    const std::vector<std::string_view> tokens = split_tokens(line);
    if (tokens.size() != 3 || tokens[0] != "format" || !parse_real(tokens[2])) {
      throw_parse_error(path, lines.line(),
                        "the second line of a PLY file must be 'format "
                        "<ascii|binary_little_endian|binary_big_endian> <version>'");
    }
    format = tokens[1];
    if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian") {
      throw_parse_error(path, lines.line(), "unknown PLY format '" + format + "'");
    }
    // PLY has one version, 1.0. OpenMesh's reader builds a string as long as the number it
    // reads there: a version of 1e121 made it ask for 2 GiB (a fuzz finding).
    if (*parse_real(tokens[2]) != 1.0) {
      const std::string_view version = tokens[2].substr(0, 32);
      throw_parse_error(path, lines.line(),
                        "unsupported PLY version '" + std::string(version) +
                            (version.size() < tokens[2].size() ? "...'" : "'") +
                            " (only 1.0 exists)");
    }
  }
  while (!ended) {
    previous_line = line;
    if (!lines.next(line)) break;
    const std::vector<std::string_view> tokens = split_tokens(line);
    if (tokens.empty() || tokens[0] == "comment") continue;
    if (tokens[0] == "obj_info") {
      // OpenMesh reads the words of an obj_info line as keywords.
      for (std::string_view word : tokens) {
        if (word == "element" || word == "property" || word == "end_header") {
          throw_parse_error(path, lines.line(),
                            "an obj_info line containing '" + std::string(word) +
                                "' would confuse OpenMesh's PLY reader");
        }
      }
    } else if (tokens[0] == "end_header" && tokens.size() == 1) {
      ended = true;
    } else if (tokens[0] == "element" && tokens.size() == 3) {
      const std::optional<long long> count = parse_integer(tokens[2]);
      if (!count || *count < 0 || *count > static_cast<long long>(UINT32_MAX)) {
        throw_parse_error(path, lines.line(), "bad element count '" + std::string(tokens[2]) + "'");
      }
      elements.push_back(
          {std::string(tokens[1]), static_cast<std::size_t>(*count), {}, lines.line()});
    } else if (tokens[0] == "property" && !elements.empty()) {
      PlyProperty property;
      if (tokens.size() == 5 && tokens[1] == "list") {
        property = {std::string(tokens[4]), true, ply_type(tokens[3]), ply_type(tokens[2])};
        // The length types OpenMesh's reader accepts.
        const bool known_count = tokens[2] == "uchar" || tokens[2] == "uint8" ||
                                 tokens[2] == "uint16" || tokens[2] == "int";
        if (property.type == PlyType::Unknown || !known_count) {
          throw_parse_error(path, lines.line(),
                            "unsupported PLY list types '" + std::string(tokens[2]) + " " +
                                std::string(tokens[3]) + "' (lengths: uchar, uint8, uint16, int)");
        }
      } else if (tokens.size() == 3) {
        property = {std::string(tokens[2]), false, ply_type(tokens[1]), PlyType::Unknown};
        if (property.type == PlyType::Unknown) {
          throw_parse_error(path, lines.line(),
                            "unknown PLY property type '" + std::string(tokens[1]) + "'");
        }
      } else {
        throw_parse_error(path, lines.line(), "malformed PLY property line");
      }
      elements.back().properties.push_back(property);
    } else {
      throw_parse_error(path, lines.line(),
                        "unexpected PLY header line '" + std::string(trim(line)) + "'");
    }
  }
  if (!ended) throw_parse_error(path, 0, "the PLY header has no end_header line");
  for (const PlyElement& element : elements) {
    // Records without properties take no bytes, so the count is not bounded by the file: a
    // 200-byte file announcing 4e9 of them kept the scan below looping for minutes (a timeout
    // of tests/fuzz/mesh_io_fuzzer). Such records carry nothing: refuse them.
    if (element.count > 0 && element.properties.empty()) {
      throw_parse_error(path, element.line,
                        "PLY element '" + element.name + "' announces " +
                            std::to_string(element.count) + " records but has no properties");
    }
  }
  if (format != "ascii") {
    // OpenMesh's binary reader locates the data 12 bytes (14 with CRLF) after the end of the
    // last token before end_header: a comment line or trailing blanks there shift every value.
    const std::string_view before =
        previous_line.substr(0, previous_line.find_last_not_of('\r') + 1);
    const bool blank_before =
        previous_line.find_last_not_of('\r') == std::string_view::npos || is_space(before.back());
    const std::vector<std::string_view> previous_tokens = split_tokens(previous_line);
    if (blank_before || previous_tokens.empty() || previous_tokens[0] == "comment" ||
        (line != "end_header" && line != "end_header\r")) {
      throw_parse_error(path, lines.line(),
                        "OpenMesh cannot find the binary data of this PLY file: end_header must "
                        "follow a property line directly, with no comment or blanks around it");
    }
  }
  const std::size_t header_lines = lines.line();
  const std::size_t body_offset =
      std::min(static_cast<std::size_t>(line.data() + line.size() - text.data()) + 1, text.size());

  const PlyElement* vertex_element = nullptr;
  const PlyElement* face_element = nullptr;
  const PlyElement* strip_element = nullptr;
  for (const PlyElement& element : elements) {
    const PlyElement** slot = element.name == "vertex"      ? &vertex_element
                              : element.name == "face"      ? &face_element
                              : element.name == "tristrips" ? &strip_element
                                                            : nullptr;
    if (!slot) continue;
    if (*slot) {
      throw_parse_error(path, element.line,
                        "a second PLY element '" + element.name + "' (a file has one of each)");
    }
    *slot = &element;
  }
  if (!vertex_element) throw_parse_error(path, 0, "the PLY file has no vertex element");
  for (const char* axis : {"x", "y", "z"}) {
    if (std::none_of(vertex_element->properties.begin(), vertex_element->properties.end(),
                     [&](const PlyProperty& p) { return !p.is_list && p.name == axis; })) {
      throw_parse_error(path, 0,
                        std::string("the PLY vertex element has no '") + axis + "' property");
    }
  }
  if (face_element && strip_element) {
    throw FileError(ErrorCode::UnsupportedFormat,
                    path + ": the PLY file has both faces and triangle strips (elements face "
                           "and tristrips); keep one of them");
  }
  for (const PlyElement* element : {face_element, strip_element}) {
    if (element && element->count > 0 &&
        std::none_of(element->properties.begin(), element->properties.end(),
                     is_face_index_list)) {
      throw_parse_error(path, 0,
                        "the PLY " + element->name + " element has no vertex_indices list");
    }
  }
  if (strip_element) {
    // OpenMesh skips an element it does not know by one value per property, not by whole
    // lists: strips before the vertices would shift where it reads them.
    if (strip_element < vertex_element) {
      throw_parse_error(path, strip_element->line,
                        "the tristrips element must come after the vertex element");
    }
    if (std::count_if(strip_element->properties.begin(), strip_element->properties.end(),
                      is_face_index_list) > 1) {
      throw_parse_error(path, strip_element->line,
                        "the PLY tristrips element has more than one vertex index list");
    }
  }

  FileScan scan;
  const std::string_view body = text.substr(body_offset);
  PlyValueReader values = format == "ascii" ? PlyValueReader(body, header_lines + 1)
                                            : PlyValueReader(body, format == "binary_big_endian");
  double value = 0;
  std::string value_text;
  auto next_value = [&](PlyType type, const PlyElement& element, std::size_t index) {
    switch (values.read(type, value, value_text)) {
      case PlyValueReader::Result::End:
        throw_parse_error(path, values.line(),
                          "the file ends in " + element.name + " " + std::to_string(index) +
                              " of the " + std::to_string(element.count) + " its header announces");
      case PlyValueReader::Result::NotANumber:
        throw_parse_error(
            path, values.line(),
            element.name + " " + std::to_string(index) + ": '" + value_text + "' is not a number");
      case PlyValueReader::Result::Number:
        break;
    }
    return value;
  };
  auto next_integer = [&](PlyType type, const PlyElement& element, std::size_t index,
                          const char* what) {
    const double number = next_value(type, element, index);
    if (number != std::floor(number) || std::abs(number) > 1e15) {
      throw_parse_error(path, values.line(),
                        element.name + " " + std::to_string(index) + ": '" +
                            PlyValueReader::text_of(number, value_text) + "' is not " + what);
    }
    return static_cast<long long>(number);
  };
  // Do not trust the header's counts with memory before the records are there.
  scan.positions.reserve(std::min(vertex_element->count, text.size() / 6));
  scan.faces.reserve(std::min(face_element ? face_element->count : 0, text.size() / 8));
  scan.faces_from_strips = strip_element != nullptr;
  for (const PlyElement& element : elements) {
    const bool is_vertex = &element == vertex_element;
    const bool is_face = &element == face_element;
    const bool is_strip = &element == strip_element;
    for (std::size_t i = 0; i < element.count; ++i) {
      double xyz[3] = {0, 0, 0};
      std::size_t record_line = 0;
      for (const PlyProperty& property : element.properties) {
        if (!property.is_list) {
          const double number = next_value(property.type, element, i);
          if (record_line == 0) record_line = values.line();
          if (is_vertex && property.name.size() == 1 && property.name[0] >= 'x' &&
              property.name[0] <= 'z') {
            xyz[property.name[0] - 'x'] = number;
          }
          continue;
        }
        const long long count = next_integer(property.count_type, element, i, "a list length");
        if (record_line == 0) record_line = values.line();
        if (count < 0) {
          throw_parse_error(path, values.line(),
                            element.name + " " + std::to_string(i) + ": negative list length " +
                                PlyValueReader::text_of(value, value_text));
        }
        if (is_strip && is_face_index_list(property)) {
          TriangleStrip strip;
          for (long long k = 0; k < count; ++k) {
            const long long index = next_integer(property.type, element, i, "a vertex index");
            if (index == -1) {
              strip.restart();
              continue;
            }
            // Checked here, not only in the triangles kept: an index in a dropped triangle or
            // a strip of fewer than three is as wrong.
            if (index < 0 || index >= static_cast<long long>(vertex_element->count)) {
              throw_mesh_error(ErrorCode::VertexOutOfRange, path, values.line(),
                               "tristrips " + std::to_string(i) + ": vertex index " +
                                   std::to_string(index) + " is out of range (the file has " +
                                   std::to_string(vertex_element->count) +
                                   " vertices; only -1 ends a strip)");
            }
            const std::optional<Triangle> t = strip.append(static_cast<std::uint32_t>(index));
            if (!t) continue;
            // One byte of index can add a triangle: stop at the mesh's limit before holding
            // more than a mesh may have.
            if (scan.faces.size() == TriangleMesh::kMaxFaces) {
              throw_mesh_error(ErrorCode::TooLarge, path, values.line(),
                               "the triangle strips give more than 2^30 triangles, the most a "
                               "mesh may have");
            }
            scan.faces.push_back(*t);
            scan.face_lines.push_back(record_line);
          }
          continue;
        }
        const bool corners = is_face && is_face_index_list(property);
        if (corners && count != 3) {
          throw_non_triangle(path, values.line(), i, static_cast<std::size_t>(count));
        }
        Triangle t{};
        for (long long k = 0; k < count; ++k) {
          if (!corners) {
            next_value(property.type, element, i);
            continue;
          }
          const long long index = next_integer(property.type, element, i, "a vertex index");
          t[static_cast<std::size_t>(k)] = checked_index(index, i, path, values.line());
        }
        if (corners) {
          scan.faces.push_back(t);
          scan.face_lines.push_back(record_line);
        }
      }
      if (is_vertex) scan.positions.push_back(checked_position(xyz, i, path, record_line));
    }
  }
  scan.vertex_count = scan.positions.size();
  scan.face_count = scan.faces.size();
  return scan;
}

// --- STL. Binary exactly when the size is 84 + 50 * (triangle count in the header), which is
// OpenMesh's own test. Corners are welded here as OpenMesh does (equal as floats) so that a
// degenerate facet, which OpenMesh would drop silently, is refused naming the facet.
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
      // +0 and -0 compare equal, so they weld (as in OpenMesh's comparator).
      key.bits[i] = std::bit_cast<std::uint32_t>(p[i] == 0.0f ? 0.0f : p[i]);
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

FileScan scan_stl(std::string_view text, const std::string& path) {
  FileScan scan;
  StlWelder welder(path);
  const std::size_t binary_facets = text.size() >= 84 ? read_le32(text.data() + 80) : 0;
  if (text.size() >= 84 && text.size() == 84 + 50 * binary_facets) {
    for (std::size_t f = 0; f < binary_facets; ++f) {
      const char* record = text.data() + 84 + 50 * f;
      FloatCorner corners[3];
      for (int c = 0; c < 3; ++c) {
        for (int i = 0; i < 3; ++i) {
          corners[c].xyz[i] = std::bit_cast<float>(read_le32(record + 12 + 12 * c + 4 * i));
        }
      }
      welder.add_facet(corners, 0, scan);
    }
  } else {
    if (!trim(text.substr(0, 512)).starts_with("solid")) {
      throw_parse_error(path, 0,
                        "neither a binary STL (" + std::to_string(text.size()) +
                            " bytes, but 84 + 50 x " + std::to_string(binary_facets) +
                            " expected from its header) nor an ascii one (no 'solid')");
    }
    // OpenMesh: a line containing "outer" starts a facet; the next three lines are its corners.
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
          const auto [end, error] =
              std::from_chars(token.data(), token.data() + token.size(), value);
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
  scan.vertex_count = scan.positions.size();
  scan.face_count = scan.faces.size();
  return scan;
}

FileScan scan_file(Format format, std::string_view text, const std::string& path) {
  FileScan scan;
  switch (format) {
    case Format::Obj:
      scan = scan_obj(text, path);
      break;
    case Format::Off:
      scan = scan_off(text, path);
      break;
    case Format::Ply:
      scan = scan_ply(text, path);
      break;
    case Format::Stl:
      scan = scan_stl(text, path);
      break;
  }
  check_scanned_faces(scan, path);
  return scan;
}

// ------------------------------------------------------------------------------------------------
// RawMeshRecorder: an OpenMesh importer that keeps exactly what the reader hands over, in call
// order, with no connectivity (OpenMesh's own mesh would drop complex faces).

class RawMeshRecorder final : public OpenMesh::IO::BaseImporter {
 public:
  std::vector<Vec3> positions;
  std::vector<int> corners;                 ///< vertex ids of all faces, concatenated
  std::vector<std::size_t> face_starts{0};  ///< face f has corners[face_starts[f], [f + 1])
  bool used_halfedge_calls = false;         ///< only the OM format builds halfedges directly

  std::size_t face_count() const { return face_starts.size() - 1; }

  OpenMesh::VertexHandle add_vertex(const OpenMesh::Vec3f& p) override {
    return add_position({p[0], p[1], p[2]});
  }
  OpenMesh::VertexHandle add_vertex(const OpenMesh::Vec3d& p) override {
    return add_position({p[0], p[1], p[2]});
  }
  OpenMesh::VertexHandle add_vertex() override { return add_position({}); }
  void set_point(OpenMesh::VertexHandle vh, const OpenMesh::Vec3f& p) override {
    if (vh.is_valid() && static_cast<std::size_t>(vh.idx()) < positions.size()) {
      positions[static_cast<std::size_t>(vh.idx())] = {p[0], p[1], p[2]};
    }
  }
  OpenMesh::FaceHandle add_face(const VHandles& vertices) override {
    for (const OpenMesh::VertexHandle& v : vertices) corners.push_back(v.idx());
    face_starts.push_back(corners.size());
    return OpenMesh::FaceHandle(static_cast<int>(face_count() - 1));
  }
  OpenMesh::HalfedgeHandle add_edge(OpenMesh::VertexHandle, OpenMesh::VertexHandle) override {
    used_halfedge_calls = true;
    return OpenMesh::HalfedgeHandle();
  }
  OpenMesh::FaceHandle add_face(OpenMesh::HalfedgeHandle) override {
    used_halfedge_calls = true;
    return OpenMesh::FaceHandle();
  }
  std::size_t n_vertices() const override { return positions.size(); }
  std::size_t n_faces() const override { return face_count(); }
  std::size_t n_edges() const override { return 0; }

  // Attributes geoprox does not use.
  void add_face_texcoords(OpenMesh::FaceHandle, OpenMesh::VertexHandle,
                          const std::vector<OpenMesh::Vec2f>&) override {}
  void add_face_texcoords(OpenMesh::FaceHandle, OpenMesh::VertexHandle,
                          const std::vector<OpenMesh::Vec3f>&) override {}
  void set_face_texindex(OpenMesh::FaceHandle, int) override {}
  void set_halfedge(OpenMesh::VertexHandle, OpenMesh::HalfedgeHandle) override {}
  void set_normal(OpenMesh::VertexHandle, const OpenMesh::Vec3f&) override {}
  void set_normal(OpenMesh::VertexHandle, const OpenMesh::Vec3d&) override {}
  void set_color(OpenMesh::VertexHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(OpenMesh::VertexHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(OpenMesh::VertexHandle, const OpenMesh::Vec3f&) override {}
  void set_color(OpenMesh::VertexHandle, const OpenMesh::Vec4f&) override {}
  void set_texcoord(OpenMesh::VertexHandle, const OpenMesh::Vec2f&) override {}
  void set_texcoord(OpenMesh::VertexHandle, const OpenMesh::Vec3f&) override {}
  void set_texcoord(OpenMesh::HalfedgeHandle, const OpenMesh::Vec2f&) override {}
  void set_texcoord(OpenMesh::HalfedgeHandle, const OpenMesh::Vec3f&) override {}
  void set_status(OpenMesh::VertexHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_status(OpenMesh::HalfedgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_status(OpenMesh::EdgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_status(OpenMesh::FaceHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_next(OpenMesh::HalfedgeHandle, OpenMesh::HalfedgeHandle) override {}
  void set_face(OpenMesh::HalfedgeHandle, OpenMesh::FaceHandle) override {}
  void request_face_texcoords2D() override {}
  void set_color(OpenMesh::EdgeHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(OpenMesh::EdgeHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(OpenMesh::EdgeHandle, const OpenMesh::Vec3f&) override {}
  void set_color(OpenMesh::EdgeHandle, const OpenMesh::Vec4f&) override {}
  void set_normal(OpenMesh::FaceHandle, const OpenMesh::Vec3f&) override {}
  void set_normal(OpenMesh::FaceHandle, const OpenMesh::Vec3d&) override {}
  void set_color(OpenMesh::FaceHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(OpenMesh::FaceHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(OpenMesh::FaceHandle, const OpenMesh::Vec3f&) override {}
  void set_color(OpenMesh::FaceHandle, const OpenMesh::Vec4f&) override {}
  void add_texture_information(int, std::string) override {}

 private:
  OpenMesh::VertexHandle add_position(const Vec3& p) {
    positions.push_back(p);
    return OpenMesh::VertexHandle(static_cast<int>(positions.size() - 1));
  }
};

/// Sends OpenMesh's omerr/omout/omlog to a string instead of the terminal while it lives. The
/// streams' buffers are swapped rather than using mostream::connect/disconnect, because
/// OpenMesh's disconnect() never frees the target it allocated in connect() (a leak per load
/// that LeakSanitizer reports).
class OpenMeshLogCapture {
 public:
  OpenMeshLogCapture() {
    for (Route& route : routes_) {
      route.stream.flush();
      route.saved = route.stream.rdbuf(captured_.rdbuf());
    }
  }
  ~OpenMeshLogCapture() {
    for (Route& route : routes_) route.stream.rdbuf(route.saved);
  }
  OpenMeshLogCapture(const OpenMeshLogCapture&) = delete;
  OpenMeshLogCapture& operator=(const OpenMeshLogCapture&) = delete;

  /// The first few captured lines, joined with "; ".
  std::string summary() const {
    std::istringstream lines(captured_.str());
    std::string line, joined;
    int kept = 0;
    while (std::getline(lines, line) && kept < 4) {
      const std::string_view trimmed = trim(line);
      if (trimmed.empty()) continue;
      if (!joined.empty()) joined += "; ";
      joined += trimmed;
      ++kept;
    }
    return joined;
  }

 private:
  struct Route {
    std::ostream& stream;
    std::streambuf* saved = nullptr;
  };
  std::ostringstream captured_;
  Route routes_[3] = {{omerr()}, {omout()}, {omlog()}};
};

RawMeshRecorder read_with_openmesh(const std::string& path, Format format) {
  // OpenMesh's readers are singletons with per-read state (the OBJ reader keeps its path and
  // materials), and the log streams are global: one read at a time.
  static std::mutex openmesh_mutex;
  const std::lock_guard lock(openmesh_mutex);
  OpenMeshLogCapture log;
  OpenMesh::IO::_STLReader_& stl_reader = OpenMesh::IO::STLReader();
  const float default_weld_tolerance = stl_reader.epsilon();
  stl_reader.set_epsilon(0.0f);

  RawMeshRecorder recorder;
  OpenMesh::IO::Options options;  // geometry only: no normals, colours or texture coordinates
  bool ok = false;
  std::string failure;
  try {
    ok = OpenMesh::IO::IOManager().read(path, recorder, options);
  } catch (const std::exception& e) {
    failure = e.what();
  }
  stl_reader.set_epsilon(default_weld_tolerance);
  if (!ok || recorder.used_halfedge_calls) {
    std::string details = log.summary();
    if (!failure.empty()) details = failure + (details.empty() ? "" : "; " + details);
    throw FileError(ErrorCode::ParseError, path + ": OpenMesh could not read this " +
                                      std::string(format_name(format)) + " file" +
                                      (details.empty() ? "" : " (" + details + ")"));
  }
  return recorder;
}

// ------------------------------------------------------------------------------------------------

/// Both floats agree to one unit in the last place (OpenMesh rounds decimal text to float
/// directly, the scan rounds to double first).
bool same_float(double openmesh_value, double scanned_value) {
  const float a = static_cast<float>(openmesh_value);
  const float b = static_cast<float>(scanned_value);
  return a == b || std::nextafter(b, a) == a;
}

[[noreturn]] void throw_disagreement(const std::string& path, Format format,
                                     const std::string& what) {
  throw FileError(ErrorCode::ParseError, path + ": OpenMesh's " + std::string(format_name(format)) +
                                    " reader and geoprox's check of the file disagree: " + what);
}

std::string describe_corners(const RawMeshRecorder& recorder, std::size_t f) {
  std::string text;
  for (std::size_t i = recorder.face_starts[f]; i < recorder.face_starts[f + 1]; ++i) {
    if (!text.empty()) text += ' ';  // not `" " + to_string(...)`: GCC 12 -O3 -Wrestrict
    text += std::to_string(recorder.corners[i]);
  }
  return text;
}

/// Refuses the file unless OpenMesh delivered exactly the scanned records.
void cross_check(const FileScan& scan, const RawMeshRecorder& recorder, Format format,
                 const std::string& path) {
  if (recorder.positions.size() != scan.vertex_count) {
    throw_disagreement(path, format,
                       "OpenMesh read " + std::to_string(recorder.positions.size()) +
                           " vertices, the file has " + std::to_string(scan.vertex_count));
  }
  const std::size_t openmesh_faces = scan.faces_from_strips ? 0 : scan.face_count;
  if (recorder.face_count() != openmesh_faces) {
    throw_disagreement(path, format,
                       "OpenMesh read " + std::to_string(recorder.face_count()) +
                           " faces, the file has " + std::to_string(openmesh_faces));
  }
  for (std::size_t v = 0; v < scan.vertex_count; ++v) {
    const Vec3& a = recorder.positions[v];
    const Vec3& b = scan.positions[v];
    if (!same_float(a.x, b.x) || !same_float(a.y, b.y) || !same_float(a.z, b.z)) {
      throw_disagreement(path, format,
                         "vertex " + std::to_string(v) + " is " + describe_point(b.x, b.y, b.z) +
                             " in the file but OpenMesh read " + describe_point(a.x, a.y, a.z));
    }
  }
  for (std::size_t f = 0; f < openmesh_faces; ++f) {
    const Triangle& t = scan.faces[f];
    const std::size_t start = recorder.face_starts[f];
    const bool same =
        recorder.face_starts[f + 1] - start == 3 &&
        std::equal(t.begin(), t.end(),
                   recorder.corners.begin() + static_cast<std::ptrdiff_t>(start),
                   [](std::uint32_t s, int r) { return static_cast<long long>(s) == r; });
    if (!same) {
      throw_disagreement(
          path, format,
          describe_face(f, t) + " was read by OpenMesh as (" + describe_corners(recorder, f) + ")");
    }
  }
}

std::optional<Format> format_of(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".obj") return Format::Obj;
  if (extension == ".off") return Format::Off;
  if (extension == ".ply") return Format::Ply;
  if (extension == ".stl") return Format::Stl;
  return std::nullopt;
}

void check_readable(const std::string& path) {
  std::error_code error;
  const auto status = std::filesystem::status(path, error);
  if (error || !std::filesystem::exists(status)) {
    throw FileError(ErrorCode::FileNotFound, path + ": no such file");
  }
  if (std::filesystem::is_directory(status)) {
    throw FileError(ErrorCode::FileNotFound, path + ": is a directory, not a mesh file");
  }
}

std::string read_whole_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(ErrorCode::FileNotFound, path + ": cannot be opened for reading");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw FileError(ErrorCode::FileNotFound, path + ": read error");
  return text;
}

}  // namespace

MeshSoup load_mesh_soup(const std::string& path) {
  check_readable(path);
  const std::optional<Format> format = format_of(path);
  if (!format) {
    throw FileError(ErrorCode::UnsupportedFormat,
                    path + ": unknown mesh format (expected .obj, .off, .ply or .stl)");
  }
  const std::string text = read_whole_file(path);
  if (text.empty()) {
    throw MeshError(ErrorCode::EmptyMesh, path + ": the file is empty (0 bytes, no faces)");
  }
  FileScan scan = scan_file(*format, text, path);
  const RawMeshRecorder recorder = read_with_openmesh(path, *format);
  cross_check(scan, recorder, *format, path);
  // The two readings agree record by record; the scan's copy keeps the file's precision.
  return {std::move(scan.positions), std::move(scan.faces)};
}

TriangleMesh load_mesh(const std::string& path) {
  MeshSoup soup = load_mesh_soup(path);
  try {
    return TriangleMesh(std::move(soup.positions), std::move(soup.faces));
  } catch (const MeshError& e) {
    throw MeshError(e.code(), path + ": " + e.what());
  }
}

}  // namespace geoprox
