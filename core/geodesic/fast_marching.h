// Fast marching on triangle meshes: Kimmel & Sethian, "Computing geodesic paths on manifolds",
// PNAS 95(15):8431-8435, 1998, on the intrinsic edge lengths.
//
// Vertex-based: vertices are accepted in increasing order of distance from a heap of trial
// vertices. When a vertex is accepted, every unaccepted corner C of its faces is updated:
//  - from a face whose two other corners P, Q are known, by the planar wavefront through them
//    (the 2D eikonal |grad T| = 1 on the face's linear interpolant), kept only if causal: the
//    upwind direction lies inside the angle at C, and T(C) >= T(P), T(Q) (it comes from within
//    90 degrees of both CP and CQ, which an acute angle implies; at an obtuse corner this keeps
//    the scheme monotone);
//  - always by the edge (Dijkstra) value d(a) + |ab|, the fallback when no update is causal.
// An obtuse corner C of face (C, X, Y) gets no causal update from fronts arriving outside its
// acute section (the directions within 90 degrees of both CX and CY): the far side is downwind.
// Following Kimmel & Sethian the face is split: the faces beyond XY are unfolded into C's plane,
// one at a time along the section, until an unfolded vertex D lies in the section; C is then
// updated from the virtual faces (C, X, D) and (C, D, Y) instead of (C, X, Y), and by d(D) +
// |CD| (the straight segment CD runs inside the unfolded strip, a real path like an edge). The
// split depends only on the edge lengths and is found once per corner, unfolding at most
// Options::max_unfold_steps faces; when none is found (boundary, too many steps) the corner
// keeps the plain update. A flat corner (about 180 degrees: zero-area faces, extreme caps) has a
// section too thin to hit and no plain update at all: it is split by the first vertex beyond XY.
//
// Values are first-order accurate (error O(h) in the edge length h); a planar front is
// reproduced exactly; a vertex source's neighbours get exactly their edge length. Nothing is
// ever NaN: degenerate faces, zero-length edges, needles and caps fall back to edge updates.
//
// Reads only IntrinsicGeometry (edge lengths, face layouts and areas), never positions.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/geodesic/geodesic_types.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

struct FastMarchingOptions {
  /// Stop once the front passes this geodesic distance from the sources (mesh units): vertices
  /// farther away stay at kInfinity; those within get exactly the values of a full solve.
  double max_distance = kInfinity;
  /// Faces unfolded at most, per obtuse corner, to find the vertex that splits the angle into
  /// two acute ones (see above). 0 disables the splitting: obtuse corners use the plain update.
  /// The splitting table is rebuilt (one pass over the faces) when this changes between solves.
  int max_unfold_steps = 12;
  /// lower() only: rings of not-lowered vertices around the lowered region whose values are
  /// computed (as neighbours for the updates of lowered ones, never written). The fresh field
  /// at a lowered vertex can depend on such vertices where the new front meets the old one at a
  /// grazing angle. With 3 rings the lowered field equals min(distances, fresh solve) bit for
  /// bit in the tests, and on large meshes a few values stay higher by a tiny fraction of the
  /// covering radius; 1 ring is cheaper but leaves values noticeably higher.
  int lower_halo_rings = 3;
};

struct FastMarchingStats {
  std::size_t vertices_settled = 0;  ///< vertices accepted (lower(): those it lowered)
  std::size_t heap_pushes = 0;       ///< entries pushed on the trial heap (with stale ones)
  std::size_t triangle_updates = 0;  ///< causal planar-front updates computed
  std::size_t unfolded_updates = 0;  ///< of which through a virtual (unfolded) face
  /// Of the splitting table for the current max_unfold_steps (mesh properties, not per solve):
  std::size_t obtuse_corners = 0;    ///< corners above 90 degrees (zero-area faces included)
  std::size_t unsplit_corners = 0;   ///< of which no acute split was found for
};

class FastMarchingSolver {
 public:
  using Options = FastMarchingOptions;

