#include "core/mesh/mesh_refinement.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <unordered_map>

#include "core/base/errors.h"
#include "core/mesh/refinement_map.h"

namespace geoprox {

namespace {

using Bary = RefinedMesh::Bary;
// The parts a face is split into, with their corners' barycentrics in the input face.
using Parts = std::vector<std::pair<Triangle, std::array<Bary, 3>>>;

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return a < b ? (std::uint64_t{a} << 32) | b : (std::uint64_t{b} << 32) | a;
}

double length_squared(const Vec3& a, const Vec3& b) {
  const Vec3 d = a - b;
  return d.x * d.x + d.y * d.y + d.z * d.z;
}

Bary midpoint(const Bary& a, const Bary& b) {
  return {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2};
}

// The side of a face bisected first: its longest, ties to the lowest corner index (any fixed rule
// does: marks live on edges, which both faces share).
int longest_side(const std::vector<Vec3>& positions, const Triangle& t) {
  int best = 0;
  double best_length = -1;
  for (int k = 0; k < 3; ++k) {
    const double l = length_squared(positions[t[k]], positions[t[(k + 1) % 3]]);
    if (l > best_length) {
      best_length = l;
      best = k;
    }
  }
  return best;
}

/// Marked edge (edge_key) -> its new midpoint vertex, kUnassigned until created.
using MidpointMap = std::unordered_map<std::uint64_t, std::uint32_t>;
constexpr std::uint32_t kUnassigned = UINT32_MAX;

/// Marks the edges longer than the limit, then the longest side of every face with a mark,
/// until stable.
void mark_edges_to_split(const RefinedMesh& out, double limit_squared, MidpointMap& midpoint_of) {
  midpoint_of.clear();
  for (const Triangle& t : out.faces) {
    for (int k = 0; k < 3; ++k) {
      if (length_squared(out.positions[t[k]], out.positions[t[(k + 1) % 3]]) > limit_squared) {
        midpoint_of.emplace(edge_key(t[k], t[(k + 1) % 3]), kUnassigned);
      }
    }
  }
  if (midpoint_of.empty()) return;
  for (bool changed = true; changed;) {
    changed = false;
    for (const Triangle& t : out.faces) {
      bool marked = false;
      for (int k = 0; k < 3; ++k) {
        marked = marked || midpoint_of.count(edge_key(t[k], t[(k + 1) % 3]));
      }
      if (!marked) continue;
      const int s = longest_side(out.positions, t);
      changed =
          midpoint_of.emplace(edge_key(t[s], t[(s + 1) % 3]), kUnassigned).second || changed;
    }
  }
}

/// A key of a face's vertex set (a hash of the sorted ids): a collision only fans a face that
/// needed no fan, which is as valid a split.
std::uint64_t vertex_set_key(Triangle t) {
  std::sort(t.begin(), t.end());
  return std::uint64_t{t[0]} * 0x9E3779B97F4A7C15ull ^ (std::uint64_t{t[1]} << 21) ^
         (std::uint64_t{t[2]} << 42) ^ t[2];
}

/// One round of splits: every face with a mark on its longest side, in face order (new ids
/// come out the same every run). The first part of a split face keeps its id; the others are
/// appended.
class RoundSplitter {
 public:
  RoundSplitter(const TriangleMesh& mesh, RefinedMesh& out, MidpointMap& midpoint_of)
      : mesh_(mesh), out_(out), midpoint_of_(midpoint_of) {
    // Two faces over the same three vertices (a closed two-face surface, which loads) would
    // both draw their inner edges between the same vertices: those faces are split around a
    // new vertex at their centroid instead, whose edges are theirs alone.
    for (const Triangle& t : out_.faces) ++faces_over_[vertex_set_key(t)];
  }

  void split_all() {
    const std::size_t faces_before = out_.faces.size();
    for (std::uint32_t f = 0; f < faces_before; ++f) {
      const Triangle t = out_.faces[f];
      const int s = longest_side(out_.positions, t);
      if (!midpoint_of_.count(edge_key(t[s], t[(s + 1) % 3]))) continue;
      const std::array<Bary, 3> corners = out_.source_bary[f];
      Parts parts;  // the first keeps f's id
      if (faces_over_.at(vertex_set_key(t)) > 1) {
        split_around_centroid(t, corners, f, parts);
      } else {
        split_across_longest_side(t, s, corners, f, parts);
      }
      out_.faces[f] = parts[0].first;
      out_.source_bary[f] = parts[0].second;
      for (std::size_t k = 1; k < parts.size(); ++k) {
        out_.faces.push_back(parts[k].first);
        out_.source_bary.push_back(parts[k].second);
        out_.source_face.push_back(out_.source_face[f]);
      }
    }
  }

 private:
  /// The midpoint vertex of marked edge a-b, created on first use (bary: its barycentrics in
  /// the input face of f).
  std::uint32_t vertex_at(std::uint32_t a, std::uint32_t b, std::uint32_t f, const Bary& bary) {
    std::uint32_t& id = midpoint_of_.at(edge_key(a, b));
    if (id == kUnassigned) {
      id = static_cast<std::uint32_t>(out_.positions.size());
      out_.positions.push_back(0.5 * (out_.positions[a] + out_.positions[b]));
      out_.new_vertex_source.push_back(simplest_point_in_face(mesh_, out_.source_face[f], bary));
    }
    return id;
  }

