// Result files of the `geoprox` tool: PLY, OBJ and PNG writers (see result_files.h).
#include "clients/cli/result_files.h"

#include <png.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>

#include "clients/cli/cli.h"
#include "core/base/errors.h"

namespace geoprox::cli {
namespace {

void put_u32(std::string& out, std::uint32_t u) {
  for (int shift = 0; shift < 32; shift += 8) out += static_cast<char>((u >> shift) & 0xFF);
}
void put_f32(std::string& out, float value) { put_u32(out, std::bit_cast<std::uint32_t>(value)); }

std::string one_line(std::string text) {
  for (char& c : text) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return text;
}

// libpng reports errors through callbacks; they longjmp back to encode() (see there).
struct PngWriter {
  png_structp png = nullptr;
  png_infop info = nullptr;
  std::string bytes;
  char message[256] = "unknown libpng error";
};

void on_png_error(png_structp png, png_const_charp message) {
  auto* writer = static_cast<PngWriter*>(png_get_error_ptr(png));
  std::snprintf(writer->message, sizeof writer->message, "%s", message);
  png_longjmp(png, 1);
}
void on_png_warning(png_structp, png_const_charp) {}
void on_png_write(png_structp png, png_bytep data, png_size_t length) {
  auto* writer = static_cast<PngWriter*>(png_get_io_ptr(png));
  writer->bytes.append(reinterpret_cast<const char*>(data), length);
}
void on_png_flush(png_structp) {}

/// Runs libpng's writer; false (with writer.message) on a libpng error. Kept free of locals
/// that change after setjmp, so that the longjmp clobbers nothing.
bool encode(PngWriter& writer, const Image& image, png_bytepp rows) {
  if (setjmp(png_jmpbuf(writer.png))) return false;
  png_set_write_fn(writer.png, &writer, on_png_write, on_png_flush);
  png_set_IHDR(writer.png, writer.info, static_cast<png_uint_32>(image.width),
               static_cast<png_uint_32>(image.height), 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(writer.png, 9);
  png_write_info(writer.png, writer.info);
  png_write_image(writer.png, rows);
  png_write_end(writer.png, nullptr);
  return true;
}

}  // namespace

void write_field_ply(const std::string& path, const TriangleMesh& mesh,
                     const std::vector<double>& distances,
                     const std::vector<std::string>& comments) {
  if (distances.size() != mesh.num_vertices()) {
    throw InvalidInput(ErrorCode::MeshMismatch,
                       "the field has " + std::to_string(distances.size()) +
                           " values but the mesh has " + std::to_string(mesh.num_vertices()) +
                           " vertices");
  }
  GEOPROX_ASSERT(mesh.num_vertices() <= static_cast<std::size_t>(INT32_MAX),
                 "PLY vertex indices are int32");
  const double max_distance = max_finite(distances);
  std::string out =
      "ply\n"
      "format binary_little_endian 1.0\n";
  for (const std::string& comment : comments) out += "comment " + one_line(comment) + "\n";
  std::string max_text;
  append_number(max_text, max_distance);
  out +=
      "comment distance: geodesic distance in mesh units, nan where unreachable or cut off\n"
      "comment red green blue: viridis over [0, " +
      max_text + "], 128 128 128 where nan\n";
  out += "element vertex " + std::to_string(mesh.num_vertices()) +
         "\n"
         "property float x\n"
         "property float y\n"
         "property float z\n"
         "property float distance\n"
         "property uchar red\n"
         "property uchar green\n"
         "property uchar blue\n"
         "element face " +
         std::to_string(mesh.num_faces()) +
         "\n"
         "property list uchar int vertex_indices\n"
         "end_header\n";
  out.reserve(out.size() + mesh.num_vertices() * 19 + mesh.num_faces() * 13);
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    const Vec3& p = mesh.position(v);
    put_f32(out, static_cast<float>(p.x));
    put_f32(out, static_cast<float>(p.y));
    put_f32(out, static_cast<float>(p.z));
    const double d = distances[v];
    put_f32(out,
            std::isfinite(d) ? static_cast<float>(d) : std::numeric_limits<float>::quiet_NaN());
    const Rgb colour = value_colour(d, max_distance);
    out += static_cast<char>(colour.r);
    out += static_cast<char>(colour.g);
    out += static_cast<char>(colour.b);
  }
  for (const Triangle& face : mesh.faces()) {
    out += static_cast<char>(3);
    for (std::uint32_t v : face) put_u32(out, v);
  }
  write_file_atomically(path, out);
}

std::string field_ply_footer() {
  return "--out FILE: a binary little-endian PLY (MeshLab, ParaView), nothing on stdout: the\n"
         "vertices and faces in file order, per vertex float x y z, float distance ('nan' where\n"
         "unreachable or cut off) and uchar red green blue (viridis from 0, dark purple, to the\n"
         "largest finite distance, yellow; 128 128 128 where nan).";
}

std::string field_file_summary(const TriangleMesh& mesh, const std::vector<double>& distances) {
  std::size_t unreachable = 0;
  for (double d : distances) unreachable += std::isfinite(d) ? 0 : 1;
  char text[160];
  std::snprintf(text, sizeof text,
                "%zu vertices, %zu faces, distances 0..%.6g, %zu unreachable (nan)",
                mesh.num_vertices(), mesh.num_faces(), max_finite(distances), unreachable);
  return text;
}

void append_xyz(std::string& out, const Vec3& point) {
  append_number(out, point.x);
  out += ' ';
  append_number(out, point.y);
  out += ' ';
  append_number(out, point.z);
}

void write_path_obj(const std::string& path, const std::vector<Vec3>& points,
                    const std::vector<std::string>& comments) {
  if (points.empty()) throw InvalidInput(ErrorCode::EmptyPath, "the path has no points to write");
  std::string out;
  for (const std::string& comment : comments) out += "# " + one_line(comment) + "\n";
  for (const Vec3& p : points) {
    out += "v ";
    append_xyz(out, p);
    out += '\n';
  }
  out += "l";
  for (std::size_t i = 1; i <= points.size(); ++i) {
    out += ' ';  // not " " + ...: a false -Wrestrict of g++ 12 (see write_file_atomically)
    out += std::to_string(i);
  }
  if (points.size() == 1) out += " 1";
  out += '\n';
  write_file_atomically(path, out);
}

void write_png(const std::string& path, const Image& image) {
  GEOPROX_ASSERT(image.width > 0 && image.height > 0 &&
                     image.rgb.size() == static_cast<std::size_t>(image.width) *
                                             static_cast<std::size_t>(image.height) * 3,
                 "an image's pixels do not match its size");
  PngWriter writer;
  writer.png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, &writer, on_png_error, on_png_warning);
  if (writer.png) writer.info = png_create_info_struct(writer.png);
  if (!writer.png || !writer.info) {
    png_destroy_write_struct(&writer.png, nullptr);
    throw FileError(ErrorCode::WriteFailed, "cannot write '" + path + "': libpng could not start");
  }
  std::vector<png_bytep> rows(static_cast<std::size_t>(image.height));
  for (std::size_t y = 0; y < rows.size(); ++y) {
    // libpng's row pointers are not const, but png_write_image only reads them.
    rows[y] =
        const_cast<png_bytep>(image.rgb.data() + y * static_cast<std::size_t>(image.width) * 3);
  }
  const bool ok = encode(writer, image, rows.data());
  png_destroy_write_struct(&writer.png, &writer.info);
  if (!ok)
    throw FileError(ErrorCode::WriteFailed,
                    "cannot write '" + path + "': libpng: " + writer.message);
  write_file_atomically(path, writer.bytes);
}

}  // namespace geoprox::cli