  /// Both must outlive the solver, which only reads them (many solvers may share one mesh).
  FastMarchingSolver(const TriangleMesh& mesh, const IntrinsicGeometry& geometry);

  /// Runs one solve, reusing the buffers of the previous ones (they only grow, so after warm-up
  /// a solve allocates nothing) and costing time proportional to the vertices it reaches, not
  /// to the mesh (the splitting table aside, rebuilt only when max_unfold_steps changes, O(F)).
  /// Vertex sources start at their offset; edge and face sources give the corners of their
  /// face(s) the offset plus the exact Euclidean distance within the face (in the face's
  /// layout); several sources race, each vertex keeping the first front to reach it (so the
  /// field is the minimum of the single fields except where two fronts meet inside a face: a
  /// face with a corner from each gets a planar update mixing both, a little below either).
  /// Throws InvalidInput for an invalid source point,
  /// a negative or non-finite offset (BadOffset), a negative or NaN max_distance (BadRadius), a
  /// negative max_unfold_steps (BadUnfoldSteps) or lower_halo_rings outside [1, 254]
  /// (BadHaloRings).
  void solve(std::span<const GeodesicSource> sources, const Options& options = {});
  void solve(const SurfacePoint& source, const Options& options = {});

  /// Distance of vertex v from the last solve's sources; kInfinity if unreached or beyond
  /// max_distance. After lower(): the new source's distance at the vertices it lowered.
  double distance(std::uint32_t v) const;
  /// Every vertex's distance(), in vertex order.
  std::vector<double> vertex_distances() const;

  /// Farthest-point sampling's incremental update: lowers the caller's `distances` (one per
  /// vertex) with the fast-marching field of `source`, visiting only the vertices where that
  /// field is smaller, plus options.lower_halo_rings rings around them whose values it computes
  /// but does not write. Returns the number of vertices lowered; lowered_vertices() lists them.
  ///
  /// Guaranteed: entries are only lowered, never raised, and untouched entries keep their bits;
  /// every value written is below the old one and is a fast-marching update of this source's
  /// front from neighbours known in this run. The result is min(distances, fresh solve from
  /// source) exactly when the fresh field at each lowered vertex depends on no vertex beyond the
  /// halo (see FastMarchingOptions::lower_halo_rings); otherwise a few vertices at the border of
  /// the lowered region keep a higher value (never above the old one). The tests check bitwise
  /// equality on a grid and on a sample mesh; the benchmark counts differences on larger meshes.
  /// Throws InvalidInput for an invalid source, bad options, or (BadDistanceCount) if
  /// distances.size() != number of vertices. NaN entries count as larger than any distance.
  std::size_t lower(std::span<double> distances, const SurfacePoint& source,
                    const Options& options = {});
  /// The vertices the last lower() changed, in the order it accepted them.
  std::span<const std::uint32_t> lowered_vertices() const { return lowered_; }

  const FastMarchingStats& stats() const { return stats_; }
  const TriangleMesh& mesh() const { return *mesh_; }
  const IntrinsicGeometry& geometry() const { return *geometry_; }

