// Discrete exponential map (geodesic polar coordinates) around a surface point: "Lightweight
// preprocessing and fast query of geodesic distance via proximity graph", §6.1 (the map from
// graph distances and path directions, compared there with the exact one; decals as in Schmidt,
// Grimm & Wyvill, "Interactive decal compositing with discrete exponential maps", 2006).
//
// For a source s and a radius R, every vertex v with geodesic distance d(s, v) <= R gets polar
// coordinates (d, theta), theta being the angle of the shortest path's start direction in the
// tangent frame of s, and (u, v) = (d cos theta, d sin theta).
//
// Tangent frame of s (all frames are intrinsic, so they follow a Riemannian metric):
//  - a point inside a face: the face's frame (origin at corner 0, x towards corner 1, y towards
//    corner 2's side; see IntrinsicGeometry);
//  - a point on an edge: the frame of the face of the edge's first halfedge (the other face's
//    directions are unfolded into it across the edge);
//  - a vertex: the one-ring unfolded around it. Angle 0 is the direction of the first outgoing
//    halfedge of the fan (for a boundary vertex, the boundary edge whose face lies
//    counter-clockwise of it; for an interior vertex, outgoing_halfedges(v)[0]), the corner
//    angles follow counter-clockwise, and at an interior vertex they are scaled by 2 pi / Theta
//    (Theta = the vertex's angle sum) so that the fan closes; at a boundary vertex they are not
//    scaled (theta runs over [0, Theta]).
// A face point with one (two) zero barycentrics is the edge (vertex) point it lies on.
//
// Modes:
//  - Exact: one exact solve bounded by R; theta from each vertex's exact path.
//  - Graph: d is the graph's distance field (GeodesicQuery::field, §3.2: exact within the link
//    radius rho, graph distances beyond it). Within rho, theta comes from the exact solve bounded
//    by rho that links s to the graph. Beyond rho, theta is the start direction of the graph path
//    to v: s links to every sample within rho, a Dijkstra over the samples (labels d(s, i) + graph
//    edges) carries each sample's first path sample (its root), v takes the root of its best
//    covering sample (label + cover distance), and the path leaves s along the exact link
//    geodesic to that root (or, when s is a sample itself, along the graph edge's stored
//    direction). Cost: the field, one bounded exact solve, one Dijkstra over the samples and one
//    pass over the cover rows; one exact path backtrace per vertex within rho and per root.
//    The first sample is at most rho away, so theta errs by about the lateral offset of that
//    sample from the true geodesic over rho (docs/applications.md has measured figures).
#pragma once

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/query/geodesic_query.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

enum class ExponentialMapMode : std::uint8_t {
  Graph = 0,  ///< graph distances and path directions (needs a GeodesicQuery)
  Exact = 1,  ///< exact solver (the reference)
};

struct ExponentialMapOptions {
  /// Vertices with d(s, v) <= radius are mapped (mesh units, or metric units under a metric).
  /// Must be >= 0; infinity maps the whole component.
  double radius = kInfinity;
  ExponentialMapMode mode = ExponentialMapMode::Graph;
  /// Polled by the exact solve and the graph search; throws Interrupted. Not owned.
  const QueryInterrupt* interrupt = nullptr;
};

struct ExponentialMapVertex {
  std::uint32_t vertex = 0;
  double distance = 0;  ///< d(s, v)
  double angle = 0;     ///< theta in radians, in [0, 2 pi) (a boundary vertex source: [0, Theta])
  double u = 0, v = 0;  ///< d cos(theta), d sin(theta)
};

struct ExponentialMapResult {
  /// The source as used (a face point on an edge or at a corner is that edge or vertex point).
  SurfacePoint source;
  /// Every vertex within the radius, in increasing vertex id.
  std::vector<ExponentialMapVertex> vertices;
};

/// The source's tangent frame (see the file comment), built once per source.
class TangentFrame {
 public:
  TangentFrame(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
               const SurfacePoint& source);
  /// Polar angle of a unit direction at the source, given in the frame of a face containing
  /// the source (as GeodesicPath::direction_at_source). Throws InvalidInput ("BadDirection")
  /// for a face that does not contain the source.
  double angle(const FaceDirection& direction) const;
  const SurfacePoint& source() const { return source_; }

