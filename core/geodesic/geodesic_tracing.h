// Straightest geodesics: Polthier & Schmies, "Straightest geodesics on polyhedral surfaces",
// Mathematical Visualization 1998. Here only the part inside faces and across edges: a trace
// walks straight in a face and, at an edge, continues in the neighbouring face unfolded flat
// about that edge. It stops at a vertex rather than choosing a straightest continuation there
// (the caller then falls back to an exact solve), and at the boundary.
//
// Reads only IntrinsicGeometry (edge lengths, face layouts): positions are used only to report
// path points. To keep rounding from accumulating along long traces, every edge crossing is
// re-expressed as (edge, parameter t) and the direction relative to that edge, and the next face
// is rebuilt from those in its own frame; nothing is carried over as accumulated coordinates.
//
// Used by queries on the proximity graph ("Lightweight preprocessing and fast query of geodesic
// distance via proximity graph", §3 and Fig. 5) to turn the stored end directions of graph edges
// back into path polylines.
#pragma once

#include <cstdint>
#include <vector>

#include "core/geodesic/geodesic_types.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox {

struct GeodesicTraceOptions {
  /// A crossing closer than this to an edge's end (as a fraction of the edge length) counts as
  /// hitting the vertex.
  double vertex_tolerance = 1e-9;
  /// A trace that reaches an edge or a vertex within this fraction of the requested length of
  /// its end ends there (SurfacePoint::Kind::Edge or Vertex, TraceStop::Completed) instead of
  /// a hair before it in a face or a hair after it (HitVertex with nothing left to travel).
  double length_tolerance = 1e-12;
  /// A direction at a vertex or edge start that points out of direction.face by at most this
  /// angle (radians) is accepted: it continues into the neighbouring face (around the vertex,
  /// across the edge) or, on the boundary, is clamped onto the boundary edge. Directions stored
  /// as floats (the proximity graph's) are off by ~1e-7. Beyond this: BadDirection.
  double angle_tolerance = 1e-6;
};

enum class TraceStop : std::uint8_t {
  Completed,   ///< travelled the requested length
  HitVertex,   ///< reached a vertex (within vertex_tolerance) or entered a zero-area face
  HitBoundary  ///< reached a boundary edge
};

struct GeodesicTrace {
  /// The start point, then each edge crossing (SurfacePoint::Kind::Edge with the edge id and
  /// parameter t), then the end point: Kind::Face with barycentrics, or Vertex/Edge if the trace
  /// ends exactly there (HitVertex, HitBoundary, or Completed within length_tolerance of an edge
  /// or vertex). A zero-length trace has the start point only. Consecutive points lie in one
  /// face, so the polyline is the trace.
  std::vector<PathPoint> points;
  /// Length travelled: the requested length when Completed, else the sum of the intrinsic
  /// segment lengths up to the stop.
  double length = 0;
  TraceStop stop = TraceStop::Completed;
  std::int32_t stop_vertex = -1;  ///< the vertex hit when stop == HitVertex, else -1
  SurfacePoint end;               ///< last point reached (== points.back().point)
  /// Direction of travel at the end, unit, in the frame of the face the trace ended in
  /// (end_direction.face; for a zero-length trace the start face).
  FaceDirection end_direction;
};

/// Traces the straightest geodesic from `start` in `direction` for `length` (mesh units).
///
/// `direction` is a vector in the frame of face direction.face (origin corner 0, x towards corner
/// 1, corner 2 at y > 0; see IntrinsicGeometry); it need not be unit (it is normalized), but
/// must be finite and non-zero. That face must contain `start`: for a vertex start, one of the
/// vertex's faces, with the direction pointing into that face's corner wedge or along one of its
/// two edges; for an edge start, one of the edge's faces, pointing into it or along the edge;
/// for a face start, that face. A face point with a zero (or slightly negative) barycentric is
/// the edge point it lies on, with two it is the vertex, and an edge point with t = 0 or 1 is
/// its vertex: the rules for those apply.
///
/// Stops: Completed after `length`; HitVertex when the trace meets a vertex within
/// vertex_tolerance (the vertex is the last point, `length` is the distance travelled to it);
/// HitBoundary at a boundary edge (the edge point is the last point; a boundary vertex is
/// HitVertex). Zero-area faces (IntrinsicGeometry::is_degenerate_face) have no usable frame:
/// a trace starting in or entering one stops HitVertex at the corner of that face nearest to
/// where it entered, with a last segment from there to the corner along the (collinear) face,
/// counted in `length`.
///
/// Throws InvalidInput: invalid `start` (reasons from SurfacePoint::validate); direction.face
/// out of range (FaceOutOfRange); BadDirection for a non-finite or zero direction, a face that
/// does not contain `start`, or a direction pointing out of the face (beyond angle_tolerance);
/// BadLength for a negative or non-finite length; BadTolerance for a negative or non-finite
/// option.
GeodesicTrace trace_geodesic(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                             const SurfacePoint& start, const FaceDirection& direction,
                             double length, const GeodesicTraceOptions& options = {});

/// The same into `out`: its points are cleared and refilled (their capacity is kept, so a
/// caller tracing many paths allocates only when a trace is longer than any before) and every
/// other field is overwritten. On InvalidInput, `out` is unchanged.
void trace_geodesic(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                    const SurfacePoint& start, const FaceDirection& direction, double length,
                    const GeodesicTraceOptions& options, GeodesicTrace& out);

/// `direction`, given in the frame of face_of(h), expressed in the frame of face_of(twin(h)) by
/// unfolding the two faces flat about the edge of halfedge h (its magnitude is kept). Throws
/// InvalidInput: BadHalfedge if h is out of range or on the boundary, BadDirection if
/// direction.face != face_of(h).
FaceDirection unfold_direction(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                               std::uint32_t h, const FaceDirection& direction);

}  // namespace geoprox
