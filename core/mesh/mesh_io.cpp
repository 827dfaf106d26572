// Mesh loading: the format by extension, one strict reader per format (read_obj.cpp,
// read_off.cpp, read_ply.cpp, read_stl.cpp), the same index checks and triangulation of
// polygons for all, then TriangleMesh.
// See core/mesh/mesh_io.h for the contract.
#include "core/mesh/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string_view>

#include "core/base/errors.h"
#include "core/mesh/mesh_reader_support.h"

namespace geoprox {
namespace {

using mesh_reading::FileScan;

enum class Format { Obj, Off, Ply, Stl };

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

FileScan scan_file(Format format, std::string_view text, const std::string& path) {
  FileScan scan;
  switch (format) {
    case Format::Obj:
      scan = mesh_reading::scan_obj(text, path);
      break;
    case Format::Off:
      scan = mesh_reading::scan_off(text, path);
      break;
    case Format::Ply:
      scan = mesh_reading::scan_ply(text, path);
      break;
    case Format::Stl:
      scan = mesh_reading::scan_stl(text, path);
      break;
  }
  mesh_reading::check_and_triangulate_faces(scan, path);
  return scan;
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
  MeshSoup soup;
  soup.positions = std::move(scan.positions);
  soup.faces = std::move(scan.faces);
  soup.face_polygon = std::move(scan.face_polygon);
  soup.polygons = scan.face_records;
  return soup;
}

namespace {

TriangleMesh make_mesh(const std::string& path, std::vector<Vec3> positions,
                       std::vector<Triangle> faces) {
  try {
    return TriangleMesh(std::move(positions), std::move(faces));
  } catch (const MeshError& e) {
    throw MeshError(e.code(), path + ": " + e.what());
  }
}

}  // namespace

TriangleMesh load_mesh(const std::string& path) {
  MeshSoup soup = load_mesh_soup(path);
  return make_mesh(path, std::move(soup.positions), std::move(soup.faces));
}

LoadedMeshFile load_mesh_file(const std::string& path, const MeshLoadOptions& options) {
  MeshSoup soup = load_mesh_soup(path);
  if (!options.repair) {
    return {make_mesh(path, std::move(soup.positions), std::move(soup.faces)),
            std::move(soup.face_polygon), soup.polygons, std::nullopt};
  }
  RepairedMesh repaired = [&] {
    try {
      return repair_mesh(soup.positions, soup.faces);
    } catch (const MeshError& e) {
      throw MeshError(e.code(), path + ": " + e.what());
    }
  }();
  std::vector<std::uint32_t> face_polygon;
  if (!soup.face_polygon.empty()) {
    face_polygon.reserve(repaired.faces.size());
    for (const std::uint32_t f : repaired.source_face) face_polygon.push_back(soup.face_polygon[f]);
  }
  return {make_mesh(path, std::move(repaired.positions), std::move(repaired.faces)),
          std::move(face_polygon), soup.polygons, repaired.report};
}

}  // namespace geoprox
