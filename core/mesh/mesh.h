// Triangle mesh connectivity and positions (no paper: the halfedge layout every solver reads).
//
// Ids are file order and never change: vertex v is the v-th vertex of the file, face f the f-th
// face. Halfedge h = 3*f + i runs from corner i of face f to corner (i+1)%3, so next/prev/face
// are arithmetic. Undirected edges are numbered in order of first appearance when walking the
// halfedges 0, 1, 2, ...; edge e runs from edge_origin(e) to edge_target(e), which are the
// origin and target of its first halfedge (the parameter t of an edge point goes from 0 at the
// origin to 1 at the target).
//
// A TriangleMesh is an oriented 2-manifold, possibly with boundary and several components:
// every directed edge appears at most once, every undirected edge has one or two faces, and the
// faces around each vertex form one fan. Construction refuses anything else with a MeshError
// naming the first offending face and its vertex ids. Vertices used by no face are kept (their
// ids stay valid) and are simply unreachable from everything else.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

namespace geoprox {

struct Vec3 {
  double x = 0, y = 0, z = 0;
};
inline Vec3 operator+(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(double s, const Vec3& a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }

using Triangle = std::array<std::uint32_t, 3>;
inline constexpr std::int32_t kNoHalfedge = -1;

class TriangleMesh {
 public:
  /// The most faces a mesh may have (its halfedge ids, 3 per face, then fit in 32 bits).
  static constexpr std::size_t kMaxFaces = std::size_t{1} << 30;

  /// Builds connectivity; throws MeshError (EmptyMesh, TooLarge, NonFiniteCoordinate,
  /// VertexOutOfRange, DegenerateFaceIndices, NonManifoldEdge, InconsistentOrientation,
  /// NonManifoldVertex).
  TriangleMesh(std::vector<Vec3> positions, std::vector<Triangle> faces);

  std::size_t num_vertices() const { return positions_.size(); }
  std::size_t num_faces() const { return faces_.size(); }
  std::size_t num_halfedges() const { return 3 * faces_.size(); }
  std::size_t num_edges() const { return edge_first_halfedge_.size(); }

  const std::vector<Vec3>& positions() const { return positions_; }
  const std::vector<Triangle>& faces() const { return faces_; }
  const Vec3& position(std::uint32_t v) const { return positions_[v]; }
  const Triangle& face(std::uint32_t f) const { return faces_[f]; }

  // Halfedge arithmetic.
  static std::uint32_t face_of(std::uint32_t h) { return h / 3; }
  static std::uint32_t next(std::uint32_t h) { return h - h % 3 + (h % 3 + 1) % 3; }
  static std::uint32_t prev(std::uint32_t h) { return h - h % 3 + (h % 3 + 2) % 3; }
  std::uint32_t origin(std::uint32_t h) const { return faces_[h / 3][h % 3]; }
  std::uint32_t target(std::uint32_t h) const { return faces_[h / 3][(h % 3 + 1) % 3]; }
  /// Vertex of the face of h that is not on h.
  std::uint32_t opposite_vertex(std::uint32_t h) const { return faces_[h / 3][(h % 3 + 2) % 3]; }
  /// The oppositely directed halfedge in the neighbouring face, or kNoHalfedge on the boundary.
  std::int32_t twin(std::uint32_t h) const { return twin_[h]; }
  std::uint32_t edge_of(std::uint32_t h) const { return halfedge_edge_[h]; }
  std::uint32_t edge_halfedge(std::uint32_t e) const { return edge_first_halfedge_[e]; }
  std::uint32_t edge_origin(std::uint32_t e) const { return origin(edge_first_halfedge_[e]); }
  std::uint32_t edge_target(std::uint32_t e) const { return target(edge_first_halfedge_[e]); }
  bool is_boundary_edge(std::uint32_t e) const { return twin_[edge_first_halfedge_[e]] < 0; }

  /// Halfedges leaving v (one per incident face corner), in no particular order.
  std::span<const std::uint32_t> outgoing_halfedges(std::uint32_t v) const {
    return {vertex_halfedges_.data() + vertex_offsets_[v],
            vertex_halfedges_.data() + vertex_offsets_[v + 1]};
  }
  bool is_boundary_vertex(std::uint32_t v) const { return boundary_vertex_[v] != 0; }
  /// Cache hints for a solver that will soon walk v's outgoing halfedges: the first starts
  /// loading where the list is kept (and v's boundary flag); the second, issued once that had
  /// time to arrive, the list itself. The list is found through the index, two dependent cold
  /// loads that nothing else a solver reads brings into cache.
  void prefetch_outgoing_index(std::uint32_t v) const {
    __builtin_prefetch(&vertex_offsets_[v]);
    __builtin_prefetch(&boundary_vertex_[v]);
  }
  void prefetch_outgoing_halfedges(std::uint32_t v) const {
    __builtin_prefetch(vertex_halfedges_.data() + vertex_offsets_[v]);
  }
  bool is_isolated_vertex(std::uint32_t v) const {
    return vertex_offsets_[v] == vertex_offsets_[v + 1];
  }

  /// Position of the point on halfedge-free barycentric coordinates of face f.
  Vec3 face_point(std::uint32_t f, const std::array<double, 3>& bary) const;

 private:
  std::vector<Vec3> positions_;
  std::vector<Triangle> faces_;
  std::vector<std::int32_t> twin_;
  std::vector<std::uint32_t> halfedge_edge_;
  std::vector<std::uint32_t> edge_first_halfedge_;
  std::vector<std::uint32_t> vertex_offsets_;
  std::vector<std::uint32_t> vertex_halfedges_;
  std::vector<std::uint8_t> boundary_vertex_;
};

}  // namespace geoprox
