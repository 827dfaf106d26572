// Shared checks and messages of core/mesh's readers (mesh_reader_support.h).
#include "core/mesh/mesh_reader_support.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>

#include "core/base/tuning.h"
#include "core/mesh/polygon_triangulation.h"

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

std::string describe_point(double x, double y, double z) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.9g, %.9g, %.9g)", x, y, z);
  return buf;
}

std::string describe_face(std::size_t face, const Triangle& t) {
  return "face " + std::to_string(face) + " (vertices " + std::to_string(t[0]) + " " +
         std::to_string(t[1]) + " " + std::to_string(t[2]) + ")";
}

std::string describe_polygon(std::size_t face, std::span<const std::uint32_t> corners) {
  // Enough to find the record in the file; a polygon may have thousands of corners.
  constexpr std::size_t kListedCorners = 8;
  std::string text = "face " + std::to_string(face) + " (vertices";
  for (std::size_t i = 0; i < std::min(corners.size(), kListedCorners); ++i) {
    text += ' ';
    text += std::to_string(corners[i]);
  }
  if (corners.size() > kListedCorners) {
    text += " ... " + std::to_string(corners.back()) + ", " + std::to_string(corners.size()) +
            " corners";
  }
  return text + ")";
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

void check_corner_count(std::size_t corners, std::size_t face, const std::string& path,
                        std::size_t line) {
  if (corners < 3) {
    throw_mesh_error(ErrorCode::DegenerateFaceIndices, path, line,
                     "face " + std::to_string(face) + " has " + std::to_string(corners) +
                         " corners; a face needs at least 3");
  }
  if (corners > tuning::kMaxPolygonCorners) {
    throw_mesh_error(ErrorCode::TooLarge, path, line,
                     "face " + std::to_string(face) + " has " + std::to_string(corners) +
                         " corners, more than the " + std::to_string(tuning::kMaxPolygonCorners) +
                         " a polygon may have");
  }
}

void FileScan::add_face(std::span<const std::uint32_t> corners, std::size_t line) {
  if (corners.size() == 3) {
    faces.push_back({corners[0], corners[1], corners[2]});
    face_lines.push_back(line);
    return;
  }
  polygons.push_back({records_read(), polygon_corners.size(), corners.size(), line});
  polygon_corners.insert(polygon_corners.end(), corners.begin(), corners.end());
}

namespace {

void check_triangle(const Triangle& t, std::size_t face, std::size_t vertex_count,
                    const std::string& path, std::size_t line) {
  for (std::uint32_t v : t) {
    if (v >= vertex_count) {
      throw_mesh_error(ErrorCode::VertexOutOfRange, path, line,
                       describe_face(face, t) + " refers to vertex " + std::to_string(v) +
                           " but the file has " + std::to_string(vertex_count) + " vertices");
    }
  }
  if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) {
    throw_mesh_error(
        ErrorCode::DegenerateFaceIndices, path, line,
        describe_face(face, t) + " repeats a vertex; a triangle needs 3 distinct ones");
  }
}

/// Checks a polygon's corners as check_triangle does, then appends its triangles, over the
/// file's vertex ids, to `triangles`.
void triangulate_scanned_polygon(const FileScan& scan, const ScannedPolygon& polygon,
                                 const std::string& path, std::vector<Triangle>& triangles) {
  const std::span<const std::uint32_t> corners(scan.polygon_corners.data() + polygon.first_corner,
                                               polygon.corners);
  const std::size_t vertex_count = scan.positions.size();
  for (std::uint32_t v : corners) {
    if (v >= vertex_count) {
      throw_mesh_error(ErrorCode::VertexOutOfRange, path, polygon.line,
                       describe_polygon(polygon.record, corners) + " refers to vertex " +
                           std::to_string(v) + " but the file has " + std::to_string(vertex_count) +
                           " vertices");
    }
  }
  std::vector<std::uint32_t> sorted(corners.begin(), corners.end());
  std::sort(sorted.begin(), sorted.end());
  const auto repeated = std::adjacent_find(sorted.begin(), sorted.end());
  if (repeated != sorted.end()) {
    throw_mesh_error(ErrorCode::DegenerateFaceIndices, path, polygon.line,
                     describe_polygon(polygon.record, corners) + " repeats vertex " +
                         std::to_string(*repeated) + "; a polygon needs " +
                         std::to_string(corners.size()) + " distinct ones");
  }
  std::vector<Vec3> positions;
  positions.reserve(corners.size());
  for (std::uint32_t v : corners) positions.push_back(scan.positions[v]);
  PolygonTriangulation triangulation;
  try {
    triangulation = triangulate_polygon(positions);
  } catch (const MeshError& e) {
    throw_mesh_error(e.code(), path, polygon.line,
                     describe_polygon(polygon.record, corners) + ": " + e.what());
  }
  for (const Triangle& t : triangulation.triangles) {
    triangles.push_back({corners[t[0]], corners[t[1]], corners[t[2]]});
  }
}

}  // namespace

void check_and_triangulate_faces(FileScan& scan, const std::string& path) {
  const std::size_t vertex_count = scan.positions.size();
  scan.face_records = scan.records_read();
  if (scan.polygons.empty()) {
    for (std::size_t f = 0; f < scan.faces.size(); ++f) {
      check_triangle(scan.faces[f], f, vertex_count, path,
                     scan.face_lines.empty() ? 0 : scan.face_lines[f]);
    }
    return;
  }
  std::size_t triangle_count = scan.faces.size();
  for (const ScannedPolygon& polygon : scan.polygons) triangle_count += polygon.corners - 2;
  if (triangle_count > TriangleMesh::kMaxFaces) {
    throw_mesh_error(ErrorCode::TooLarge, path, 0,
                     "the file's faces give " + std::to_string(triangle_count) +
                         " triangles, more than the 2^30 a mesh may have");
  }
  // Records in file order: the triangle records before each polygon, then the polygon.
  std::vector<Triangle> triangles;
  std::vector<std::size_t> lines;
  std::vector<std::uint32_t> face_polygon;
  triangles.reserve(triangle_count);
  lines.reserve(triangle_count);
  face_polygon.reserve(triangle_count);
  std::size_t next_triangle = 0;
  auto take_triangle_records = [&](std::size_t end, std::size_t polygons_before) {
    for (; next_triangle < end; ++next_triangle) {
      const std::size_t record = next_triangle + polygons_before;
      const std::size_t line = scan.face_lines[next_triangle];
      check_triangle(scan.faces[next_triangle], record, vertex_count, path, line);
      triangles.push_back(scan.faces[next_triangle]);
      lines.push_back(line);
      face_polygon.push_back(static_cast<std::uint32_t>(record));
    }
  };
  for (std::size_t p = 0; p < scan.polygons.size(); ++p) {
    const ScannedPolygon& polygon = scan.polygons[p];
    take_triangle_records(polygon.record - p, p);
    triangulate_scanned_polygon(scan, polygon, path, triangles);
    lines.resize(triangles.size(), polygon.line);
    face_polygon.resize(triangles.size(), static_cast<std::uint32_t>(polygon.record));
  }
  take_triangle_records(scan.faces.size(), scan.polygons.size());
  scan.faces = std::move(triangles);
  scan.face_lines = std::move(lines);
  scan.face_polygon = std::move(face_polygon);
}

}  // namespace geoprox::mesh_reading
