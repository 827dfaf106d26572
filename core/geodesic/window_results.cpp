// What a finished solve tells: distances at vertices and surface points, the nearest source, and
// paths, backtraced from a point to the sources through the chain of windows and pseudo-source
// vertices that reached it.
#include <algorithm>
#include <cmath>
#include <string>

#include "core/base/errors.h"
#include "core/geodesic/window_propagation.h"

namespace geoprox::detail {

WindowPropagation::Candidate WindowPropagation::best_in_face(std::uint32_t face, Vec2 p) const {
  const IntrinsicGeometry& g = *geometry_;
  Candidate best;
  for (int i = 0; i < 3; ++i) {
    const std::uint32_t v = mesh_->face(face)[i];
    const double dv = vertex_estimate(v);
    if (dv < kInfinity) {
      const Vec2 c = g.face_corner(face, i);
      const double d = dv + length2(p.x - c.x, p.y - c.y);
      if (d < best.distance) best = {Candidate::Kind::Vertex, d, static_cast<std::int32_t>(v), {}};
    }
  }
  if (face_stamp_[face] == generation_) {
    for (std::int32_t s = face_first_seed_[face]; s >= 0; s = seeds_[s].next) {
      const Seed& seed = seeds_[s];
      const double d = seed.offset + length2(p.x - seed.point.x, p.y - seed.point.y);
      if (d < best.distance) best = {Candidate::Kind::Seed, d, s, {}};
    }
  }
  for (int i = 0; i < 3; ++i) {
    const std::uint32_t h = 3 * face + static_cast<std::uint32_t>(i);
    if (first_chunk(h) < 0) continue;
    const double L = g.layout(h).length;
    if (L <= 0) continue;
    const Vec2 q = face_to_halfedge_frame(g, face, i, p);
    const double slack = tuning::kVisibilitySlack * L;
    for_each_live_window(h, [&](std::int32_t wi, const Window& w) {
      const double qy = std::max(q.y, 0.0);
      const double x = w.crossing_x(q.x, qy);
      if (x < w.b0 - slack || x > w.b1 + slack) return;
      const double d = through_window(w, x, q.x, qy);
      if (d < best.distance) best = {Candidate::Kind::Window, d, wi, {q.x, qy}};
    });
  }
  return best;
}

double WindowPropagation::distance(std::uint32_t vertex) const {
  if (vertex >= mesh_->num_vertices()) {
    throw InvalidInput(ErrorCode::VertexOutOfRange,
                       "vertex " + std::to_string(vertex) + " is out of range (mesh has " +
                           std::to_string(mesh_->num_vertices()) + " vertices)");
  }
  const double d = vertex_estimate(vertex);
  return d <= radius_reached_ ? d : kInfinity;
}

double WindowPropagation::distance(const SurfacePoint& point) const {
  point.validate(*mesh_);
  if (point.kind == SurfacePoint::Kind::Vertex) return distance(point.id);
  auto [face, bary] = point.in_face(*mesh_);
  const double d = best_in_face(face, geometry_->face_point(face, bary.data())).distance;
  return d <= radius_reached_ ? d : kInfinity;
}

std::vector<double> WindowPropagation::vertex_distances() const {
  std::vector<double> out(mesh_->num_vertices());
  for (std::uint32_t v = 0; v < out.size(); ++v) {
    const double d = vertex_estimate(v);
    out[v] = d <= radius_reached_ ? d : kInfinity;
  }
  return out;
}

std::int32_t WindowPropagation::nearest_source(std::uint32_t vertex) const {
  if (distance(vertex) == kInfinity) return -1;
  return static_cast<std::int32_t>(vertex_source_[vertex]);
}

// ---------------------------------------------------------------------------------------------
// Backtracing: from the target towards the source, through the chain of windows whose unfolded
// source the path points at, and through pseudo-source vertices.

namespace {

struct PathBuilder {
  const TriangleMesh& mesh;
  std::vector<PathPoint> points;

