// OFF reader (ascii; 3D only). The first line is the header ([ST][C][N]OFF, alone on its line),
// the next holds the counts (vertices, faces, edges). A vertex record is its line: three
// coordinates, three normal components with N, then texture coordinates and colour, which are
// skipped. Face records are whitespace-separated values (the count, 3 or more, then the
// corners), so they may span lines; values after the corners are a colour and need a C header.
#include <algorithm>

#include "core/base/tuning.h"
#include "core/mesh/mesh_reader_support.h"

namespace geoprox::mesh_reading {
namespace {

struct OffHeader {
  bool has_normals = false;
  bool has_colours = false;
  bool has_texcoords = false;
};

OffHeader read_off_header(std::string_view header, const std::string& path) {
  const std::string_view magic = header.substr(0, header.find_first_of(" \t"));
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
                      "the OFF header must be alone on its line, with the counts on the next "
                      "line");
  }
  return {magic.find('N') != std::string_view::npos, magic.find('C') != std::string_view::npos,
          magic.starts_with("ST")};
}

/// OFF has no comments: a '#' line would be read as numbers, so it is refused.
void refuse_comment_lines(std::string_view body, const std::string& path) {
  LineReader lines(body, 2);
  std::string_view line;
  while (lines.next(line)) {
    if (trim(line).starts_with('#')) {
      throw_parse_error(path, lines.line(), "comment lines are not supported in OFF files");
    }
  }
}

/// A colour is 0 to 4 values (none, a colour-map index, RGB or RGBA) after the coordinates
/// (and 2 texture coordinates) of a vertex or the corners of a face; more or fewer items mean
/// a record that is not what the header says.
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

struct OffCounts {
  std::size_t vertices = 0;
  std::size_t faces = 0;
};

OffCounts read_off_counts(Tokenizer& tokens, const std::string& path) {
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
  OffCounts counts;
  counts.vertices = expect_count("vertices");
  const std::size_t counts_line = tokens.line();
  counts.faces = expect_count("faces");
  expect_count("edges");
  if (tokens.line() != counts_line) {
    // Otherwise the first coordinate would be taken as the third count.
    throw_parse_error(path, counts_line,
                      "the counts line needs three numbers: vertices, faces, "
                      "edges");
  }
  return counts;
}

void read_off_vertices(Tokenizer& tokens, std::size_t count, const OffHeader& header,
                       const std::string& path, FileScan& scan) {
  for (std::size_t v = 0; v < count; ++v) {
    std::string_view xyz[3];
    for (std::string_view& token : xyz) {
      token = tokens.next();
      if (token.empty()) {
        throw_parse_error(path, tokens.line(),
                          "the file ends in vertex " + std::to_string(v) + " of the " +
                              std::to_string(count) + " its header announces");
      }
    }
    scan.positions.push_back(parse_coordinates(xyz[0], xyz[1], xyz[2], v, path, tokens.line()));
    if (header.has_normals) {
      for (int i = 0; i < 3; ++i) tokens.next();
    }
    const std::string_view extras = tokens.skip_rest_of_line();
    if (header.has_colours) {
      check_off_colour(extras, header.has_texcoords, "vertex", v, path, tokens.line());
    }
  }
}

void read_off_faces(Tokenizer& tokens, std::size_t count, const OffHeader& header,
                    const std::string& path, FileScan& scan) {
  std::vector<std::uint32_t> record;  // the corners of one face record
  for (std::size_t f = 0; f < count; ++f) {
    const std::string_view count_token = tokens.next();
    if (count_token.empty()) {
      throw_parse_error(path, tokens.line(),
                        "the file ends before face " + std::to_string(f) + " of the " +
                            std::to_string(count) + " its header announces");
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
    const std::size_t corner_count = static_cast<std::size_t>(*corners);
    check_corner_count(corner_count, f, path, line);
    record.clear();
    for (std::size_t i = 0; i < corner_count; ++i) {
      const std::string_view token = tokens.next();
      const std::optional<long long> index = parse_integer(token);
      if (!index) {
        throw_parse_error(
            path, tokens.line(),
            "face " + std::to_string(f) + ": '" + std::string(token) + "' is not a vertex index");
      }
      record.push_back(checked_index(*index, f, path, tokens.line()));
    }
    if (header.has_colours) {
      check_off_colour(tokens.skip_rest_of_line(), false, "face", f, path, tokens.line());
    } else if (tokens.more_on_this_line()) {
      throw_parse_error(path, tokens.line(),
                        "face " + std::to_string(f) + " has values after its " +
                            std::to_string(corner_count) +
                            " corners; face colours need a COFF header");
    }
    scan.add_face(record, line);
  }
}

}  // namespace

FileScan scan_off(std::string_view text, const std::string& path) {
  const std::size_t header_end = std::min(text.find('\n'), text.size());
  const OffHeader header = read_off_header(trim(text.substr(0, header_end)), path);
  const std::string_view body = header_end < text.size() ? text.substr(header_end + 1) : "";
  refuse_comment_lines(body, path);
  Tokenizer tokens(body, 2);
  const OffCounts counts = read_off_counts(tokens, path);
  FileScan scan;
  reserve_announced(scan.positions, counts.vertices, text.size(),
                    tuning::kSmallestVertexRecordBytes);
  reserve_announced(scan.faces, counts.faces, text.size(), tuning::kSmallestFaceRecordBytes);
  read_off_vertices(tokens, counts.vertices, header, path, scan);
  read_off_faces(tokens, counts.faces, header, path, scan);
  return scan;
}

}  // namespace geoprox::mesh_reading
