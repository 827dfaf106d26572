#include "core/mesh/mesh_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <numeric>
#include <string>

#include "core/base/tuning.h"
#include "core/base/union_find.h"

namespace geoprox {
namespace {

/// The boundary halfedge that follows boundary halfedge h = a->b along its loop: the one leaving
/// b, found by turning around b from face to face (TriangleMesh guarantees a single fan).
std::uint32_t next_boundary_halfedge(const TriangleMesh& mesh, std::uint32_t h) {
  std::uint32_t g = TriangleMesh::next(h);  // b -> c, leaves b
  for (std::size_t guard = 0; guard <= mesh.num_halfedges(); ++guard) {
    const std::int32_t t = mesh.twin(g);
    if (t < 0) return g;
    g = TriangleMesh::next(static_cast<std::uint32_t>(t));
  }
  return g;  // unreachable on a valid TriangleMesh
}

/// Lo's triangle quality G = area / (|AB|^2 + |BC|^2 + |CA|^2); 0 for a face with no extent.
double lo_quality(double area, double a, double b, double c) {
  const double sum_squares = a * a + b * b + c * c;
  return sum_squares > 0 ? area / sum_squares : 0.0;
}

/// Whether the angle opposite the longest side exceeds 90 degrees; the slack keeps exact right
/// triangles (legs^2 + legs^2 == hypotenuse^2 up to rounding) from counting.
bool is_obtuse(double a, double b, double c) {
  double sides[3] = {a, b, c};
  std::sort(sides, sides + 3);
  return sides[2] * sides[2] > (sides[0] * sides[0] + sides[1] * sides[1]) * (1 + 1e-12);
}

std::string format_number(double value) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", value);
  return buf;
}

/// Components, boundary edges and loops, isolated vertices, genus per component.
void report_topology(const TriangleMesh& mesh, MeshReport& report) {
  const auto num_faces = static_cast<std::uint32_t>(mesh.num_faces());
  const auto num_vertices = static_cast<std::uint32_t>(mesh.num_vertices());
  // Connected components of faces across shared edges.
  UnionFind components(num_faces);  // labelled by their lowest face
  for (std::uint32_t h = 0; h < mesh.num_halfedges(); ++h) {
    const std::int32_t t = mesh.twin(h);
    if (t >= 0)
      components.unite(TriangleMesh::face_of(h),
                       TriangleMesh::face_of(static_cast<std::uint32_t>(t)));
  }
  // Index components in order of their lowest face.
  std::vector<std::uint32_t> component_of_root(num_faces, UINT32_MAX);
  std::vector<std::uint32_t> component_of_face(num_faces);
  for (std::uint32_t f = 0; f < num_faces; ++f) {
    const std::uint32_t root = components.find(f);
    if (component_of_root[root] == UINT32_MAX) {
      component_of_root[root] = static_cast<std::uint32_t>(report.components++);
    }
    component_of_face[f] = component_of_root[root];
  }

  // Euler characteristic per component: V - E + F over what the component's faces use. A vertex
  // is in one component only, since TriangleMesh guarantees one fan per vertex.
  std::vector<long> chi(report.components, 0);
  std::vector<long> loops(report.components, 0);
  for (std::uint32_t f = 0; f < num_faces; ++f) ++chi[component_of_face[f]];
  for (std::uint32_t e = 0; e < mesh.num_edges(); ++e) {
    --chi[component_of_face[TriangleMesh::face_of(mesh.edge_halfedge(e))]];
    if (mesh.is_boundary_edge(e)) ++report.boundary_edges;
  }
  for (std::uint32_t v = 0; v < num_vertices; ++v) {
    const auto out = mesh.outgoing_halfedges(v);
    if (out.empty()) {
      ++report.isolated_vertices;
      continue;
    }
    ++chi[component_of_face[TriangleMesh::face_of(out[0])]];
  }

  // Boundary loops: follow each unvisited boundary halfedge around its hole.
  std::vector<std::uint8_t> visited(mesh.num_halfedges(), 0);
  for (std::uint32_t h = 0; h < mesh.num_halfedges(); ++h) {
    if (mesh.twin(h) >= 0 || visited[h]) continue;
    ++report.boundary_loops;
    ++loops[component_of_face[TriangleMesh::face_of(h)]];
    std::uint32_t g = h;
    do {
      visited[g] = 1;
      g = next_boundary_halfedge(mesh, g);
    } while (!visited[g]);
  }
  report.genus_per_component.resize(report.components);
  for (std::size_t c = 0; c < report.components; ++c) {
    report.genus_per_component[c] = (2 - chi[c] - loops[c]) / 2;
  }
}

/// Degenerate, thin and obtuse faces, area and quality, saddles: from the intrinsic lengths.
void report_geometry(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                     MeshReport& report) {
  const auto num_faces = static_cast<std::uint32_t>(mesh.num_faces());
  const auto num_vertices = static_cast<std::uint32_t>(mesh.num_vertices());
  // Faces: degeneracy, obtuse angles, area and quality, all from the intrinsic lengths.
  report.lo_quality_min = std::numeric_limits<double>::infinity();
  double quality_sum = 0;
  for (std::uint32_t f = 0; f < num_faces; ++f) {
    const double a = geometry.edge_length(mesh.edge_of(3 * f));
    const double b = geometry.edge_length(mesh.edge_of(3 * f + 1));
    const double c = geometry.edge_length(mesh.edge_of(3 * f + 2));
    const double area = geometry.face_area(f);
    if (geometry.is_degenerate_face(f)) ++report.degenerate_faces;
    if (geometry.is_thin_face(f)) ++report.thin_faces;
    if (is_obtuse(a, b, c)) ++report.obtuse_faces;
    report.total_area += area;
    const double quality = lo_quality(area, a, b, c);
    quality_sum += quality;
    report.lo_quality_min = std::min(report.lo_quality_min, quality);
  }
  report.lo_quality_mean = quality_sum / num_faces;

  // Saddles: interior vertices whose angle sum exceeds 2 pi beyond rounding (flat ones do not).
  const double full_turn = 2 * std::numbers::pi;
  for (std::uint32_t v = 0; v < num_vertices; ++v) {
    if (mesh.is_isolated_vertex(v) || mesh.is_boundary_vertex(v)) continue;
    if (geometry.angle_sum(v) > full_turn * (1 + tuning::kRelativeSlack)) {
      ++report.saddle_vertices;
    }
  }
}

/// Bounding box and edge lengths.
void report_extent(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                   MeshReport& report) {
  const auto num_vertices = static_cast<std::uint32_t>(mesh.num_vertices());
  // Bounding box of the surface: vertices used by faces (isolated ones are not on it).
  constexpr double inf = std::numeric_limits<double>::infinity();
  report.bbox_min = {inf, inf, inf};
  report.bbox_max = {-inf, -inf, -inf};
  for (std::uint32_t v = 0; v < num_vertices; ++v) {
    if (mesh.is_isolated_vertex(v)) continue;
    const Vec3& p = mesh.position(v);
    report.bbox_min = {std::min(report.bbox_min.x, p.x), std::min(report.bbox_min.y, p.y),
                       std::min(report.bbox_min.z, p.z)};
    report.bbox_max = {std::max(report.bbox_max.x, p.x), std::max(report.bbox_max.y, p.y),
                       std::max(report.bbox_max.z, p.z)};
  }

  const std::vector<double>& lengths = geometry.edge_lengths();
  const auto [shortest, longest] = std::minmax_element(lengths.begin(), lengths.end());
  report.min_edge_length = *shortest;
  report.max_edge_length = *longest;
  report.mean_edge_length =
      std::accumulate(lengths.begin(), lengths.end(), 0.0) / static_cast<double>(lengths.size());
}

}  // namespace

