// Shared checks and messages of core/mesh's readers (mesh_reader_support.h).
#include "core/mesh/mesh_reader_support.h"

#include <cfloat>
#include <cmath>
#include <cstdio>

namespace geoprox::mesh_reading {

std::string where(const std::string& path, std::size_t line) {
  return line == 0 ? path + ": " : path + ":" + std::to_string(line) + ": ";
}

void throw_parse_error(const std::string& path, std::size_t line, const std::string& what) {
  throw FileError(ErrorCode::ParseError, where(path, line) + what);
}

void throw_mesh_error(ErrorCode code, const std::string& path, std::size_t line,
                      const std::string& what) {
  throw MeshError(code, where(path, line) + what);
}

void throw_non_triangle(const std::string& path, std::size_t line, std::size_t face,
                        std::size_t corners) {
  throw_mesh_error(ErrorCode::NonTriangleFace, path, line,
                   "face " + std::to_string(face) + " has " + std::to_string(corners) +
                       " corners; only triangles are supported (triangulate the mesh first)");
}

std::string describe_point(double x, double y, double z) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.9g, %.9g, %.9g)", x, y, z);
  return buf;
}

std::string describe_face(std::size_t face, const Triangle& t) {
  return "face " + std::to_string(face) + " (vertices " + std::to_string(t[0]) + " " +
         std::to_string(t[1]) + " " + std::to_string(t[2]) + ")";
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

Vec3 checked_position(const double (&values)[3], std::size_t vertex, const std::string& path,
                      std::size_t line) {
  for (double v : values) {
    if (!std::isfinite(v)) {
      throw_mesh_error(ErrorCode::NonFiniteCoordinate, path, line,
                       "vertex " + std::to_string(vertex) + " has a non-finite coordinate " +
                           describe_point(values[0], values[1], values[2]));
    }
  }
  // Every format loads the same range of coordinates: that of 32-bit floats, which STL and
  // most binary PLY files store.
  for (double v : values) {
    if (std::abs(v) > FLT_MAX) {
      throw_parse_error(path, line,
                        "vertex " + std::to_string(vertex) +
                            " has a coordinate beyond the 32-bit float range " +
                            describe_point(values[0], values[1], values[2]));
    }
  }
  return {values[0], values[1], values[2]};
}

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

std::uint32_t checked_index(long long index, std::size_t face, const std::string& path,
                            std::size_t line) {
  if (index < 0 || index >= static_cast<long long>(UINT32_MAX)) {
    throw_mesh_error(ErrorCode::VertexOutOfRange, path, line,
                     "face " + std::to_string(face) + " refers to vertex " + std::to_string(index) +
                         ", which cannot exist");
  }
  return static_cast<std::uint32_t>(index);
}

void check_scanned_faces(const FileScan& scan, const std::string& path) {
  const std::size_t vertex_count = scan.positions.size();
  for (std::size_t f = 0; f < scan.faces.size(); ++f) {
    const Triangle& t = scan.faces[f];
    const std::size_t line = scan.face_lines.empty() ? 0 : scan.face_lines[f];
    for (std::uint32_t v : t) {
      if (v >= vertex_count) {
        throw_mesh_error(ErrorCode::VertexOutOfRange, path, line,
                         describe_face(f, t) + " refers to vertex " + std::to_string(v) +
                             " but the file has " + std::to_string(vertex_count) + " vertices");
      }
    }
    if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) {
      throw_mesh_error(ErrorCode::DegenerateFaceIndices, path, line,
                       describe_face(f, t) + " repeats a vertex; a triangle needs 3 distinct ones");
    }
  }
}

}  // namespace geoprox::mesh_reading
