// Private to core/mesh's readers (mesh_io.cpp, read_obj.cpp, read_off.cpp, read_ply.cpp,
// read_stl.cpp); no public header includes it.
//
// Each reader scans the whole text of one file strictly, once: every vertex and face record in
// file order, refusing what it cannot read exactly (with the path and line in the message)
// instead of guessing. Coordinates keep the file's precision: the decimal digits of OBJ, OFF
// and ascii PLY, binary PLY doubles, STL's floats.
#pragma once

#include <algorithm>
#include <charconv>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/base/errors.h"
#include "core/mesh/mesh.h"

namespace geoprox::mesh_reading {

/// A face record of more than three corners, kept as read until every vertex is: a face may
/// come before the vertices it uses (OBJ indices ahead, PLY elements in any order), and its
/// triangulation needs their positions.
struct ScannedPolygon {
  std::size_t record = 0;        ///< the file's face id: face records counted from 0
  std::size_t first_corner = 0;  ///< in FileScan::polygon_corners
  std::size_t corners = 0;
  std::size_t line = 0;  ///< 0 if binary
};

/// What a reader found in the file, in file order.
struct FileScan {
  std::vector<Vec3> positions;  ///< as exact as the file: its digits, doubles, or STL's floats
  /// The triangle records; after check_and_triangulate_faces, every triangle of the file's face
  /// records in file order (a polygon's where it stands).
  std::vector<Triangle> faces;
  std::vector<std::size_t> face_lines;  ///< line of each face's record (0 if binary)
  /// The face records of more than three corners, in file order, and their corners.
  std::vector<ScannedPolygon> polygons;
  std::vector<std::uint32_t> polygon_corners;
  /// After check_and_triangulate_faces: the face record of each triangle, or empty when every
  /// record is a triangle (MeshSoup::face_polygon); and the number of face records.
  std::vector<std::uint32_t> face_polygon;
  std::size_t face_records = 0;

  /// Face records read so far (the id of the next one).
  std::size_t records_read() const { return faces.size() + polygons.size(); }
  /// Appends a face record of at least three corners (check_corner_count).
  void add_face(std::span<const std::uint32_t> corners, std::size_t line);
};

/// The readers, one per format (read_obj.cpp, ...). Each throws FileError(ParseError) for
/// syntax, MeshError for content (NonFiniteCoordinate, VertexOutOfRange, ...). Indices are
/// range-checked by check_and_triangulate_faces afterwards, except where a reader says so.
FileScan scan_obj(std::string_view text, const std::string& path);
FileScan scan_off(std::string_view text, const std::string& path);
FileScan scan_ply(std::string_view text, const std::string& path);
FileScan scan_stl(std::string_view text, const std::string& path);

// ---- Errors. Every message starts with the path (and line, when known) so that a user with
// several meshes knows which file to fix.

/// "path: " or "path:line: " (line 0 means unknown or binary).
std::string where(const std::string& path, std::size_t line);
[[noreturn]] void throw_parse_error(const std::string& path, std::size_t line,
                                    const std::string& what);
[[noreturn]] void throw_mesh_error(ErrorCode code, const std::string& path, std::size_t line,
                                   const std::string& what);
/// "(x, y, z)" to 9 significant digits.
std::string describe_point(double x, double y, double z);
/// "face F (vertices A B C)".
std::string describe_face(std::size_t face, const Triangle& t);
/// "face F (vertices A B C D ...)", the first few corners of a polygon.
std::string describe_polygon(std::size_t face, std::span<const std::uint32_t> corners);

// ---- Strict number syntax: the whole token must be a number (a leading '+' is allowed).

inline std::string_view strip_plus(std::string_view token) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
  return token;
}

/// Accepts nan and inf (from_chars does), so that the caller can name the non-finite vertex.
inline std::optional<double> parse_real(std::string_view token) {
  token = strip_plus(token);
  double value = 0;
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (error != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

inline std::optional<long long> parse_integer(std::string_view token) {
  token = strip_plus(token);
  long long value = 0;
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (error != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

inline bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
}

inline std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split_tokens(std::string_view line);

/// Lines of a text, numbered from `first_line`.
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

/// Whitespace-separated tokens with their line numbers (OFF and ascii PLY bodies, where a
/// record may span lines).
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
  /// Drops the rest of the line of the last token and returns it.
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

// ---- Checked values.

/// Refuses non-finite values (NonFiniteCoordinate, as TriangleMesh would, but naming the line)
/// and values beyond the 32-bit float range (ParseError).
Vec3 checked_position(const double (&values)[3], std::size_t vertex, const std::string& path,
                      std::size_t line);

/// Parses three coordinate tokens of vertex `vertex` (ParseError for a non-number), then
/// checks them as checked_position does.
Vec3 parse_coordinates(std::string_view x, std::string_view y, std::string_view z,
                       std::size_t vertex, const std::string& path, std::size_t line);

/// A non-negative vertex index that fits a Triangle; otherwise VertexOutOfRange.
std::uint32_t checked_index(long long index, std::size_t face, const std::string& path,
                            std::size_t line);

/// Refuses a face record of fewer than 3 corners (DegenerateFaceIndices) or of more than
/// tuning::kMaxPolygonCorners (TooLarge), as soon as a reader knows its corner count.
void check_corner_count(std::size_t corners, std::size_t face, const std::string& path,
                        std::size_t line);

/// Checks every face record's indices against the vertex count and for repeated corners, in
/// file order, as TriangleMesh does but naming the line; triangulates the polygons
/// (core/mesh/polygon_triangulation.h; DegenerateFaceIndices for one whose corners lie on a
/// line) into scan.faces, where their records stand; fills face_polygon and face_records.
void check_and_triangulate_faces(FileScan& scan, const std::string& path);

/// Reserves room for records a header announces, but no more than the text could hold at
/// `min_record_bytes` each: a header's counts are not trusted with memory before the records
/// are there.
template <typename T>
void reserve_announced(std::vector<T>& records, std::size_t announced, std::size_t text_bytes,
                       std::size_t min_record_bytes) {
  records.reserve(std::min(announced, text_bytes / min_record_bytes));
}

}  // namespace geoprox::mesh_reading