MeshReport compute_mesh_report(const TriangleMesh& mesh, const IntrinsicGeometry& geometry) {
  MeshReport report;
  report.vertices = mesh.num_vertices();
  report.faces = mesh.num_faces();
  report.edges = mesh.num_edges();
  report_topology(mesh, report);
  report_geometry(mesh, geometry, report);
  report_extent(mesh, geometry, report);
  return report;
}

std::string format_mesh_report(const MeshReport& report) {
  // Right-aligned labels so that the values line up and every line reads "label: value".
  constexpr int kLabelWidth = 18;
  std::string text;
  auto line = [&](const std::string& label, const std::string& value) {
    const std::string key = label + ":";
    text += std::string(
        static_cast<std::size_t>(std::max(0, kLabelWidth - static_cast<int>(key.size()))), ' ');
    text += key + " " + value + "\n";
  };
  auto count_with_share = [&](std::size_t count, std::size_t total) {
    std::string value = std::to_string(count);
    if (count > 0 && total > 0) {
      char share[32];
      std::snprintf(share, sizeof share, " (%.1f%%)",
                    100.0 * static_cast<double>(count) / static_cast<double>(total));
      value += share;
    }
    return value;
  };
  auto vec = [](const Vec3& p) {
    return format_number(p.x) + " " + format_number(p.y) + " " + format_number(p.z);
  };

  line("vertices", std::to_string(report.vertices));
  line("faces", std::to_string(report.faces));
  line("edges", std::to_string(report.edges));
  line("isolated vertices", std::to_string(report.isolated_vertices));
  line("boundary edges", std::to_string(report.boundary_edges));
  line("boundary loops", std::to_string(report.boundary_loops));
  line("components", std::to_string(report.components));
  // One genus per component, in order of each component's lowest face; long lists are cut.
  std::string genus;
  constexpr std::size_t kMaxListed = 20;
  for (std::size_t c = 0; c < report.genus_per_component.size() && c < kMaxListed; ++c) {
    if (c > 0) genus += ' ';
    genus += std::to_string(report.genus_per_component[c]);
  }
  if (report.genus_per_component.size() > kMaxListed) {
    genus += " ... (" + std::to_string(report.genus_per_component.size() - kMaxListed) + " more)";
  }
  line("genus", genus);
  line("degenerate faces", count_with_share(report.degenerate_faces, report.faces));
  line("thin faces", count_with_share(report.thin_faces, report.faces));
  line("obtuse faces", count_with_share(report.obtuse_faces, report.faces));
  line("saddle vertices", count_with_share(report.saddle_vertices, report.vertices));
  line("bbox min", vec(report.bbox_min));
  line("bbox max", vec(report.bbox_max));
  line("bbox size", vec(report.bbox_max - report.bbox_min));
  line("edge length", "mean " + format_number(report.mean_edge_length) + ", min " +
                          format_number(report.min_edge_length) + ", max " +
                          format_number(report.max_edge_length));
  line("total area", format_number(report.total_area));
  line("Lo quality", "mean " + format_number(report.lo_quality_mean) + ", min " +
                         format_number(report.lo_quality_min) + " (equilateral 0.1443)");
  return text;
}

}  // namespace geoprox