 private:
  // Per-vertex scratch of one solve, valid when stamp == generation_ (16 bytes).
  struct VertexState {
    double distance;
    std::uint32_t stamp;
    std::uint8_t state;  // kTrial, kAccepted or kBlocked (lower(): known but not lowered)
    std::uint8_t depth;  // lower(): steps from the lowered region through blocked vertices
  };
  struct HeapEntry {
    std::uint64_t key;  ///< bits of the (non-negative) distance: ordered like the doubles
    std::uint32_t vertex;
  };
  // A (possibly virtual) face seen from the corner C being updated, with known corners P and Q:
  // squared lengths |CP|^2, |CQ|^2, |PQ|^2, m = CP.CQ and det = (CP x CQ)^2 = (2 area)^2.
  struct CornerFace {
    double cp2, cq2, pq2, m, det;
  };
  // One face (v, a, b) around vertex v, everything accepting v needs without touching the mesh
  // (the fans are v's outgoing halfedges, in the mesh's order). det < 0 marks an edge-only slot:
  // the boundary edge b->v whose far vertex no outgoing halfedge of v reaches.
  struct FanSlot {
    double len_va, len_vb, len_ab;
    double det;  ///< (2 area)^2, 0 for degenerate faces
    std::uint32_t a, b;
    std::int32_t split_a, split_b;  ///< split of the corner at a / at b, or -1
  };
  // The vertex D that splits the obtuse corner C of face (C, X, Y), in the corner's frame: C at
  // the origin, X = (x_length, 0), Y = y_at, D = d_at as unfolded. One cache line.
  struct alignas(64) Split {
    double x_length;
    Vec2 y_at, d_at;
    double cd;  ///< |CD|
    std::uint32_t c, x, y, d;
    CornerFace face_xd() const;  ///< the virtual face (C, X, D), P = X, Q = D
    CornerFace face_dy() const;  ///< the virtual face (C, D, Y), P = D, Q = Y
  };

  void validate(const Options& options) const;
  void build_fans();
  void build_splits(int max_unfold_steps);
  bool find_split(std::uint32_t corner, int max_steps, bool flat, Split& split) const;
  void reset();
  void add_source(const GeodesicSource& source);
  void run(const Options& options, double* floor);
  void accept_neighbours(std::uint32_t v, double dv, std::uint8_t depth);
  double split_update(const Split& split, std::uint32_t known, double known_distance);
  double planar_update(double dp, double dq, const CornerFace& face);
  void relax(std::uint32_t v, double distance, std::uint8_t depth);
  void heap_push(double key, std::uint32_t vertex);
  bool heap_refill();
  bool is_open(std::uint32_t v) const {
    return state_[v].stamp != generation_ || state_[v].state == kTrial;
  }
  bool is_known(std::uint32_t v) const { return !is_open(v); }

  static constexpr std::uint8_t kTrial = 0, kAccepted = 1, kBlocked = 2;

  const TriangleMesh* mesh_;
  const IntrinsicGeometry* geometry_;

  // Fans: CSR by vertex.
  std::vector<std::uint32_t> fan_offsets_;
  std::vector<FanSlot> fan_;
  std::vector<std::uint32_t> halfedge_slot_;  ///< slot of outgoing halfedge h in its origin's fan

  // Splitting table, rebuilt when max_unfold_steps changes.
  int split_steps_ = -1;
  std::vector<Split> splits_;
  std::vector<std::uint32_t> split_offsets_;  ///< CSR by split vertex D ...
  std::vector<std::uint32_t> splits_by_d_;     ///< ... of the splits it makes

  std::uint32_t generation_ = 0;
  std::vector<VertexState> state_;
  // Trial vertices in a radix heap (Ahuja, Mehlhorn, Orlin & Tarjan 1990): fast marching pushes
  // no key below the last one popped, so entry e waits in bucket "highest bit in which e.key
  // differs from heap_last_"; bucket 0 holds keys equal to heap_last_, popped first. Stale
  // entries (a vertex pushed again with a lower key) are skipped when popped.
  std::array<std::vector<HeapEntry>, 65> buckets_;
  std::uint64_t heap_last_ = 0;
  double current_key_ = 0;
  std::uint8_t halo_depth_ =
      255;  ///< relax() touches no new vertex deeper than this  ///< distance of the vertex being
            ///< accepted (pushes never go below)
  std::vector<std::uint32_t> lowered_;
  FastMarchingStats stats_;
};

/// One-shot: fast-marching distance of every vertex from the sources (kInfinity where
/// unreachable or beyond options.max_distance).
std::vector<double> fast_marching_distances(const TriangleMesh& mesh,
                                            const IntrinsicGeometry& geometry,
                                            std::span<const GeodesicSource> sources,
                                            const FastMarchingOptions& options = {});

}  // namespace geoprox