  /// Splits face f, corners t, across its longest side s (a -> b, with c across it), and again
  /// across b -> c and c -> a where those are marked: 2, 3 or 4 parts, each run the face's way.
  void split_across_longest_side(const Triangle& t, int s, const std::array<Bary, 3>& corners,
                                 std::uint32_t f, Parts& parts) {
    // a -> b is the longest side, c the corner across it; the face runs a, b, c.
    const std::uint32_t a = t[s], b = t[(s + 1) % 3], c = t[(s + 2) % 3];
    const Bary& ba = corners[s];
    const Bary& bb = corners[(s + 1) % 3];
    const Bary& bc = corners[(s + 2) % 3];
    const Bary bm = midpoint(ba, bb);
    const std::uint32_t m = vertex_at(a, b, f, bm);
    const bool split_bc = midpoint_of_.count(edge_key(b, c)) != 0;
    const bool split_ca = midpoint_of_.count(edge_key(c, a)) != 0;
    // The half on a's side, (a, m, c), split again when c -> a is marked.
    if (split_ca) {
      const Bary bp = midpoint(bc, ba);
      const std::uint32_t p = vertex_at(c, a, f, bp);
      parts.push_back({{a, m, p}, {ba, bm, bp}});
      parts.push_back({{p, m, c}, {bp, bm, bc}});
    } else {
      parts.push_back({{a, m, c}, {ba, bm, bc}});
    }
    // The half on b's side, (m, b, c), split again when b -> c is marked.
    if (split_bc) {
      const Bary bn = midpoint(bb, bc);
      const std::uint32_t n = vertex_at(b, c, f, bn);
      parts.push_back({{m, b, n}, {bm, bb, bn}});
      parts.push_back({{m, n, c}, {bm, bn, bc}});
    } else {
      parts.push_back({{m, b, c}, {bm, bb, bc}});
    }
  }

  /// A fan around the centroid: one part per side of the face, or per half of a marked one.
  void split_around_centroid(const Triangle& t, const std::array<Bary, 3>& corners,
                             std::uint32_t f, Parts& parts) {
    std::vector<std::pair<std::uint32_t, Bary>> rim;  // the face's boundary, in its order
    for (int k = 0; k < 3; ++k) {
      const int next = (k + 1) % 3;
      rim.push_back({t[k], corners[k]});
      if (midpoint_of_.count(edge_key(t[k], t[next]))) {
        const Bary mid = midpoint(corners[k], corners[next]);
        rim.push_back({vertex_at(t[k], t[next], f, mid), mid});
      }
    }
    Bary centre{};
    for (int i = 0; i < 3; ++i) {
      centre[i] = (corners[0][i] + corners[1][i] + corners[2][i]) / 3;
    }
    const auto g = static_cast<std::uint32_t>(out_.positions.size());
    out_.positions.push_back((1.0 / 3) * (out_.positions[t[0]] + out_.positions[t[1]] +
                                          out_.positions[t[2]]));
    out_.new_vertex_source.push_back(simplest_point_in_face(mesh_, out_.source_face[f], centre));
    for (std::size_t k = 0; k < rim.size(); ++k) {
      const auto& [u, bu] = rim[k];
      const auto& [w, bw] = rim[(k + 1) % rim.size()];
      parts.push_back({{u, w, g}, {bu, bw, centre}});
    }
  }

  const TriangleMesh& mesh_;
  RefinedMesh& out_;
  MidpointMap& midpoint_of_;
  std::unordered_map<std::uint64_t, std::uint32_t> faces_over_;  ///< vertex set -> faces
};

}  // namespace

RefinedMesh refine_long_edges(const TriangleMesh& mesh, const MeshRefinementOptions& options) {
  const double limit = options.max_edge_length;
  if (!(std::isfinite(limit) && limit > 0)) {
    throw InvalidInput(
        ErrorCode::BadOption,
        "the longest edge allowed must be a positive length, not " + std::to_string(limit));
  }
  RefinedMesh out;
  out.input_vertices = mesh.num_vertices();
  out.input_faces = mesh.num_faces();
  out.positions = mesh.positions();
  out.faces = mesh.faces();
  out.source_face.resize(mesh.num_faces());
  out.source_bary.resize(mesh.num_faces());
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
    out.source_face[f] = f;
    out.source_bary[f] = {Bary{1, 0, 0}, Bary{0, 1, 0}, Bary{0, 0, 1}};
  }
  const double limit_squared = limit * limit;
  MidpointMap midpoint_of;
  while (true) {
    // 1. Mark the long edges, then the longest side of every face with a mark, until stable.
    mark_edges_to_split(out, limit_squared, midpoint_of);
    if (midpoint_of.empty()) break;
    const std::size_t growth = 3 * midpoint_of.size();  // at most 3 new faces per marked edge
    if (out.faces.size() + growth > options.max_faces) {
      throw InvalidInput(ErrorCode::RefinementTooLarge,
                         "refining to edges of at most " + std::to_string(limit) +
                             " would make more than " + std::to_string(options.max_faces) +
                             " faces");
    }
    ++out.rounds;
    out.edges_split += midpoint_of.size();
    // 2. Split every face by its marks.
    RoundSplitter(mesh, out, midpoint_of).split_all();
  }
  return out;
}

SurfacePoint RefinedMesh::to_refined(const TriangleMesh& input, const SurfacePoint& point) const {
  point.validate(input);
  if (point.kind == SurfacePoint::Kind::Vertex) return point;
  const auto [f, b] = point.in_face(input);
  double best_low = -std::numeric_limits<double>::infinity();
  SurfacePoint best = SurfacePoint::face(f, b[0], b[1], b[2]);
  for (std::size_t g = 0; g < faces.size(); ++g) {
    if (source_face[g] != f) continue;
    const auto [low, in_part] = barycentrics_in_part(b, source_bary[g]);
    if (low > best_low) {
      best_low = low;
      best = SurfacePoint::face(static_cast<std::uint32_t>(g), in_part[0], in_part[1], in_part[2]);
    }
  }
  return best;
}

}  // namespace geoprox
