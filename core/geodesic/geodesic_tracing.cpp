#include "core/geodesic/geodesic_tracing.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>

#include "core/base/errors.h"

namespace geoprox {

namespace {

Vec2 operator-(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }
Vec2 operator+(Vec2 a, Vec2 b) { return {a.x + b.x, a.y + b.y}; }
Vec2 operator*(double s, Vec2 a) { return {s * a.x, s * a.y}; }
double dot2(Vec2 a, Vec2 b) { return a.x * b.x + a.y * b.y; }
double cross2(Vec2 a, Vec2 b) { return a.x * b.y - a.y * b.x; }

std::string fmt(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

/// Unit vector along v, or the x axis for a zero vector (an edge of zero length, which only a
/// zero-area face has; the trace never unfolds into such a face).
Vec2 unit(Vec2 v) {
  const double n = std::hypot(v.x, v.y);
  if (!(n > 0)) return {1, 0};
  return {v.x / n, v.y / n};
}

Vec2 rotate(Vec2 u, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return {c * u.x - s * u.y, s * u.x + c * u.y};
}

/// The corners of a face in its frame.
struct FaceCorners {
  Vec2 c[3];
  FaceCorners(const IntrinsicGeometry& g, std::uint32_t f)
      : c{g.face_corner(f, 0), g.face_corner(f, 1), g.face_corner(f, 2)} {}
  /// Edge i: halfedge 3f + i, from corner i to corner i + 1.
  Vec2 edge(int i) const { return c[(i + 1) % 3] - c[i]; }
};

int corner_of(std::uint32_t h) { return static_cast<int>(h % 3); }
unsigned edge_bit(int i) { return 1u << i; }

/// Unit vector of halfedge h in the frame of its face.
Vec2 halfedge_unit(const IntrinsicGeometry& g, std::uint32_t h) {
  return unit(FaceCorners(g, h / 3).edge(corner_of(h)));
}

/// The point at parameter t (0 at the origin, 1 at the target) of halfedge h, in the frame of its
/// face, measured from the nearer end so that points near either end keep their precision.
Vec2 point_on_halfedge(const IntrinsicGeometry& g, std::uint32_t h, double t) {
  const FaceCorners fc(g, h / 3);
  const int i = corner_of(h);
  const Vec2 a = fc.c[i], b = fc.c[(i + 1) % 3];
  return t <= 0.5 ? a + t * (b - a) : b + (1 - t) * (a - b);
}

/// d (frame of face_of(h)) in the frame of face_of(twin): its components along the edge and
/// across it are kept, the edge's direction and the across side flip.
Vec2 unfold(const IntrinsicGeometry& g, std::uint32_t h, std::uint32_t twin, Vec2 d) {
  const Vec2 u = halfedge_unit(g, h);
  const double along = dot2(d, u), across = cross2(u, d);
  const Vec2 u2 = halfedge_unit(g, twin);
  const Vec2 n2{-u2.y, u2.x};
  return {-along * u2.x - across * n2.x, -along * u2.y - across * n2.y};
}

/// Where a trace starts: face, point and unit direction in that face's frame, and the edges of
/// the face (bits of i for halfedge 3f + i) the point lies on, which are no exits.
struct Cursor {
  std::uint32_t face = 0;
  Vec2 p;
  Vec2 d;
  unsigned excluded = 0;
};

/// Angle (radians, [0, pi]) of the corner of face f at corner k, from the face's own layout.
double corner_angle_in_frame(const FaceCorners& fc, int k, Vec2& along, Vec2& other) {
  along = unit(fc.edge(k));
  other = unit(fc.c[(k + 2) % 3] - fc.c[k]);
  return std::atan2(cross2(along, other), dot2(along, other));
}

class StartResolver {
 public:
  StartResolver(const TriangleMesh& mesh, const IntrinsicGeometry& g,
                const GeodesicTraceOptions& options, const FaceDirection& direction, Vec2 d)
      : mesh_(mesh), g_(g), options_(options), direction_(direction), d_(d) {}

  Cursor resolve(const SurfacePoint& start) const {
    const std::uint32_t f = direction_.face;
    switch (start.kind) {
      case SurfacePoint::Kind::Vertex:
        return at_vertex(start.id);
      case SurfacePoint::Kind::Edge:
        if (start.t == 0) return at_vertex(mesh_.edge_origin(start.id));
        if (start.t == 1) return at_vertex(mesh_.edge_target(start.id));
        return on_edge(start.id, start.t, start);
      case SurfacePoint::Kind::Face: {
        // A face point with zero barycentrics is the edge or vertex point it lies on (which
        // other faces contain too, and out of which a direction can point).
        int zeros = 0, zero = -1, positive = -1;
        for (int k = 0; k < 3; ++k) {
          if (start.bary[k] <= 0) {
            ++zeros;
            zero = k;
          } else {
            positive = k;
          }
        }
        if (zeros == 2) return at_vertex(mesh_.face(start.id)[positive]);
        if (zeros == 1) {
          const int i = (zero + 1) % 3;  // the edge opposite corner `zero`
          const std::uint32_t h = 3 * start.id + static_cast<std::uint32_t>(i);
          const double bi = start.bary[i], bj = start.bary[(i + 1) % 3];
          const double th = bj / (bi + bj);
          const std::uint32_t e = mesh_.edge_of(h);
          return on_edge(e, mesh_.edge_halfedge(e) == h ? th : 1 - th, start);
        }
        if (start.id != f) not_containing(start);
        const double b[3] = {start.bary[0], start.bary[1], start.bary[2]};
        return {f, g_.face_point(f, b), d_, 0};
      }
    }
    not_containing(start);
  }

 private:
  [[noreturn]] void not_containing(const SurfacePoint& start) const {
    throw InvalidInput(ErrorCode::BadDirection,
                       "the direction is given in face " + std::to_string(direction_.face) +
                           ", which does not contain the start point " + start.to_string());
  }
  [[noreturn]] void pointing_out(const std::string& where, double angle) const {
    throw InvalidInput(ErrorCode::BadDirection,
                       "direction (" + fmt(direction_.x) + ", " + fmt(direction_.y) + ") in face " +
                           std::to_string(direction_.face) + " points out of the face at " + where +
                           " by " + fmt(angle) + " rad (more than angle_tolerance " +
                           fmt(options_.angle_tolerance) + ")");
  }

  static unsigned corner_edges(int k) { return edge_bit(k) | edge_bit((k + 2) % 3); }

  Cursor at_vertex(std::uint32_t v) const {
    const std::uint32_t f = direction_.face;
    const Triangle& tri = mesh_.face(f);
    int k = -1;
    for (int c = 0; c < 3; ++c) {
      if (tri[c] == v) k = c;
    }
    if (k < 0) not_containing(SurfacePoint::vertex(v));
    const FaceCorners fc(g_, f);
    Vec2 along, other;
    const double alpha = corner_angle_in_frame(fc, k, along, other);
    double theta = std::atan2(cross2(along, d_), dot2(along, d_));
    if (theta >= 0 && theta <= alpha) return {f, fc.c[k], d_, corner_edges(k)};
    const double tol = options_.angle_tolerance;
    if (theta < 0 && theta + 2 * std::numbers::pi - alpha <= tol) theta += 2 * std::numbers::pi;
    const std::uint32_t h = 3 * f + static_cast<std::uint32_t>(k);
    if (theta > alpha && theta - alpha <= tol) {
      // Just past the edge to corner k + 2: the next face counter-clockwise around v.
      const std::int32_t t = mesh_.twin(TriangleMesh::prev(h));
      if (t < 0) return {f, fc.c[k], other, corner_edges(k)};
      const auto h2 = static_cast<std::uint32_t>(t);
      const FaceCorners fc2(g_, h2 / 3);
      Vec2 along2, other2;
      const double alpha2 = corner_angle_in_frame(fc2, corner_of(h2), along2, other2);
      return {h2 / 3, fc2.c[corner_of(h2)], rotate(along2, std::min(theta - alpha, alpha2)),
              corner_edges(corner_of(h2))};
    }
    if (theta < 0 && -theta <= tol) {
      // Just before the edge to corner k + 1: the previous face around v.
      const std::int32_t t = mesh_.twin(h);
      if (t < 0) return {f, fc.c[k], along, corner_edges(k)};
      const std::uint32_t h2 = TriangleMesh::next(static_cast<std::uint32_t>(t));
      const FaceCorners fc2(g_, h2 / 3);
      Vec2 along2, other2;
      const double alpha2 = corner_angle_in_frame(fc2, corner_of(h2), along2, other2);
      return {h2 / 3, fc2.c[corner_of(h2)], rotate(along2, std::max(alpha2 + theta, 0.0)),
              corner_edges(corner_of(h2))};
    }
    pointing_out("the corner of vertex " + std::to_string(v),
                 theta < 0 ? std::min(-theta, theta + 2 * std::numbers::pi - alpha)
                           : theta - alpha);
  }

  Cursor on_edge(std::uint32_t e, double t_edge, const SurfacePoint& start) const {
    const std::uint32_t f = direction_.face;
    std::uint32_t h = mesh_.edge_halfedge(e);
    double th = t_edge;
    if (TriangleMesh::face_of(h) != f) {
      const std::int32_t t = mesh_.twin(h);
      if (t < 0 || TriangleMesh::face_of(static_cast<std::uint32_t>(t)) != f) {
        not_containing(start);
      }
      h = static_cast<std::uint32_t>(t);
      th = 1 - t_edge;
    }
    const Vec2 u = halfedge_unit(g_, h);
    const double across = cross2(u, d_), along = dot2(u, d_);
    const Vec2 p = point_on_halfedge(g_, h, th);
    if (across >= 0) return {f, p, d_, edge_bit(corner_of(h))};
    const double out_angle = std::atan2(-across, std::abs(along));
    if (out_angle > options_.angle_tolerance) {
      pointing_out("edge " + std::to_string(e), out_angle);
    }
    const std::int32_t t = mesh_.twin(h);
    if (t < 0) return {f, p, along >= 0 ? u : -1.0 * u, edge_bit(corner_of(h))};
    const auto h2 = static_cast<std::uint32_t>(t);
    return {h2 / 3, point_on_halfedge(g_, h2, 1 - th), unit(unfold(g_, h, h2, d_)),
            edge_bit(corner_of(h2))};
  }

  const TriangleMesh& mesh_;
  const IntrinsicGeometry& g_;
  const GeodesicTraceOptions& options_;
  const FaceDirection& direction_;
  Vec2 d_;
};

void validate_inputs(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                     const SurfacePoint& start, const FaceDirection& direction, double length,
                     const GeodesicTraceOptions& options) {
  GEOPROX_ASSERT(geometry.edge_lengths().size() == mesh.num_edges() &&
                     geometry.mesh().num_faces() == mesh.num_faces(),
                 "the geometry must be built on the traced mesh");
  const double tolerances[] = {options.vertex_tolerance, options.length_tolerance,
                               options.angle_tolerance};
  for (double tol : tolerances) {
    if (!std::isfinite(tol) || tol < 0) {
      throw InvalidInput(ErrorCode::BadTolerance,
                         "trace tolerances must be finite and >= 0, got " + fmt(tol));
    }
  }
  start.validate(mesh);
  if (direction.face >= mesh.num_faces()) {
    throw InvalidInput(ErrorCode::FaceOutOfRange, "direction face " +
                                                      std::to_string(direction.face) +
                                                      " is out of range (mesh has " +
                                                      std::to_string(mesh.num_faces()) + " faces)");
  }
  const double n = std::hypot(direction.x, direction.y);
  if (!std::isfinite(n) || !(n > 0)) {
    throw InvalidInput(ErrorCode::BadDirection, "direction (" + fmt(direction.x) + ", " +
                                                    fmt(direction.y) + ") is zero or not finite");
  }
  if (!std::isfinite(length) || length < 0) {
    throw InvalidInput(ErrorCode::BadLength,
                       "trace length " + fmt(length) + " must be finite and >= 0");
  }
}

class Tracer {
 public:
  Tracer(const TriangleMesh& mesh, const IntrinsicGeometry& g,
         const GeodesicTraceOptions& options, double length, GeodesicTrace& out)
      : mesh_(mesh), g_(g), options_(options), length_(length), out_(out) {}

  void run(Cursor c) {
    if (length_ == 0) {
      finish(TraceStop::Completed, c.face, c.d);
      return;
    }
    if (g_.is_degenerate_face(c.face)) {
      stop_at_nearest_corner(c);
      return;
    }
    const double snap = options_.length_tolerance * length_;
    const double vt = options_.vertex_tolerance;
    std::size_t stalled = 0;  // consecutive crossings that made no progress
    while (true) {
      const FaceCorners fc(g_, c.face);
      // Edge functions w_i = cross(edge i, p - corner i) = 2 * area * (barycentric of the corner
      // opposite edge i), >= 0 inside; along the ray they change at the rate r_i.
      double w[3], r[3];
      for (int i = 0; i < 3; ++i) {
        const Vec2 e = fc.edge(i);
        w[i] = std::max(0.0, cross2(e, c.p - fc.c[i]));
        r[i] = cross2(e, c.d);
      }
      int exit = -1;
      double s = std::numeric_limits<double>::infinity();
      for (int pass = 0; pass < 2 && exit < 0; ++pass) {
        // Second pass only if rounding left no exit but the edges the point lies on (a ray
        // grazing along one of them).
        for (int i = 0; i < 3; ++i) {
          if ((pass == 0 && (c.excluded & edge_bit(i))) || !(r[i] < 0)) continue;
          const double si = w[i] / -r[i];
          if (si < s) {
            s = si;
            exit = i;
          }
        }
      }
      if (exit < 0) {  // no way out: only a (near) zero-area face does this
        stop_at_nearest_corner(c);
        return;
      }
      // The exit is at parameter t of edge `exit` from its corner `exit`; near an end of the
      // edge it is that vertex, and the segment runs to the vertex itself.
      const int i = exit;
      const double wa = std::max(0.0, w[(i + 1) % 3] + s * r[(i + 1) % 3]);  // ~ barycentric i
      const double wb = std::max(0.0, w[(i + 2) % 3] + s * r[(i + 2) % 3]);  // ~ i + 1
      const double t = wa + wb > 0 ? wb / (wa + wb) : 0.5;
      const bool at_vertex = t <= vt || t >= 1 - vt;
      const int k = t <= vt ? i : (i + 1) % 3;  // the vertex's corner, if at_vertex
      if (at_vertex) {
        const Vec2 to_vertex = fc.c[k] - c.p;
        s = std::hypot(to_vertex.x, to_vertex.y);
      }
      const double remaining = length_ - travelled_;
      if (s > remaining + snap) {  // ends inside this face
        double bary[3], sum = 0;
        for (int j = 0; j < 3; ++j) {
          const double wj = std::max(0.0, w[j] + remaining * r[j]);
          bary[(j + 2) % 3] = wj;
          sum += wj;
        }
        push(SurfacePoint::face(c.face, bary[0] / sum, bary[1] / sum, bary[2] / sum));
        travelled_ = length_;
        finish(TraceStop::Completed, c.face, c.d);
        return;
      }
      travelled_ += s;
      const bool ends_here = length_ - travelled_ <= snap;
      const std::uint32_t h = 3 * c.face + static_cast<std::uint32_t>(i);
      if (at_vertex) {
        const std::uint32_t v = mesh_.face(c.face)[k];
        push(SurfacePoint::vertex(v));
        if (ends_here) {
          travelled_ = length_;
          finish(TraceStop::Completed, c.face, c.d);
        } else {
          out_.stop_vertex = static_cast<std::int32_t>(v);
          finish(TraceStop::HitVertex, c.face, c.d);
        }
        return;
      }
      const std::uint32_t e = mesh_.edge_of(h);
      push(SurfacePoint::edge(e, mesh_.edge_halfedge(e) == h ? t : 1 - t));
      if (ends_here) {
        travelled_ = length_;
        finish(TraceStop::Completed, c.face, c.d);
        return;
      }
      const std::int32_t twin = mesh_.twin(h);
      if (twin < 0) {
        finish(TraceStop::HitBoundary, c.face, c.d);
        return;
      }
      // Rebuild in the next face from (edge, t) and the direction relative to the edge.
      const auto h2 = static_cast<std::uint32_t>(twin);
      c.d = unit(unfold(g_, h, h2, c.d));
      c.face = h2 / 3;
      c.p = point_on_halfedge(g_, h2, 1 - t);
      c.excluded = edge_bit(corner_of(h2));
      if (g_.is_degenerate_face(c.face)) {
        stop_at_nearest_corner(c);
        return;
      }
      stalled = s > 0 ? 0 : stalled + 1;
      GEOPROX_ASSERT(stalled <= 3 * mesh_.num_faces(),
                     "geodesic trace crosses edges without advancing");
    }
  }

 private:
  void push(const SurfacePoint& p) { out_.points.push_back({p, p.position(mesh_)}); }

  void finish(TraceStop stop, std::uint32_t face, Vec2 d) {
    out_.stop = stop;
    out_.length = travelled_;
    out_.end = out_.points.back().point;
    out_.end_direction = {face, d.x, d.y};
  }

  /// A zero-area face (or one rounding left without an exit): stop at its corner nearest to the
  /// current point, the last segment running there along the face.
  void stop_at_nearest_corner(const Cursor& c) {
    const FaceCorners fc(g_, c.face);
    int best = 0;
    double best_distance = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) {
      const Vec2 v = fc.c[k] - c.p;
      const double dk = std::hypot(v.x, v.y);
      if (dk < best_distance) {
        best_distance = dk;
        best = k;
      }
    }
    const std::uint32_t v = mesh_.face(c.face)[best];
    const SurfacePoint& last = out_.points.back().point;
    if (!(last.kind == SurfacePoint::Kind::Vertex && last.id == v)) {
      push(SurfacePoint::vertex(v));
      travelled_ += best_distance;
    }
    out_.stop_vertex = static_cast<std::int32_t>(v);
    finish(TraceStop::HitVertex, c.face, c.d);
  }

  const TriangleMesh& mesh_;
  const IntrinsicGeometry& g_;
  const GeodesicTraceOptions& options_;
  double length_;
  GeodesicTrace& out_;
  double travelled_ = 0;
};

}  // namespace

void trace_geodesic(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                    const SurfacePoint& start, const FaceDirection& direction, double length,
                    const GeodesicTraceOptions& options, GeodesicTrace& out) {
  validate_inputs(mesh, geometry, start, direction, length, options);
  const double n = std::hypot(direction.x, direction.y);
  const Vec2 d{direction.x / n, direction.y / n};
  const Cursor cursor = StartResolver(mesh, geometry, options, direction, d).resolve(start);

  out.points.clear();
  out.length = 0;
  out.stop = TraceStop::Completed;
  out.stop_vertex = -1;
  out.points.push_back({start, start.position(mesh)});
  Tracer(mesh, geometry, options, length, out).run(cursor);
}

GeodesicTrace trace_geodesic(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                             const SurfacePoint& start, const FaceDirection& direction,
                             double length, const GeodesicTraceOptions& options) {
  GeodesicTrace out;
  trace_geodesic(mesh, geometry, start, direction, length, options, out);
  return out;
}

FaceDirection unfold_direction(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                               std::uint32_t h, const FaceDirection& direction) {
  if (h >= mesh.num_halfedges() || mesh.twin(h) < 0) {
    throw InvalidInput(
        ErrorCode::BadHalfedge,
        "halfedge " + std::to_string(h) +
            (h >= mesh.num_halfedges() ? " is out of range"
                                       : " is on the boundary: nothing to unfold into"));
  }
  if (direction.face != TriangleMesh::face_of(h)) {
    throw InvalidInput(ErrorCode::BadDirection,
                       "direction is given in face " + std::to_string(direction.face) +
                           ", not in face " + std::to_string(TriangleMesh::face_of(h)) +
                           " of halfedge " + std::to_string(h));
  }
  const auto twin = static_cast<std::uint32_t>(mesh.twin(h));
  const Vec2 d = unfold(geometry, h, twin, {direction.x, direction.y});
  return {twin / 3, d.x, d.y};
}

}  // namespace geoprox
