// Intrinsic geometry of a triangle mesh: edge lengths and what derives from them (no paper; the
// "intrinsic triangulation" view of Sharp, Soliman & Crane 2019 in its simplest form).
//
// Every geodesic solver in geoprox reads lengths from here and never positions, so a Riemannian
// metric (other edge lengths) changes nothing in the solvers (a goal-directed exact solve bounds
// distances by straight lines, only when lengths_are_chords()). For each halfedge h = a->b of face
// (a, b, c) the face is laid out in h's frame: a = (0, 0), b = (L, 0), c = (cx, cy) with cy >= 0.
// The frame of face f is the frame of its halfedge 3f (origin at its corner 0).
#pragma once

#include <cstdint>
#include <vector>

#include "core/mesh/mesh.h"

namespace geoprox {

struct HalfedgeLayout {
  double length = 0;  ///< |ab| in mesh units
  double cx = 0;      ///< opposite corner c in the frame of h
  double cy = 0;      ///< >= 0; 0 for a degenerate (zero-area) face
};

/// What an exact solver reads to carry a window across the face of halfedge h = a->b (face
/// (a, b, c)), in 48 bytes: h's layout, the face's corners, and the halfedges a window leaves
/// into. Solves wait on memory more than on arithmetic; with these gathered, crossing a face
/// reads about one cache line instead of three (layout, twin and face arrays). The other two
/// edges' lengths are left out: they are in the layouts of the halfedges a window moves on to.
struct alignas(16) HalfedgeCrossing {
  HalfedgeLayout layout;
  std::uint32_t origin = 0, target = 0, opposite = 0;  ///< a, b, c
  /// twin(prev(h)): the halfedge a window leaving through edge c-a enters; -1 on a boundary or
  /// when c-a is short (no window goes through it).
  std::int32_t twin_prev = -1;
  /// twin(next(h)): the halfedge a window leaving through edge b-c enters; -1 on a boundary or
  /// when b-c is short.
  std::int32_t twin_next = -1;
  /// Which sides of the face are short edges (tuning::kShortEdgeRatio):
  /// kShortSide (a-b, h's own), kShortPrev (c-a), kShortNext (b-c).
  std::uint32_t short_sides = 0;
  static constexpr std::uint32_t kShortSide = 1, kShortPrev = 2, kShortNext = 4;
};
static_assert(sizeof(HalfedgeCrossing) == 48);

struct Vec2 {
  double x = 0, y = 0;
};

struct IntrinsicGeometryOptions {
  /// Faces whose area is below this fraction of (mean edge length)^2 count as degenerate: their
  /// corners become pseudo-sources, so exact solvers route through them instead of unfolding.
  double degenerate_area_ratio = 1e-14;
  /// Faces whose height over their longest side is below this fraction of that side count as
  /// thin: their layouts, and the angles and windows derived from them, are good only to a
  /// few digits, and a straight path grazing along them can be lost or bent. Their corners
  /// become pseudo-sources emitting in every direction, like those of zero-area faces: the
  /// paths through them are real, so exactness is unaffected and solves on such meshes only
  /// create more windows. The ratio is far below the faces of real scanned or modelled meshes,
  /// so that only slivers pay for it.
  double thin_face_ratio = 1e-5;
};

class IntrinsicGeometry {
 public:
  using Options = IntrinsicGeometryOptions;


  /// Lengths from the mesh's vertex positions, and the layouts from them too: a face's area
  /// (so each layout's height) from a cross product, and where its third corner projects onto
  /// each side from a dot product. They resolve a sliver to the roundoff of its sides, where
  /// the rounded lengths alone leave its height uncertain by about the square root of that
  /// roundoff (a zero-area face would get a height well above rounding).
  explicit IntrinsicGeometry(const TriangleMesh& mesh, const Options& options = {});
  /// Explicit per-edge lengths (edge ids of `mesh`): a Riemannian metric. Layouts from the
  /// lengths (areas by Heron's formula), unless every length is the positions' chord to the
  /// last bit (a graph file's copy of the lengths): then as above, so that both constructors
  /// give the same geometry. Throws MeshError (BadEdgeLength, TriangleInequality) naming the
  /// edge or face.
  IntrinsicGeometry(const TriangleMesh& mesh, std::vector<double> edge_lengths,
                    const Options& options = {});

  /// The mesh must outlive this object.
  const TriangleMesh& mesh() const { return *mesh_; }
  double edge_length(std::uint32_t e) const { return edge_length_[e]; }
  const std::vector<double>& edge_lengths() const { return edge_length_; }
  const HalfedgeLayout& layout(std::uint32_t h) const { return crossing_[h].layout; }
  const HalfedgeCrossing& crossing(std::uint32_t h) const { return crossing_[h]; }
  double angle_sum(std::uint32_t v) const { return angle_sum_[v]; }
  /// Interior angle of h's face at h's origin (radians).
  double corner_angle(std::uint32_t h) const { return corner_angle_[h]; }
  double face_area(std::uint32_t f) const { return face_area_[f]; }
  double mean_edge_length() const { return mean_edge_length_; }
  /// Every edge length is the chord between its vertices' positions (to 1e-12 relative): the
  /// embedding's own metric, under which a straight line never exceeds a geodesic, so solvers
  /// and searches may use straight-line distances as lower bounds. False under another metric.
  bool lengths_are_chords() const { return lengths_are_chords_; }
  /// Vertices through which a shortest path can bend: saddles (angle sum > 2 pi), boundary
  /// vertices and corners of degenerate or thin faces.
  bool is_pseudo_source(std::uint32_t v) const { return pseudo_source_[v] != 0; }
  /// Zero-area (below Options::degenerate_area_ratio): no usable frame.
  bool is_degenerate_face(std::uint32_t f) const { return degenerate_face_[f] != 0; }
  /// Not zero-area, but thinner than Options::thin_face_ratio.
  bool is_thin_face(std::uint32_t f) const { return thin_face_[f] != 0; }
  /// A corner of some degenerate or thin face, or of a face with a short side: angles there are
  /// unreliable, so solvers treat it as a pseudo-source emitting in every direction.
  bool is_degenerate_vertex(std::uint32_t v) const { return degenerate_vertex_[v] != 0; }
  /// Cache hints: what a solver reads about vertex v (angle sum, degenerate flag) or about the
  /// corner at h's origin when v emits windows as a pseudo-source.
  void prefetch_vertex(std::uint32_t v) const {
    __builtin_prefetch(&angle_sum_[v]);
    __builtin_prefetch(&degenerate_vertex_[v]);
  }
  void prefetch_corner_angle(std::uint32_t h) const { __builtin_prefetch(&corner_angle_[h]); }

  /// Corner `corner` (0..2) of face f in the face's frame.
  Vec2 face_corner(std::uint32_t f, int corner) const;
  /// Barycentrics of face f -> point in the face's frame.
  Vec2 face_point(std::uint32_t f, const double bary[3]) const;

 private:
  void build(const Options& options);

  const TriangleMesh* mesh_;
  std::vector<double> edge_length_;
  std::vector<HalfedgeCrossing> crossing_;  ///< per halfedge, with its layout
  std::vector<double> angle_sum_;
  std::vector<double> corner_angle_;
  std::vector<double> face_area_;
  std::vector<std::uint8_t> pseudo_source_;
  std::vector<std::uint8_t> degenerate_face_;
  std::vector<std::uint8_t> thin_face_;
  std::vector<std::uint8_t> degenerate_vertex_;
  double mean_edge_length_ = 0;
  bool lengths_are_chords_ = false;
};

}  // namespace geoprox
