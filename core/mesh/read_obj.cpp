// OBJ reader: line based; only `v` and `f` lines matter for geometry (an `f` line of any number
// of corners, 3 or more, is one face record). Every other line (`vt`
// with one, two or three values, `vn`, `vp`, `usemtl`, `mtllib`, `o`, `g`, `s`, `l`, ...) is
// skipped unread, as are the texture and normal indices of a face's corners.
#include <algorithm>

#include "core/mesh/mesh_reader_support.h"

namespace geoprox::mesh_reading {
namespace {

/// The corners of the `f` line `tokens` (tokens[0] == "f"), 0-based. `vertices_so_far` resolves
/// negative indices, which count back from the last vertex read.
std::vector<std::uint32_t> read_obj_face(const std::vector<std::string_view>& tokens,
                                         std::size_t face, std::size_t vertices_so_far,
                                         const std::string& path, std::size_t line) {
  std::vector<std::uint32_t> corners;
  for (std::size_t i = 1; i < tokens.size(); ++i) {
    // v, v/vt, v//vn or v/vt/vn: only the position index matters.
    const std::string_view position = tokens[i].substr(0, tokens[i].find('/'));
    const std::optional<long long> index = parse_integer(position);
    if (!index) {
      throw_parse_error(path, line,
                        "face " + std::to_string(face) + ": '" + std::string(tokens[i]) +
                            "' is not a vertex index");
    }
    if (*index == 0) {
      throw_mesh_error(
          ErrorCode::VertexOutOfRange, path, line,
          "face " + std::to_string(face) + " uses vertex index 0; OBJ indices start at 1");
    }
    const long long resolved =
        *index > 0 ? *index - 1 : static_cast<long long>(vertices_so_far) + *index;
    corners.push_back(checked_index(resolved, face, path, line));
  }
  return corners;
}

}  // namespace

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
      const std::size_t face = scan.records_read();
      const std::vector<std::uint32_t> corners =
          read_obj_face(tokens, face, scan.positions.size(), path, lines.line());
      check_corner_count(corners.size(), face, path, lines.line());
      scan.add_face(corners, lines.line());
    }
  }
  return scan;
}

}  // namespace geoprox::mesh_reading
