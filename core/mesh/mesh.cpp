#include "core/mesh/mesh.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/base/errors.h"

namespace geoprox {

namespace {

std::string describe_face(std::uint32_t f, const Triangle& t) {
  return "face " + std::to_string(f) + " (vertices " + std::to_string(t[0]) + " " +
         std::to_string(t[1]) + " " + std::to_string(t[2]) + ")";
}

std::uint64_t directed_key(std::uint32_t from, std::uint32_t to) {
  return (static_cast<std::uint64_t>(from) << 32) | to;
}

/// Refuses what no mesh can be: no faces, too many, indices out of range or repeated in a
/// face, non-finite coordinates.
void check_faces_and_positions(const std::vector<Vec3>& positions,
                               const std::vector<Triangle>& faces) {
  if (faces.empty()) {
    throw MeshError(ErrorCode::EmptyMesh, "mesh has no faces (" + std::to_string(positions.size()) +
                                              " vertices, 0 triangles)");
  }
  if (faces.size() > TriangleMesh::kMaxFaces) {
    throw MeshError(ErrorCode::TooLarge, "mesh has " + std::to_string(faces.size()) +
                                             " faces; at most 2^30 are supported");
  }
  const auto nv = static_cast<std::uint32_t>(positions.size());
  for (std::uint32_t f = 0; f < faces.size(); ++f) {
    const Triangle& t = faces[f];
    for (std::uint32_t v : t) {
      if (v >= nv) {
        throw MeshError(ErrorCode::VertexOutOfRange, describe_face(f, t) + " refers to vertex " +
                                                         std::to_string(v) + " but the mesh has " +
                                                         std::to_string(nv) + " vertices");
      }
    }
    if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) {
      throw MeshError(ErrorCode::DegenerateFaceIndices,
                      describe_face(f, t) + " repeats a vertex; a triangle needs 3 distinct ones");
    }
  }
  for (std::uint32_t v = 0; v < nv; ++v) {
    const Vec3& p = positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      throw MeshError(ErrorCode::NonFiniteCoordinate,
                      "vertex " + std::to_string(v) + " has a non-finite coordinate (" +
                          std::to_string(p.x) + ", " + std::to_string(p.y) + ", " +
                          std::to_string(p.z) + ")");
    }
  }
}

std::uint32_t origin_of(const std::vector<Triangle>& faces, std::uint32_t h) {
  return faces[h / 3][h % 3];
}
std::uint32_t target_of(const std::vector<Triangle>& faces, std::uint32_t h) {
  return faces[h / 3][(h % 3 + 1) % 3];
}

/// The twin of every halfedge (kNoHalfedge on the boundary); throws NonManifoldEdge or
/// InconsistentOrientation for a directed edge used twice.
std::vector<std::int32_t> link_twins(const std::vector<Triangle>& faces) {
  // Directed edges sorted by (origin, target): duplicates are complex edges or flipped faces.
  const std::size_t nh = 3 * faces.size();
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(nh);
  for (std::uint32_t h = 0; h < nh; ++h) {
    keyed[h] = {directed_key(origin_of(faces, h), target_of(faces, h)), h};
  }
  std::sort(keyed.begin(), keyed.end());
  for (std::size_t i = 1; i < nh; ++i) {
    if (keyed[i].first == keyed[i - 1].first) {
      const std::uint32_t first = std::min(keyed[i].second, keyed[i - 1].second) / 3;
      const std::uint32_t second = std::max(keyed[i].second, keyed[i - 1].second) / 3;
      const std::uint32_t h = keyed[i].second;
      // Exactly two faces on the edge, both running it the same way: a flipped face, not a
      // complex edge (the header documents InconsistentOrientation for this case).
      const auto halfedges_with_key = [&](std::uint64_t key) {
        return std::count_if(keyed.begin(), keyed.end(),
                             [key](const auto& entry) { return entry.first == key; });
      };
      if (halfedges_with_key(keyed[i].first) == 2 &&
          halfedges_with_key(directed_key(target_of(faces, h), origin_of(faces, h))) == 0) {
        throw MeshError(ErrorCode::InconsistentOrientation,
                        describe_face(second, faces[second]) + " runs the edge " +
                            std::to_string(origin_of(faces, h)) + "->" +
                            std::to_string(target_of(faces, h)) +
                            " in the same direction as face " + std::to_string(first) +
                            " (inconsistently oriented faces: flip one)");
      }
      throw MeshError(ErrorCode::NonManifoldEdge,
                      describe_face(second, faces[second]) + " uses the directed edge " +
                          std::to_string(origin_of(faces, h)) + "->" +
                          std::to_string(target_of(faces, h)) + " already used by face " +
                          std::to_string(first) +
                          " (an edge with more than two faces, or inconsistently oriented faces)");
    }
  }
  std::vector<std::int32_t> twins(nh, kNoHalfedge);
  for (std::uint32_t h = 0; h < nh; ++h) {
    const std::uint64_t key = directed_key(target_of(faces, h), origin_of(faces, h));
    auto it = std::lower_bound(keyed.begin(), keyed.end(),
                               std::pair<std::uint64_t, std::uint32_t>{key, 0});
    if (it != keyed.end() && it->first == key) twins[h] = static_cast<std::int32_t>(it->second);
  }
  return twins;
}