 private:
  const TriangleMesh* mesh_;
  const IntrinsicGeometry* geometry_;
  SurfacePoint source_;
  std::uint32_t face_ = 0;  ///< reference face (face and edge sources)
  // Vertex sources: the fan's outgoing halfedges counter-clockwise and the angle at which each
  // corner starts (unscaled), and the scale 2 pi / Theta (1 on the boundary).
  std::vector<std::uint32_t> fan_;
  std::vector<double> fan_start_;
  double scale_ = 1;
};

/// A face point on an edge or at a corner as that edge or vertex point, an edge point at t = 0
/// or 1 as its vertex, barycentrics off the simplex beyond rounding divided by their sum; other
/// points unchanged. Validates the point (InvalidInput).
SurfacePoint canonical_surface_point(const TriangleMesh& mesh, const SurfacePoint& point);

class ExponentialMap {
 public:
  using Options = ExponentialMapOptions;

  /// Both modes; `query` (and what it points to) must outlive this object. Over a graph built on
  /// a refinement (GeodesicQuery::refined), the map is computed on the refined mesh and given
  /// on the query's mesh: its vertices, and angles in its frames.
  explicit ExponentialMap(const GeodesicQuery& query);
  /// Exact mode only (Graph throws InvalidInput "NoGraph").
  ExponentialMap(const TriangleMesh& mesh, const IntrinsicGeometry& geometry);
  ~ExponentialMap();

  /// Throws InvalidInput: the source's reasons (SurfacePoint::validate, IsolatedVertex),
  /// BadRadius (negative or NaN), NoGraph, NoCoverTable (graph mode on an imported graph).
  ExponentialMapResult compute(const SurfacePoint& source, const Options& options);

 private:
  ExponentialMapResult compute_exact(const SurfacePoint& source, const TangentFrame& frame,
                                     const Options& options);
  ExponentialMapResult compute_graph(const SurfacePoint& source, const TangentFrame& frame,
                                     const Options& options);
  /// Graph labels out to `radius` from the samples that solver_'s solve reached within rho,
  /// with each sample's root (see root_) and the graph edge of a zero-distance root.
  void label_samples(double rho, double radius, const QueryInterrupt* interrupt);

  /// The source on the mesh computed on, and the angle that mesh's frame at it gives the
  /// direction the given mesh's frame calls 0 (0 without a refinement).
  std::pair<SurfacePoint, double> on_computed_mesh(const SurfacePoint& source) const;

  /// Over a refinement: a query on the refined mesh (the graph's own), and the map to the
  /// query's mesh; null otherwise. Declared first: the members below point into them.
  std::unique_ptr<GeodesicQuery> refined_query_;
  const RefinedSurface* refined_ = nullptr;
  const IntrinsicGeometry* given_geometry_ = nullptr;  ///< the query's mesh's
  const TriangleMesh* mesh_;  ///< the mesh computed on
  const IntrinsicGeometry* geometry_;
  const GeodesicQuery* query_ = nullptr;
  std::unique_ptr<QueryScratch> scratch_;  ///< for the distance field (graph mode)
  ExactGeodesicSolver solver_;
  std::unique_ptr<ExactGeodesicSolver> fallback_;  ///< for unknown stored directions
  std::vector<double> exact_;  ///< graph mode: exact distance per vertex inside rho, else inf
  // Graph search buffers, one entry per sample.
  std::vector<double> label_;
  std::vector<std::int32_t> root_;       ///< first sample of the path at positive distance, or -1
  std::vector<std::int32_t> root_edge_;  ///< graph edge leaving a zero-distance sample, or -1
  std::vector<double> root_angle_;       ///< cached start angle per root sample (NaN: not yet)
};

/// One-shot, either mode (graph mode needs `query`).
ExponentialMapResult exponential_map(const GeodesicQuery& query, const SurfacePoint& source,
                                     const ExponentialMapOptions& options = {});
/// One-shot exact map.
ExponentialMapResult exact_exponential_map(const TriangleMesh& mesh,
                                           const IntrinsicGeometry& geometry,
                                           const SurfacePoint& source, double radius);

}  // namespace geoprox
