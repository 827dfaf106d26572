// Validation report of a mesh (no paper; the triangle quality G = area / (|AB|^2+|BC|^2+|CA|^2)
// is Lo's, as used by the proximity-graph paper §5.3; 0.1443 for an equilateral triangle).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"

namespace geoprox {

struct MeshReport {
  std::size_t vertices = 0;
  std::size_t faces = 0;
  std::size_t edges = 0;
  std::size_t isolated_vertices = 0;   ///< referenced by no face (kept, unreachable)
  std::size_t boundary_edges = 0;
  std::size_t boundary_loops = 0;
  std::size_t components = 0;          ///< connected components of faces
  std::vector<long> genus_per_component;  ///< (2 - chi - boundary loops) / 2 per component
  std::size_t degenerate_faces = 0;    ///< zero-area faces (IntrinsicGeometry::is_degenerate_face)
  /// other faces thinner than IntrinsicGeometryOptions::thin_face_ratio (is_thin_face)
  std::size_t thin_faces = 0;
  std::size_t obtuse_faces = 0;        ///< faces with an angle > 90 degrees
  std::size_t saddle_vertices = 0;     ///< interior vertices with angle sum > 2 pi
  Vec3 bbox_min, bbox_max;
  double mean_edge_length = 0;
  double min_edge_length = 0;
  double max_edge_length = 0;
  double total_area = 0;
  double lo_quality_mean = 0;          ///< mean of G over faces
  double lo_quality_min = 0;           ///< min of G over faces
};

MeshReport compute_mesh_report(const TriangleMesh& mesh, const IntrinsicGeometry& geometry);

/// Human-readable multi-line report (what `geoprox info` prints).
std::string format_mesh_report(const MeshReport& report);

}  // namespace geoprox
