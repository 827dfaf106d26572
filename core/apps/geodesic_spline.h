// Spline curves on surfaces by geodesic interpolation: "Lightweight preprocessing and fast query
// of geodesic distance via proximity graph", §6.2, after Nava-Yazdani & Polthier's geodesic de
// Casteljau construction ("De Casteljau's algorithm on manifolds", CAGD 30(7), 2013): every
// affine combination (1 - u) A + u B of the planar algorithm becomes the point at fraction u of
// the arc length along the shortest geodesic from A to B.
//
//  - Bezier: cubic, by de Casteljau. 3k + 1 control points make k cubic pieces joined at every
//    third control point (which the curve interpolates, like the first and the last).
//  - BSpline: uniform cubic B-spline, by de Boor (integer knots). n >= 4 control points make
//    n - 3 pieces; piece i, parameter t in [0, 1], uses control points i..i+3:
//      Q_j = lerp(P_{i+j-1}, P_{i+j}, (t + 3 - j) / 3) for j = 1..3,
//      R_1 = lerp(Q_1, Q_2, (t + 1) / 2), R_2 = lerp(Q_2, Q_3, t / 2), C(t) = lerp(R_1, R_2, t).
// The first level of both runs along the control polygon, whose geodesics are computed once and
// returned; every sample then needs 3 more geodesics (levels 2 and 3).
//
// Geodesics are exact in both modes, which differ in what bounds the solve. The exact mode runs
// the exact solver from A until B is settled (goal-directed at B under the mesh's own lengths).
// The graph mode bounds that solve by the graph's answer for the pair (GeodesicQuery::
// exact_path), so that it explores a thin ellipse around the geodesic instead of a disk; a pair
// closer in space than the link radius rho skips the graph query. A graph path is not used as
// the geodesic: its length is off by a fraction of a percent, but its points stray from the
// geodesic by about the square root of that, and the spline takes points along its
// geodesics.
// Curve points are independent once the control polygon is known: Options::threads spreads
// them over OpenMP threads, each with its own scratch.
// The point at fraction u is found on the path polyline by intrinsic arc length (segment lengths
// in the faces' intrinsic frames, so a Riemannian metric is honoured) and returned as a face,
// edge or vertex point.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "core/base/errors.h"
#include "core/geodesic/geodesic_types.h"
#include "core/query/geodesic_query.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

enum class SplineType : std::uint8_t {
  Bezier = 0,   ///< cubic Bezier pieces (3k + 1 control points)
  BSpline = 1,  ///< uniform cubic B-spline (>= 4 control points)
};

enum class SplineGeodesics : std::uint8_t {
  Graph = 0,  ///< exact geodesics bounded by the graph's answers (GeodesicQuery::exact_path)
  Exact = 1,  ///< exact solver, stopped once the target is settled
};

struct GeodesicSplineOptions {
  SplineType type = SplineType::Bezier;
  /// Curve points, spread uniformly over the spline parameter, both ends included (>= 2).
  std::uint32_t samples = 100;
  SplineGeodesics geodesics = SplineGeodesics::Graph;
  /// Polled between geodesics (and inside them); throws Interrupted. Not owned.
  const QueryInterrupt* interrupt = nullptr;
  /// OpenMP threads over the curve points; 0 uses OpenMP's default, 1 runs inline (what the
  /// daemon uses: one request per compute thread). Each thread beyond the first costs one
  /// query scratch and one exact solver, made on first use and kept by the GeodesicSpline.
  int threads = 1;
};

struct GeodesicSplineResult {
  /// The curve, in order: surface points and their positions.
  std::vector<PathPoint> curve;
  /// The control polygon: the geodesic from control point i to i + 1, for each i.
  std::vector<std::vector<PathPoint>> control_polygon;
  /// Geodesics computed (control polygon included).
  std::uint32_t geodesics = 0;
};

/// The point at fraction u in [0, 1] of the arc length of a path polyline (consecutive points
/// in one face, as every path of geoprox), measured with the intrinsic lengths of `geometry`.
/// u = 0 and 1 give the path's ends exactly. Throws InvalidInput ("BadPath") for an empty
/// polyline or one whose consecutive points share no face.
SurfacePoint point_along_path(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                              std::span<const PathPoint> path, double u);

class GeodesicSpline {
 public:
  using Options = GeodesicSplineOptions;

  /// Graph or exact geodesics; `query` (and what it points to) must outlive this object.
  explicit GeodesicSpline(const GeodesicQuery& query);
  /// Exact geodesics only (Graph throws InvalidInput "NoGraph").
  GeodesicSpline(const TriangleMesh& mesh, const IntrinsicGeometry& geometry);
  ~GeodesicSpline();

  /// Throws InvalidInput: the control points' reasons (SurfacePoint::validate, IsolatedVertex),
  /// BadControlPoints (a Bezier needs 3k + 1 >= 4 points, a B-spline >= 4), BadSamples (< 2),
  /// NoGraph; Unreachable when two consecutive control points lie in different components.
  GeodesicSplineResult compute(std::span<const SurfacePoint> control, const Options& options);

 private:
  struct Worker;  // one thread's scratch
  std::vector<PathPoint> geodesic(const SurfacePoint& a, const SurfacePoint& b,
                                  const Options& options, Worker& worker) const;
  SurfacePoint lerp(const SurfacePoint& a, const SurfacePoint& b, double u,
                    const Options& options, Worker& worker) const;
  SurfacePoint curve_point(const GeodesicSplineResult& out, std::size_t pieces, std::uint32_t k,
                           const Options& options, Worker& worker) const;

  const TriangleMesh* mesh_;
  const IntrinsicGeometry* geometry_;
  const GeodesicQuery* query_ = nullptr;
  std::vector<std::unique_ptr<Worker>> workers_;  // [0] made by the constructor
};

/// One-shot.
GeodesicSplineResult geodesic_spline(const GeodesicQuery& query,
                                     std::span<const SurfacePoint> control,
                                     const GeodesicSplineOptions& options = {});

}  // namespace geoprox
