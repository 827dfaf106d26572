#include "core/geodesic/fast_marching.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <string>

#include "core/base/errors.h"

namespace geoprox {

namespace {

// A planar-front update needs a face whose angle at the updated corner is at least ~1e-10 rad
// (sin^2 > 1e-20): below that the front's direction is undetermined and the edge values rule.
constexpr double kMinSinSquared = 1e-20;
// A corner is obtuse when its cosine is below -kRightAngleSlack (about 90 + 6e-8 degrees).
constexpr double kRightAngleSlack = 1e-9;

inline double dot(Vec2 a, Vec2 b) { return a.x * b.x + a.y * b.y; }
inline double cross(Vec2 a, Vec2 b) { return a.x * b.y - a.y * b.x; }
inline Vec2 minus(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }

}  // namespace

FastMarchingSolver::FastMarchingSolver(const TriangleMesh& mesh, const IntrinsicGeometry& geometry)
    : mesh_(&mesh), geometry_(&geometry) {
  GEOPROX_ASSERT(&geometry.mesh() == &mesh, "geometry was built for another mesh");
  state_.assign(mesh.num_vertices(), VertexState{kInfinity, 0, kTrial, 0});
  build_fans();
}

void FastMarchingSolver::build_fans() {
  const TriangleMesh& mesh = *mesh_;
  const IntrinsicGeometry& g = *geometry_;
  const std::size_t nv = mesh.num_vertices();
  fan_offsets_.assign(nv + 1, 0);
  fan_.clear();
  fan_.reserve(mesh.num_halfedges());
  halfedge_slot_.assign(mesh.num_halfedges(), 0);
  for (std::uint32_t v = 0; v < nv; ++v) {
    for (std::uint32_t h : mesh.outgoing_halfedges(v)) {
      const std::uint32_t f = TriangleMesh::face_of(h);
      const std::uint32_t hb = TriangleMesh::prev(h);
      const double area = g.face_area(f);
      FanSlot slot{};
      slot.len_va = g.edge_length(mesh.edge_of(h));
      slot.len_ab = g.edge_length(mesh.edge_of(TriangleMesh::next(h)));
      slot.len_vb = g.edge_length(mesh.edge_of(hb));
      slot.det = g.is_degenerate_face(f) ? 0.0 : 4 * area * area;
      slot.a = mesh.target(h);
      slot.b = mesh.origin(hb);
      slot.split_a = slot.split_b = -1;
      halfedge_slot_[h] = static_cast<std::uint32_t>(fan_.size());
      fan_.push_back(slot);
      if (mesh.twin(hb) < 0) {
        FanSlot edge_only{};
        edge_only.len_va = slot.len_vb;
        edge_only.det = -1;
        edge_only.a = edge_only.b = slot.b;
        edge_only.split_a = edge_only.split_b = -1;
        fan_.push_back(edge_only);
      }
    }
    fan_offsets_[v + 1] = static_cast<std::uint32_t>(fan_.size());
  }
}

// ---------------------------------------------------------------------------------------------
// Splitting of obtuse corners (Kimmel & Sethian's unfolding)

bool FastMarchingSolver::find_split(std::uint32_t corner, int max_steps, bool flat,
                                    Split& split) const {
  const TriangleMesh& mesh = *mesh_;
  const HalfedgeLayout& lay = geometry_->layout(corner);
  const Vec2 px{lay.length, 0}, py{lay.cx, lay.cy};
  const double y_length = std::sqrt(dot(py, py));
  // The acute section: directions within 90 degrees of both CX and CY, i.e. counter-clockwise
  // from r_low (CY turned clockwise) to r_high (CX turned counter-clockwise).
  const Vec2 r_low{py.y, -py.x}, r_high{-px.y, px.x};
  const Vec2 r_mid{r_low.x + r_high.x, r_low.y + r_high.y};
  const double low_length = std::sqrt(dot(r_low, r_low)), high_length = lay.length;
  const std::uint32_t c = mesh.origin(corner), x = mesh.target(corner),
                      y = mesh.opposite_vertex(corner);
  // Invariant: the section crosses halfedge `edge` (face already unfolded on its left), whose
  // origin and target are at `from` and `to` in the corner's frame.
  std::uint32_t edge = TriangleMesh::next(corner);
  Vec2 from = px, to = py;
  for (int step = 0; step < max_steps; ++step) {
    const std::int32_t twin = mesh.twin(edge);
    if (twin < 0) return false;  // boundary: nothing to unfold
    const auto t = static_cast<std::uint32_t>(twin);
    // The twin runs from `to` to `from`; its face lies on its left (orientation is preserved).
    const Vec2 along = minus(from, to);
    const double length = std::sqrt(dot(along, along));
    if (!(length > 0)) return false;
    const Vec2 e1{along.x / length, along.y / length};
    const HalfedgeLayout& tl = geometry_->layout(t);
    const Vec2 z{to.x + tl.cx * e1.x - tl.cy * e1.y, to.y + tl.cx * e1.y + tl.cy * e1.x};
    const std::uint32_t zv = mesh.opposite_vertex(t);
    // Normalised to sines, with a little slack: a vertex exactly on the section's edge (a right
    // angle in the virtual face, common on regular grids) must not be lost to rounding.
    const double z_length = std::sqrt(dot(z, z));
    if (!(z_length > 0)) return false;
    const double after_low = cross(r_low, z) / (low_length * z_length);
    const double before_high = cross(z, r_high) / (high_length * z_length);
    // A flat corner (about 180 degrees: zero-area faces, extreme caps) has an acute section too
    // thin to hit and no planar update of its own; the first vertex beyond XY splits it into two
    // proper virtual faces, one of them obtuse, whose updates the monotonicity check guards.
    const double sin_xd = cross(px, z) / (lay.length * z_length);
    const double sin_dy = cross(z, py) / (y_length * z_length);
    const bool flat_split = flat && step == 0 && sin_xd * sin_xd > kMinSinSquared &&
                            sin_dy * sin_dy > kMinSinSquared && sin_xd > 0 && sin_dy > 0;
    if (flat_split || (after_low >= -kRightAngleSlack && before_high >= -kRightAngleSlack &&
                       dot(z, r_mid) > 0)) {
      // A copy of C, X or Y itself (the strip wrapped around a small closed surface) carries no
      // independent value: give up rather than update a corner from itself.
      if (zv == c || zv == x || zv == y) return false;
      split.x_length = lay.length;
      split.y_at = py;
      split.d_at = z;
      split.cd = z_length;
      split.c = c;
      split.x = x;
      split.y = y;
      split.d = zv;
      return true;
    }
    // The section lies wholly on one side of the ray C->z; continue across the new edge on that
    // side: (from, z) is the twin's next halfedge, (z, to) its previous one.
    const double section_side = after_low < 0 ? 1.0 : -1.0;
    if ((cross(z, from) > 0 ? 1.0 : -1.0) == section_side) {
      edge = TriangleMesh::next(t);
      to = z;
    } else {
      edge = TriangleMesh::prev(t);
      from = z;
    }
  }
  return false;
}

void FastMarchingSolver::build_splits(int max_unfold_steps) {
  const TriangleMesh& mesh = *mesh_;
  const std::size_t nh = mesh.num_halfedges();
  splits_.clear();
  for (FanSlot& slot : fan_) slot.split_a = slot.split_b = -1;
  stats_.obtuse_corners = stats_.unsplit_corners = 0;
  for (std::uint32_t h = 0; h < nh; ++h) {
    const HalfedgeLayout& lay = geometry_->layout(h);
    // Obtuse beyond rounding: a right angle computed as 90 + 1e-15 degrees needs no split.
    // Corners on a zero-length edge (lay.length 0) have no angle.
    const double y2 = lay.cx * lay.cx + lay.cy * lay.cy;
    if (!(lay.length > 0) || !(lay.cx < -kRightAngleSlack * std::sqrt(y2))) continue;
    ++stats_.obtuse_corners;
    const bool flat = geometry_->is_degenerate_face(TriangleMesh::face_of(h)) ||
                      lay.cy * lay.cy <= kMinSinSquared * y2;
    Split split;
    if (max_unfold_steps == 0 || !find_split(h, max_unfold_steps, flat, split)) {
      ++stats_.unsplit_corners;
      continue;
    }
    // Corner C = origin(h) of face (C, X, Y) is b in X's slot (X->Y = next(h)) and a in Y's
    // (Y->C = prev(h)).
    const auto index = static_cast<std::int32_t>(splits_.size());
    fan_[halfedge_slot_[TriangleMesh::next(h)]].split_b = index;
    fan_[halfedge_slot_[TriangleMesh::prev(h)]].split_a = index;
    splits_.push_back(split);
  }
  // Reverse index: when D is accepted, the corners it splits are updated.
  split_offsets_.assign(mesh.num_vertices() + 1, 0);
  for (const Split& sp : splits_) ++split_offsets_[sp.d + 1];
  for (std::size_t v = 0; v < mesh.num_vertices(); ++v) split_offsets_[v + 1] += split_offsets_[v];
  splits_by_d_.resize(splits_.size());
  std::vector<std::uint32_t> fill(split_offsets_.begin(), split_offsets_.end() - 1);
  for (std::uint32_t i = 0; i < splits_.size(); ++i) splits_by_d_[fill[splits_[i].d]++] = i;
  split_steps_ = max_unfold_steps;
}

// ---------------------------------------------------------------------------------------------
// Updates

FastMarchingSolver::CornerFace FastMarchingSolver::Split::face_xd() const {
  const double x2 = x_length * x_length;
  const double dx = d_at.x - x_length;
  const double cr = x_length * d_at.y;
  return {x2, dot(d_at, d_at), dx * dx + d_at.y * d_at.y, x_length * d_at.x, cr * cr};
}

FastMarchingSolver::CornerFace FastMarchingSolver::Split::face_dy() const {
  const Vec2 dy = minus(y_at, d_at);
  const double cr = cross(d_at, y_at);
  return {dot(d_at, d_at), dot(y_at, y_at), dot(dy, dy), dot(d_at, y_at), cr * cr};
}

double FastMarchingSolver::planar_update(double dp, double dq, const CornerFace& face) {
  // Solve |g| = 1 for the linear T with T(C) = t, T(P) = dp, T(Q) = dq. With s = t - dp and
  // u = dq - dp this is pq2 s^2 - 2u(cp2 - m)s + cp2 u^2 - det = 0, whose discriminant
  // simplifies to det (pq2 - u^2): a planar front exists iff |dq - dp| <= |PQ|.
  const double det = face.det;
  if (!(det > kMinSinSquared * face.cp2 * face.cq2)) return kInfinity;  // degenerate
  const double u = dq - dp;
  const double room = face.pq2 - u * u;
  if (!(room > 0)) return kInfinity;
  const double s = (u * (face.cp2 - face.m) + std::sqrt(det * room)) / face.pq2;
  // Causality: the upwind direction -g = lp*CP + lq*CQ must have lp, lq >= 0 (it comes from
  // inside the angle at C; lp, lq are proportional to the first two terms), and t >= dp, dq
  // (it is within 90 degrees of both CP and CQ). At an acute corner the first implies the
  // second; at an obtuse one the second keeps the scheme monotone: a value computed from P and
  // Q is never below theirs, so the order of acceptance stays consistent.
  if (face.cq2 * s - face.m * (s - u) < 0 || face.cp2 * (s - u) - face.m * s < 0 || s < 0 ||
      s < u) {
    return kInfinity;
  }
  ++stats_.triangle_updates;
  return dp + s;
}

double FastMarchingSolver::split_update(const Split& split, std::uint32_t known,
                                        double known_distance) {
  // `known` (X or Y of the split corner) was just accepted: the virtual face it shares with D.
  if (!is_known(split.d)) return kInfinity;
  const double dd = state_[split.d].distance;
  const std::size_t before = stats_.triangle_updates;
  const double t = known == split.x ? planar_update(known_distance, dd, split.face_xd())
                                    : planar_update(dd, known_distance, split.face_dy());
  stats_.unfolded_updates += stats_.triangle_updates - before;
  return t;
}

void FastMarchingSolver::heap_push(double key, std::uint32_t vertex) {
  const auto bits = std::bit_cast<std::uint64_t>(key + 0.0);  // + 0.0 turns -0.0 into +0.0
  const std::uint64_t diff = bits ^ heap_last_;
  buckets_[diff == 0 ? 0 : 64 - std::countl_zero(diff)].push_back({bits, vertex});
  ++stats_.heap_pushes;
}

bool FastMarchingSolver::heap_refill() {
  if (!buckets_[0].empty()) return true;
  std::size_t i = 1;
  while (i < buckets_.size() && buckets_[i].empty()) ++i;
  if (i == buckets_.size()) return false;
  // The smallest key of the first non-empty bucket becomes heap_last_; its entries then differ
  // from it in lower bits only and move to lower buckets (at least one to bucket 0).
  std::vector<HeapEntry>& bucket = buckets_[i];
  std::uint64_t smallest = bucket.front().key;
  for (const HeapEntry& e : bucket) smallest = std::min(smallest, e.key);
  heap_last_ = smallest;
  for (const HeapEntry& e : bucket) {
    const std::uint64_t diff = e.key ^ smallest;
    buckets_[diff == 0 ? 0 : 64 - std::countl_zero(diff)].push_back(e);
  }
  bucket.clear();
  return true;
}

void FastMarchingSolver::relax(std::uint32_t v, double distance, std::uint8_t depth) {
  VertexState& s = state_[v];
  if (s.stamp != generation_) {
    if (depth > halo_depth_) return;  // lower(): too far beyond the lowered region
    s = {kInfinity, generation_, kTrial, depth};
    // The fan is read when v is accepted, a whole front later: start loading it now (on large
    // meshes the fans do not fit in the cache and this miss dominated a solve).
    const char* fan = reinterpret_cast<const char*>(fan_.data() + fan_offsets_[v]);
    const char* fan_end = reinterpret_cast<const char*>(fan_.data() + fan_offsets_[v + 1]);
    for (; fan < fan_end; fan += 64) __builtin_prefetch(fan);
  }
  // Rounding may put a causal update an ulp below the vertex being accepted; the heap needs
  // keys that never decrease.
  distance = std::max(distance, current_key_);
  if (s.state != kTrial) return;
  s.depth = std::min(s.depth, depth);
  if (!(distance < s.distance)) return;
  s.distance = distance;
  heap_push(distance, v);
}

void FastMarchingSolver::accept_neighbours(std::uint32_t v, double dv, std::uint8_t depth) {
  const FanSlot* slot = fan_.data() + fan_offsets_[v];
  const FanSlot* const end = fan_.data() + fan_offsets_[v + 1];
  for (; slot != end; ++slot) {
    const std::uint32_t a = slot->a, b = slot->b;
    if (slot->det < 0) {  // edge-only slot
      if (is_open(a)) relax(a, dv + slot->len_va, depth);
      continue;
    }
    const bool open_a = is_open(a), open_b = is_open(b);
    if (!open_a && !open_b) continue;
    const double va2 = slot->len_va * slot->len_va, vb2 = slot->len_vb * slot->len_vb,
                 ab2 = slot->len_ab * slot->len_ab;
    if (open_a) {
      // Every neighbour is `a` in exactly one slot: the edge value once per edge.
      double t = dv + slot->len_va;
      if (slot->split_a >= 0) {
        t = std::min(t, split_update(splits_[static_cast<std::size_t>(slot->split_a)], v, dv));
      } else if (!open_b) {
        const CornerFace face{va2, ab2, vb2, 0.5 * (va2 + ab2 - vb2), slot->det};
        t = std::min(t, planar_update(dv, state_[b].distance, face));
      }
      relax(a, t, depth);
    }
    if (open_b) {
      double t = kInfinity;
      if (slot->split_b >= 0) {
        t = split_update(splits_[static_cast<std::size_t>(slot->split_b)], v, dv);
      } else if (!open_a) {
        const CornerFace face{vb2, ab2, va2, 0.5 * (vb2 + ab2 - va2), slot->det};
        t = planar_update(dv, state_[a].distance, face);
      }
      if (t < kInfinity) relax(b, t, depth);
    }
  }
  // Corners that v splits (v is their D): the virtual faces (C, X, v) and (C, v, Y), and the
  // straight segment CD, which runs inside the unfolded strip: a real path, like an edge.
  for (std::uint32_t i = split_offsets_[v]; i < split_offsets_[v + 1]; ++i) {
    const Split& split = splits_[splits_by_d_[i]];
    if (!is_open(split.c)) continue;
    double t = dv + split.cd;
    const std::size_t before = stats_.triangle_updates;
    if (is_known(split.x)) {
      t = std::min(t, planar_update(state_[split.x].distance, dv, split.face_xd()));
    }
    if (is_known(split.y)) {
      t = std::min(t, planar_update(dv, state_[split.y].distance, split.face_dy()));
    }
    stats_.unfolded_updates += stats_.triangle_updates - before;
    relax(split.c, t, depth);
  }
}

// ---------------------------------------------------------------------------------------------
// Solves

void FastMarchingSolver::validate(const Options& options) const {
  if (std::isnan(options.max_distance) || options.max_distance < 0) {
    throw InvalidInput(ErrorCode::BadRadius, "max_distance must be a non-negative number");
  }
  if (options.max_unfold_steps < 0) {
    throw InvalidInput(ErrorCode::BadUnfoldSteps, "max_unfold_steps must be >= 0, got " +
                                                      std::to_string(options.max_unfold_steps));
  }
  if (options.lower_halo_rings < 1 || options.lower_halo_rings > 254) {
    throw InvalidInput(ErrorCode::BadHaloRings, "lower_halo_rings must be in [1, 254], got " +
                                                    std::to_string(options.lower_halo_rings));
  }
}

void FastMarchingSolver::reset() {
  ++generation_;
  if (generation_ == 0) {  // wrapped: clear the stamps once every 2^32 solves
    for (VertexState& s : state_) s.stamp = 0;
    generation_ = 1;
  }
  for (std::vector<HeapEntry>& bucket : buckets_) bucket.clear();
  heap_last_ = 0;
  current_key_ = 0;
  lowered_.clear();
  const std::size_t obtuse = stats_.obtuse_corners, unsplit = stats_.unsplit_corners;
  stats_ = {};
  stats_.obtuse_corners = obtuse;
  stats_.unsplit_corners = unsplit;
}

void FastMarchingSolver::add_source(const GeodesicSource& source) {
  const SurfacePoint& p = source.point;
  if (p.kind == SurfacePoint::Kind::Vertex) {
    relax(p.id, source.offset, 0);
    return;
  }
  // The corners of the face(s) containing the point, at their straight distance in the face; an
  // edge point belongs to the faces on both sides.
  auto seed_face = [&](std::uint32_t face, const std::array<double, 3>& bary) {
    const Vec2 q = geometry_->face_point(face, bary.data());
    for (int i = 0; i < 3; ++i) {
      const Vec2 d = minus(q, geometry_->face_corner(face, i));
      relax(mesh_->face(face)[i], source.offset + std::sqrt(dot(d, d)), 0);
    }
  };
  const auto [face, bary] = p.in_face(*mesh_);
  seed_face(face, bary);
  for (int i = 0; i < 3; ++i) {
    if (bary[(i + 2) % 3] > 0) continue;  // not on the edge of halfedge 3f+i
    const std::int32_t twin = mesh_->twin(3 * face + static_cast<std::uint32_t>(i));
    if (twin < 0) continue;
    const auto t = static_cast<std::uint32_t>(twin);
    std::array<double, 3> across{0, 0, 0};
    across[t % 3] = bary[(i + 1) % 3];
    across[(t % 3 + 1) % 3] = bary[i];
    seed_face(TriangleMesh::face_of(t), across);
  }
}

void FastMarchingSolver::run(const Options& options, double* floor) {
  while (heap_refill()) {
    const double key = std::bit_cast<double>(heap_last_);
    if (key > options.max_distance) break;
    const std::uint32_t vertex = buckets_[0].back().vertex;
    buckets_[0].pop_back();
    VertexState& s = state_[vertex];
    if (s.state != kTrial || key != s.distance) continue;  // stale entry
    current_key_ = key;
    if (floor != nullptr && floor[vertex] <= key) {  // (a NaN entry counts as larger)
      // lower(): not lowered here. Its value still serves its neighbours' updates (the fresh
      // field's values there may depend on it), but the walk reaches new vertices only up to
      // lower_halo_rings rings beyond the lowered region.
      s.state = kBlocked;
      accept_neighbours(vertex, key, static_cast<std::uint8_t>(s.depth + 1));
      continue;
    }
    s.state = kAccepted;
    ++stats_.vertices_settled;
    if (floor != nullptr) {
      floor[vertex] = key;
      lowered_.push_back(vertex);
    }
    accept_neighbours(vertex, key, 1);
  }
}

void FastMarchingSolver::solve(std::span<const GeodesicSource> sources, const Options& options) {
  for (const GeodesicSource& s : sources) {
    s.point.validate(*mesh_);
    if (!std::isfinite(s.offset) || s.offset < 0) {
      throw InvalidInput(ErrorCode::BadOffset, "source offset " + std::to_string(s.offset) +
                                                   " must be finite and non-negative");
    }
  }
  validate(options);
  if (options.max_unfold_steps != split_steps_) build_splits(options.max_unfold_steps);
  reset();
  halo_depth_ = 255;
  for (const GeodesicSource& s : sources) add_source(s);
  run(options, nullptr);
}

void FastMarchingSolver::solve(const SurfacePoint& source, const Options& options) {
  const GeodesicSource one{source, 0.0};
  solve(std::span<const GeodesicSource>(&one, 1), options);
}

std::size_t FastMarchingSolver::lower(std::span<double> distances, const SurfacePoint& source,
                                      const Options& options) {
  source.validate(*mesh_);
  validate(options);
  if (distances.size() != mesh_->num_vertices()) {
    throw InvalidInput(ErrorCode::BadDistanceCount,
                       "lower() got " + std::to_string(distances.size()) +
                           " distances for a mesh with " + std::to_string(mesh_->num_vertices()) +
                           " vertices");
  }
  if (options.max_unfold_steps != split_steps_) build_splits(options.max_unfold_steps);
  reset();
  halo_depth_ = static_cast<std::uint8_t>(options.lower_halo_rings);
  add_source({source, 0.0});
  run(options, distances.data());
  return lowered_.size();
}

double FastMarchingSolver::distance(std::uint32_t v) const {
  if (v >= state_.size()) {
    throw InvalidInput(ErrorCode::VertexOutOfRange,
                       "vertex " + std::to_string(v) + " is out of range (mesh has " +
                           std::to_string(state_.size()) + " vertices)");
  }
  const VertexState& s = state_[v];
  return s.stamp == generation_ && s.state == kAccepted ? s.distance : kInfinity;
}

std::vector<double> FastMarchingSolver::vertex_distances() const {
  std::vector<double> out(state_.size(), kInfinity);
  for (std::size_t v = 0; v < state_.size(); ++v) {
    const VertexState& s = state_[v];
    if (s.stamp == generation_ && s.state == kAccepted) out[v] = s.distance;
  }
  return out;
}

std::vector<double> fast_marching_distances(const TriangleMesh& mesh,
                                            const IntrinsicGeometry& geometry,
                                            std::span<const GeodesicSource> sources,
                                            const FastMarchingOptions& options) {
  FastMarchingSolver solver(mesh, geometry);
  solver.solve(sources, options);
  return solver.vertex_distances();
}

}  // namespace geoprox