/// Which vertices are on the boundary; throws NonManifoldVertex unless each vertex's faces
/// form a single fan.
std::vector<std::uint8_t> check_single_fans(const TriangleMesh& mesh) {
  // Each vertex's faces must form a single fan (a disk or half-disk).
  const auto nv = static_cast<std::uint32_t>(mesh.num_vertices());
  std::vector<std::uint8_t> boundary(nv, 0);
  for (std::uint32_t v = 0; v < nv; ++v) {
    auto out = mesh.outgoing_halfedges(v);
    if (out.empty()) continue;
    std::uint32_t start = out[0];
    std::size_t open_ends = 0;
    for (std::uint32_t h : out) {
      if (mesh.twin(h) < 0) {
        if (open_ends == 0) start = h;
        ++open_ends;
      }
    }
    boundary[v] = open_ends > 0 ? 1 : 0;
    // Rotate counter-clockwise: the outgoing halfedge after h is twin(prev(h)).
    std::size_t visited = 0;
    std::uint32_t h = start;
    std::uint32_t lowest_face_in_fan = TriangleMesh::face_of(h);
    do {
      ++visited;
      lowest_face_in_fan = std::min(lowest_face_in_fan, TriangleMesh::face_of(h));
      const std::int32_t t = mesh.twin(TriangleMesh::prev(h));
      if (t < 0) break;
      h = static_cast<std::uint32_t>(t);
    } while (h != start && visited <= out.size());
    if (visited != out.size()) {
      // Name the lowest face that is not in the fan of the vertex's lowest face.
      std::vector<std::uint32_t> fan;
      h = start;
      std::size_t guard = 0;
      do {
        fan.push_back(TriangleMesh::face_of(h));
        const std::int32_t t = mesh.twin(TriangleMesh::prev(h));
        if (t < 0) break;
        h = static_cast<std::uint32_t>(t);
      } while (h != start && ++guard <= out.size());
      std::uint32_t offending = UINT32_MAX;
      for (std::uint32_t o : out) {
        if (std::find(fan.begin(), fan.end(), TriangleMesh::face_of(o)) == fan.end()) {
          offending = std::min(offending, TriangleMesh::face_of(o));
        }
      }
      if (lowest_face_in_fan > offending) std::swap(lowest_face_in_fan, offending);
      throw MeshError(ErrorCode::NonManifoldVertex,
                      describe_face(offending, mesh.face(offending)) + " meets vertex " +
                          std::to_string(v) + " in a separate fan from face " +
                          std::to_string(lowest_face_in_fan) +
                          " (non-manifold vertex: its faces do not form one disk)");
    }
  }
  return boundary;
}

}  // namespace

TriangleMesh::TriangleMesh(std::vector<Vec3> positions, std::vector<Triangle> faces)
    : positions_(std::move(positions)), faces_(std::move(faces)) {
  check_faces_and_positions(positions_, faces_);
  const auto nv = static_cast<std::uint32_t>(positions_.size());
  const std::size_t nh = 3 * faces_.size();
  twin_ = link_twins(faces_);

  halfedge_edge_.assign(nh, 0);
  edge_first_halfedge_.reserve(nh / 2 + 16);
  for (std::uint32_t h = 0; h < nh; ++h) {
    const std::int32_t t = twin_[h];
    if (t >= 0 && static_cast<std::uint32_t>(t) < h) {
      halfedge_edge_[h] = halfedge_edge_[static_cast<std::uint32_t>(t)];
    } else {
      halfedge_edge_[h] = static_cast<std::uint32_t>(edge_first_halfedge_.size());
      edge_first_halfedge_.push_back(h);
    }
  }

  vertex_offsets_.assign(nv + 1, 0);
  for (std::uint32_t h = 0; h < nh; ++h) ++vertex_offsets_[origin(h) + 1];
  for (std::uint32_t v = 0; v < nv; ++v) vertex_offsets_[v + 1] += vertex_offsets_[v];
  vertex_halfedges_.assign(nh, 0);
  {
    std::vector<std::uint32_t> fill(vertex_offsets_.begin(), vertex_offsets_.end() - 1);
    for (std::uint32_t h = 0; h < nh; ++h) vertex_halfedges_[fill[origin(h)]++] = h;
  }

  boundary_vertex_ = check_single_fans(*this);
}

Vec3 TriangleMesh::face_point(std::uint32_t f, const std::array<double, 3>& bary) const {
  const Triangle& t = faces_[f];
  return bary[0] * positions_[t[0]] + bary[1] * positions_[t[1]] + bary[2] * positions_[t[2]];
}

}  // namespace geoprox
