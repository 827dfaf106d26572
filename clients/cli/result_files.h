// Result files of the `geoprox` tool, for viewers (no paper): a distance field as a coloured PLY
// mesh (MeshLab, ParaView, CloudCompare, Blender), a path as an OBJ polyline (Blender, MeshLab),
// a picture as a PNG (libpng). Each is built in memory and written with write_file_atomically:
// readers see the old file or the whole new one. Failures throw FileError ("WriteFailed").
#pragma once

#include <string>
#include <vector>

#include "clients/cli/render.h"
#include "core/mesh/mesh.h"

namespace geoprox::cli {

/// Writes `mesh` with a distance per vertex as a binary little-endian PLY 1.0:
///   element vertex: float x, y, z; float distance; uchar red, green, blue
///   element face:   list uchar int vertex_indices
/// Vertices and faces in the mesh's file order. `distance` is NaN where the value is not finite
/// (unreachable, or beyond a cutoff), and the colour is value_colour(distance, largest finite
/// distance): viridis over [0, max], kNoValueColour (128,128,128) where NaN. `comments` become
/// `comment` lines of the header (line breaks replaced by spaces), followed by two that state
/// these conventions and the maximum. Throws InvalidInput ("MeshMismatch") when `distances`
/// does not have one value per vertex.
void write_field_ply(const std::string& path, const TriangleMesh& mesh,
                     const std::vector<double>& distances,
                     const std::vector<std::string>& comments);

/// The --help paragraph describing the PLY of `field --out` (offline and remote).
std::string field_ply_footer();

/// What write_field_ply wrote, for a message: "V vertices, F faces, distances 0..MAX, U
/// unreachable (nan)".
std::string field_file_summary(const TriangleMesh& mesh, const std::vector<double>& distances);

/// Appends "X Y Z" (%.17g each): a point of a printed path or of an OBJ `v` line.
void append_xyz(std::string& out, const Vec3& point);

/// Writes a polyline as a Wavefront OBJ: `comments` as `#` lines, one `v X Y Z` line per point
/// (%.17g, in order) and one `l 1 2 ... N` line joining them. A single point is written as the
/// line `l 1 1`. Throws InvalidInput ("EmptyPath") for no points.
void write_path_obj(const std::string& path, const std::vector<Vec3>& points,
                    const std::vector<std::string>& comments);

/// Writes an 8-bit RGB PNG (non-interlaced, zlib level 9).
void write_png(const std::string& path, const Image& image);

}  // namespace geoprox::cli