  void add(const SurfacePoint& p) {
    const Vec3 pos = p.position(mesh);
    if (!points.empty()) {
      const PathPoint& last = points.back();
      // Only the very same point is dropped: distinct points at one position (across a
      // zero-area face) each name the face they share with their neighbours.
      if (same_point(last.point, p)) return;
      // Out and back to the very same point is a spur: dropped. Along a line of zero-area
      // faces a window's interval may start a hair past the vertex its child's ray reaches
      // (its crossing is clamped into the interval), and the polyline went there and back.
      if (points.size() >= 2 && same_point(points[points.size() - 2].point, p)) {
        points.pop_back();
        return;
      }
    }
    points.push_back({p, pos});
  }

  static bool same_point(const SurfacePoint& q, const SurfacePoint& p) {
    return q.kind == p.kind && q.id == p.id && q.t == p.t && q.bary == p.bary;
  }
};

// Each crossing of an edge moved to where the path's two pieces beside it, each inside one of
// the edge's faces, are shortest: the straight line across the edge in those faces' unfolding,
// which an exact path already takes to rounding. Along a line of zero-area faces a crossing is
// ill-conditioned there (the edge lies along the path, every point of the overlap is a
// crossing) and came out a hair ahead of the next one: the polyline went forward and back,
// longer than the distance. Positions measure the pieces, so
// only where lengths are the positions' chords; moves that gain less than the positions'
// rounding are not made.
void straighten_crossings(const TriangleMesh& mesh, std::vector<PathPoint>& points) {
  // A move changes its neighbours' best places: a few passes, until none moves.
  for (int pass = 0; pass < 4; ++pass) {
    bool moved = false;
    for (std::size_t i = 1; i + 1 < points.size(); ++i) {
      PathPoint& b = points[i];
      if (b.point.kind != SurfacePoint::Kind::Edge) continue;
      const Vec3 a = points[i - 1].position, c = points[i + 1].position;
      const Vec3& p0 = mesh.position(mesh.edge_origin(b.point.id));
      const Vec3 along = mesh.position(mesh.edge_target(b.point.id)) - p0;
      const double length = norm(along);
      if (!(length > 0)) continue;
      const Vec3 u = (1 / length) * along;
      // a and c as (position along the edge, distance from its line): the pieces are shortest
      // on the segment from (sa, ra) to (sc, -rc), both laid out in one plane.
      const double sa = dot(a - p0, u), sc = dot(c - p0, u), sb = b.point.t * length;
      const double ra = norm(a - p0 - sa * u), rc = norm(c - p0 - sc * u);
      auto pieces = [&](double x) { return norm(a - p0 - x * u) + norm(c - p0 - x * u); };
      const double now = pieces(sb);
      // The rounding of these positions and projections.
      const double scale = norm(p0) + length + std::abs(sa) + std::abs(sc);
      double best;
      bool better;
      if (ra + rc > 1e-12 * scale) {
        best = std::clamp(sa + (sc - sa) * (ra / (ra + rc)), 0.0, length);
        better = pieces(best) < now - 1e-13 * scale;
      } else {
        // a and c on the line (to rounding): every point between them is as short, and a run
        // of such points can still go forward and back. Each joins the one before it (or
        // comes as near as its edge allows), so that the run advances monotonically.
        best = std::clamp(std::clamp(sa, 0.0, length), std::min(sa, sc), std::max(sa, sc));
        better = best != sb && pieces(best) <= now + 1e-13 * scale;
      }
      if (!better) continue;
      b.point = SurfacePoint::edge(b.point.id, best / length);
      b.position = b.point.position(mesh);
      moved = true;
    }
    if (!moved) break;
  }
}

void faces_of(const TriangleMesh& mesh, const SurfacePoint& p, std::vector<std::uint32_t>& out) {
  out.clear();
  switch (p.kind) {
    case SurfacePoint::Kind::Vertex:
      for (std::uint32_t h : mesh.outgoing_halfedges(p.id)) out.push_back(h / 3);
      break;
    case SurfacePoint::Kind::Edge: {
      const std::uint32_t h = mesh.edge_halfedge(p.id);
      out.push_back(h / 3);
      if (mesh.twin(h) >= 0) out.push_back(static_cast<std::uint32_t>(mesh.twin(h)) / 3);
      break;
    }
    case SurfacePoint::Kind::Face:
      out.push_back(p.id);
      break;
  }
}

// Unit direction (dx, dy) given in the frame of halfedge h, in the frame of h's face.
FaceDirection halfedge_direction(const IntrinsicGeometry& g, std::uint32_t h, double dx,
                                 double dy) {
  const std::uint32_t f = h / 3;
  const int i = static_cast<int>(h % 3);
  const double len = length2(dx, dy);
  if (!(len > 0)) return {f, 1, 0};
  dx /= len;
  dy /= len;
  if (i == 0) return {f, dx, dy};
  const HalfedgeAxes a = halfedge_axes(g, f, i);
  // The axes are unit only to the rounding of the side's layout, which a cap or needle makes
  // coarse: normalise the result, a unit vector by contract.
  const double x = dx * a.ex - dy * a.ey, y = dx * a.ey + dy * a.ex;
  const double norm = length2(x, y);
  if (!(norm > 0)) return {f, dx, dy};
  return {f, x / norm, y / norm};
}

FaceDirection reversed(FaceDirection d) { return {d.face, -d.x, -d.y}; }

SurfacePoint point_on_halfedge(const TriangleMesh& mesh, std::uint32_t h, double x, double L) {
  const double rel = L > 0 ? std::clamp(x / L, 0.0, 1.0) : 0.0;
  if (rel <= 1e-12) return SurfacePoint::vertex(mesh.origin(h));
  if (rel >= 1 - 1e-12) return SurfacePoint::vertex(mesh.target(h));
  const std::uint32_t e = mesh.edge_of(h);
  return SurfacePoint::edge(e, mesh.edge_halfedge(e) == h ? rel : 1 - rel);
}

}  // namespace

// One walk from the point back to a source, alternating between windows and pseudo-source
// vertices with the state of each step carried to the next: kept whole (over 100 lines) so that
// the walk reads in order.
GeodesicPath WindowPropagation::path_to(const SurfacePoint& point) const {
  point.validate(*mesh_);
  const IntrinsicGeometry& g = *geometry_;
  GeodesicPath path;
  PathBuilder builder{*mesh_, {}};
  builder.add(point);

  std::int32_t vertex = -1;  // continue from this vertex when >= 0
  std::int32_t window = -1;  // or trace this window from `p` (in its halfedge frame)
  Vec2 p{};
  double distance_found = kInfinity;
  std::uint32_t source_index = 0;
  bool done = false;

  // End directions come from the straight pieces themselves (window geometry, edges), not from
  // consecutive polyline points, which can be arbitrarily close across slivers.
  bool have_target_direction = false;
  auto record_piece = [&](FaceDirection at_target_side, FaceDirection at_source_side) {
    if (!have_target_direction) {
      path.direction_at_target = at_target_side;
      have_target_direction = true;
    }
    path.direction_at_source = at_source_side;
  };
  // A straight piece inside face f between two points given in f's frame.
  auto record_in_face = [&](std::uint32_t f, Vec2 from, Vec2 to) {
    // A piece of (numerically) zero length has no direction: the next one decides.
    const double scale = g.layout(3 * f).length + length2(g.layout(3 * f).cx, g.layout(3 * f).cy);
    if (length2(to.x - from.x, to.y - from.y) <= 1e-12 * scale) return;
    const FaceDirection d = halfedge_direction(g, 3 * f, to.x - from.x, to.y - from.y);
    record_piece(d, reversed(d));
  };
  auto corner_of = [&](std::uint32_t f, std::uint32_t v) {
    int corner = 0;
    while (corner < 2 && mesh_->face(f)[corner] != v) ++corner;
    return g.face_corner(f, corner);
  };

  auto finish_at_seed = [&](std::int32_t seed) {
    const Seed& s = seeds_[static_cast<std::size_t>(seed)];
    builder.add(sources_[s.source_index].point);
    source_index = s.source_index;
    done = true;
  };

  if (point.kind == SurfacePoint::Kind::Vertex) {
    distance_found = distance(point.id);
    vertex = static_cast<std::int32_t>(point.id);
  } else {
    auto [face, bary] = point.in_face(*mesh_);
    const Candidate best = best_in_face(face, g.face_point(face, bary.data()));
    distance_found = best.distance <= radius_reached_ ? best.distance : kInfinity;
    if (distance_found < kInfinity) {
      const Vec2 here = g.face_point(face, bary.data());
      switch (best.kind) {
        case Candidate::Kind::Vertex:
          vertex = best.index;
          record_in_face(face, here, corner_of(face, static_cast<std::uint32_t>(vertex)));
          builder.add(SurfacePoint::vertex(static_cast<std::uint32_t>(vertex)));
          break;
        case Candidate::Kind::Seed:
          record_in_face(face, here, seeds_[static_cast<std::size_t>(best.index)].point);
          finish_at_seed(best.index);
          break;
        case Candidate::Kind::Window:
          window = best.index;
          p = best.point_in_frame;
          break;
        case Candidate::Kind::None:
          break;
      }
    }
  }
  if (distance_found == kInfinity) {
    throw Unreachable(ErrorCode::Unreachable,
                      "point " + point.to_string() + " is not reachable from the sources" +
                          (radius_reached_ < kInfinity ? " within the radius solved" : ""));
  }

  const std::size_t guard_limit = 4 * (windows_.size() + mesh_->num_vertices()) + 16;
  std::size_t guard = 0;
  bool piece_started = false;  // inside a window chain, its target-side direction is recorded
  bool p_on_edge_end = false;  // p is an end vertex of the window's edge
  // The chain's target-side point, carried into each parent's frame with p: a chain is one
  // straight segment in the unfolding, and where the crossings all lie at its source (a
  // source on a line of zero-area faces) only this point still gives its direction.
  Vec2 far{};
  while (!done) {
    GEOPROX_ASSERT(++guard < guard_limit, "backtrace does not terminate");
    if (window >= 0) {
      const Window& w = windows_[static_cast<std::size_t>(window)];
      const HalfedgeLayout& lay = g.layout(w.halfedge);
      if (!piece_started) {
        piece_started = true;
        far = p;
        // From a point inside the face the segment runs in this face; from an end vertex of
        // the window's edge it runs into the face across that edge, behind which S lies.
        const std::int32_t across = mesh_->twin(w.halfedge);
        const FaceDirection towards =
            !p_on_edge_end || across < 0
                ? halfedge_direction(g, w.halfedge, w.sx - p.x, w.sy - p.y)
                : halfedge_direction(g, static_cast<std::uint32_t>(across), p.x - w.sx, p.y - w.sy);
        if (!have_target_direction) {
          path.direction_at_target = towards;
          have_target_direction = true;
        }
      }
      // Where the segment from p towards the unfolded source crosses the window's edge.
      const double x = std::clamp(w.crossing_x(p.x, p.y), w.b0, w.b1);
      builder.add(point_on_halfedge(*mesh_, w.halfedge, x, lay.length));
      if (w.parent >= 0) {
        const Window& parent = windows_[static_cast<std::size_t>(w.parent)];
        const std::uint32_t ph = parent.halfedge;
        const HalfedgeLayout& play = g.layout(ph);
        const auto twin = static_cast<std::uint32_t>(mesh_->twin(w.halfedge));
        const double along = lay.length > 0 ? (lay.length - x) / lay.length : 0;  // on the twin
        // The parent's side from A to B is the twin of this window's edge, which runs from B.
        Vec2 a_end, b_end;
        if (twin == TriangleMesh::next(ph)) {  // b' -> c'
          p = {play.length + along * (play.cx - play.length), along * play.cy};
          a_end = {play.length, 0};
          b_end = {play.cx, play.cy};
        } else {
          GEOPROX_ASSERT(twin == TriangleMesh::prev(ph), "window chain is not adjacent");
          p = {play.cx * (1 - along), play.cy * (1 - along)};  // c' -> a'
          a_end = {play.cx, play.cy};
          b_end = {0, 0};
        }
        const double side = length2(a_end.x - b_end.x, a_end.y - b_end.y);
        if (side > 0) {
          const double ex = (a_end.x - b_end.x) / side, ey = (a_end.y - b_end.y) / side;
          far = {b_end.x + far.x * ex - far.y * ey, b_end.y + far.x * ey + far.y * ex};
        } else {
          far = p;
        }
        window = w.parent;
        continue;
      }
      // The chain's root: its source lies in the face across the root's edge. The direction at
      // the source points at the crossing, expressed in that face.
      // Measured towards the current point p rather than the crossing, which coincides with the
      // source when the source lies on the root's edge (a zero-area face behind it).
      piece_started = false;
      if (w.sy == 0) {
        const double to_far = length2(far.x - w.sx, far.y - w.sy);
        const Vec2 ahead = to_far > 1e-9 * (lay.length + std::abs(w.sx)) ? far : p;
        path.direction_at_source =
            halfedge_direction(g, w.halfedge, ahead.x - w.sx, ahead.y - w.sy);
      } else {
        const auto across = static_cast<std::uint32_t>(mesh_->twin(w.halfedge));
        path.direction_at_source = halfedge_direction(g, across, w.sx - p.x, w.sy - p.y);
      }
      if (w.root >= 0) {
        builder.add(SurfacePoint::vertex(static_cast<std::uint32_t>(w.root)));
        vertex = w.root;
        window = -1;
        continue;
      }
      finish_at_seed(-1 - w.root);
      continue;
    }
    // From a vertex: follow how its distance was obtained.
    const auto v = static_cast<std::uint32_t>(vertex);
    const std::int32_t via_vertex = vertex_via_vertex_[v];
    const std::int32_t via_window = vertex_via_window_[v];
    if (via_vertex == kViaSourceVertex) {
      builder.add(SurfacePoint::vertex(v));
      source_index = vertex_source_[v];
      // A source a rounding error from its vertex (add_source): the path starts at the point.
      const SurfacePoint& source = sources_[source_index].point;
      if (source.kind != SurfacePoint::Kind::Vertex &&
          norm(source.position(*mesh_) - mesh_->position(v)) > 0) {
        builder.add(source);
      }
      done = true;
    } else if (via_vertex >= 0) {
      const auto u = static_cast<std::uint32_t>(via_vertex);
      for (std::uint32_t h : mesh_->outgoing_halfedges(v)) {
        if (mesh_->target(h) == u) {
          const FaceDirection along = halfedge_direction(g, h, 1, 0);
          record_piece(along, reversed(along));
          break;
        }
        if (mesh_->origin(TriangleMesh::prev(h)) == u) {  // v <- u is prev(h): run it backwards
          const std::uint32_t back = TriangleMesh::prev(h);
          const FaceDirection along = halfedge_direction(g, back, -1, 0);
          record_piece(along, reversed(along));
          break;
        }
      }
      builder.add(SurfacePoint::vertex(u));
      vertex = via_vertex;
    } else if (via_vertex <= kViaSeedBase) {
      const Seed& seed = seeds_[static_cast<std::size_t>(kViaSeedBase - via_vertex)];
      record_in_face(seed.face, corner_of(seed.face, v), seed.point);
      finish_at_seed(kViaSeedBase - via_vertex);
    } else {
      GEOPROX_ASSERT(via_window >= 0, "reached vertex without a predecessor");
      const Window& w = windows_[static_cast<std::size_t>(via_window)];
      const HalfedgeLayout& lay = g.layout(w.halfedge);
      p_on_edge_end = v != mesh_->opposite_vertex(w.halfedge);
      if (v == mesh_->origin(w.halfedge)) {
        p = {0, 0};
      } else if (v == mesh_->target(w.halfedge)) {
        p = {lay.length, 0};
      } else {
        p = {lay.cx, lay.cy};
      }
      window = via_window;
      vertex = -1;
    }
  }

  std::reverse(builder.points.begin(), builder.points.end());
  path.points = std::move(builder.points);
  if (g.lengths_are_chords()) straighten_crossings(*mesh_, path.points);
  path.length = distance_found;
  path.source_index = source_index;
  if (!have_target_direction) {  // a path of length zero
    std::vector<std::uint32_t> faces;
    faces_of(*mesh_, point, faces);
    const std::uint32_t f = faces.empty() ? 0 : faces.front();
    path.direction_at_source = {f, 1, 0};
    path.direction_at_target = {f, 1, 0};
    return path;
  }
  // At a vertex end, give the direction in the face whose corner it points into.
  const PathPoint& first = path.points.front();
  const PathPoint& last = path.points.back();
  if (first.point.kind == SurfacePoint::Kind::Vertex) {
    path.direction_at_source = into_corner(first.point.id, path.direction_at_source);
  }
  if (last.point.kind == SurfacePoint::Kind::Vertex) {
    path.direction_at_target = into_corner(last.point.id, path.direction_at_target);
  }
  return path;
}

FaceDirection WindowPropagation::into_corner(std::uint32_t v, FaceDirection d) const {
  // Angles around v are intrinsic (sums of corner angles), so turning from one corner into the
  // next is the unfolding across the edge between them.
  const IntrinsicGeometry& g = *geometry_;
  std::uint32_t h = UINT32_MAX;  // outgoing halfedge of v in d.face
  for (int i = 0; i < 3; ++i) {
    if (mesh_->face(d.face)[i] == v) h = 3 * d.face + static_cast<std::uint32_t>(i);
  }
  if (h == UINT32_MAX) return d;
  auto edge_angle = [&](std::uint32_t halfedge) {  // direction of halfedge in its face frame
    const FaceDirection e = halfedge_direction(g, halfedge, 1, 0);
    return std::atan2(e.y, e.x);
  };
  constexpr double kTwoPi = 2 * 3.14159265358979323846;
  double theta = std::atan2(d.y, d.x) - edge_angle(h);  // from v -> a, counter-clockwise
  theta = std::remainder(theta, kTwoPi);
  const double slack = 1e-9;
  for (std::size_t step = 0; step <= mesh_->outgoing_halfedges(v).size(); ++step) {
    const double corner = g.corner_angle(h);
    if (theta >= -slack && theta <= corner + slack) break;
    if (theta > corner) {  // further counter-clockwise: the next face around v
      const std::int32_t t = mesh_->twin(TriangleMesh::prev(h));
      if (t < 0) break;
      theta -= corner;
      h = static_cast<std::uint32_t>(t);
    } else {  // clockwise: the previous face
      const std::int32_t t = mesh_->twin(h);
      if (t < 0) break;
      h = TriangleMesh::next(static_cast<std::uint32_t>(t));
      theta += g.corner_angle(h);
    }
  }
  const double angle = edge_angle(h) + theta;
  return {h / 3, std::cos(angle), std::sin(angle)};
}

}  // namespace geoprox::detail
