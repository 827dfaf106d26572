#include "core/mesh/mesh_repair.h"

#include <algorithm>
#include <array>
#include <numeric>
#include <string>
#include <utility>

#include "core/base/errors.h"
#include "core/base/union_find.h"

namespace geoprox {

namespace {

std::uint64_t undirected_key(std::uint32_t a, std::uint32_t b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}
std::uint32_t corner_origin(const std::vector<Triangle>& faces, std::uint32_t h) {
  return faces[h / 3][h % 3];
}
std::uint32_t corner_target(const std::vector<Triangle>& faces, std::uint32_t h) {
  return faces[h / 3][(h % 3 + 1) % 3];
}

/// For every halfedge, the other halfedge of its undirected edge when exactly two faces use
/// that edge, else -1; counts in `crowded` the edges used by three or more faces (cut open).
std::vector<std::int32_t> pair_halfedges(const std::vector<Triangle>& faces, std::size_t& crowded) {
  const auto nh = static_cast<std::uint32_t>(3 * faces.size());
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(nh);
  for (std::uint32_t h = 0; h < nh; ++h) {
    keyed[h] = {undirected_key(corner_origin(faces, h), corner_target(faces, h)), h};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<std::int32_t> partner(nh, -1);
  for (std::size_t i = 0; i < keyed.size();) {
    std::size_t j = i + 1;
    while (j < keyed.size() && keyed[j].first == keyed[i].first) ++j;
    if (j - i == 2) {
      partner[keyed[i].second] = static_cast<std::int32_t>(keyed[i + 1].second);
      partner[keyed[i + 1].second] = static_cast<std::int32_t>(keyed[i].second);
    } else if (j - i > 2) {
      ++crowded;
    }
    i = j;
  }
  return partner;
}

/// Step 1: which faces stay. Faces that repeat a vertex are dropped, then faces over the
/// vertices of an earlier face (unless the two are a closed two-face surface).
std::vector<std::uint8_t> faces_to_keep(const std::vector<Triangle>& faces, std::uint32_t nv,
                                        MeshRepairReport& report) {
  std::vector<std::pair<Triangle, std::uint32_t>> by_vertices;
  by_vertices.reserve(faces.size());
  for (std::uint32_t f = 0; f < faces.size(); ++f) {
    Triangle t = faces[f];
    for (std::uint32_t v : t) {
      if (v >= nv) {
        throw MeshError(ErrorCode::VertexOutOfRange,
                        "face " + std::to_string(f) + " refers to vertex " + std::to_string(v) +
                            " but the mesh has " + std::to_string(nv) + " vertices");
      }
    }
    if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) {
      ++report.degenerate_faces_dropped;
      continue;
    }
    std::sort(t.begin(), t.end());
    by_vertices.push_back({t, f});
  }
  std::sort(by_vertices.begin(), by_vertices.end());
  // A face and its reverse alone on their three edges are a closed two-face surface, which
  // loads as it is: both stay. Anywhere else a reverse only crowds the edges it shares.
  std::vector<std::uint64_t> edge_uses;
  edge_uses.reserve(3 * by_vertices.size());
  for (const auto& [t, f] : by_vertices) {
    for (int i = 0; i < 3; ++i) edge_uses.push_back(undirected_key(t[i], t[(i + 1) % 3]));
  }
  std::sort(edge_uses.begin(), edge_uses.end());
  auto uses = [&edge_uses](std::uint32_t a, std::uint32_t b) {
    const auto range = std::equal_range(edge_uses.begin(), edge_uses.end(), undirected_key(a, b));
    return range.second - range.first;
  };
  auto same_turn = [](const Triangle& a, const Triangle& b) {
    return (a[0] == b[0] && a[1] == b[1]) || (a[0] == b[1] && a[1] == b[2]) ||
           (a[0] == b[2] && a[1] == b[0]);
  };
  std::vector<std::uint8_t> keep(faces.size(), 0);
  for (std::size_t i = 0; i < by_vertices.size();) {
    std::size_t j = i + 1;
    while (j < by_vertices.size() && by_vertices[j].first == by_vertices[i].first) ++j;
    const Triangle& t = by_vertices[i].first;
    const std::uint32_t first = by_vertices[i].second,
                        second = by_vertices[i + 1 < j ? i + 1 : i].second;
    const bool two_face_surface = j - i == 2 && !same_turn(faces[first], faces[second]) &&
                                  uses(t[0], t[1]) == 2 && uses(t[1], t[2]) == 2 &&
                                  uses(t[2], t[0]) == 2;
    // The lowest face id of its vertex set comes first and stays.
    for (std::size_t k = i; k < j; ++k) {
      if (k == i || two_face_surface) {
        keep[by_vertices[k].second] = 1;
      } else {
        ++report.duplicate_faces_dropped;
      }
    }
    i = j;
  }
  return keep;
}

/// Steps 2 and 3, orientation: each sheet (faces joined through edges of two faces) is
/// oriented by a breadth-first search from its lowest face, and cut (partner -1) where the
/// search meets itself the wrong way round. Returns which faces turn.
std::vector<std::uint8_t> orient_sheets(const std::vector<Triangle>& kept,
                                        std::vector<std::int32_t>& partner, bool orient,
                                        MeshRepairReport& report) {
  const auto nf = static_cast<std::uint32_t>(kept.size());
  std::vector<std::uint8_t> flip(nf, 0), visited(nf, 0);
  std::vector<std::uint32_t> queue;
  for (std::uint32_t seed = 0; seed < nf; ++seed) {
    if (visited[seed]) continue;
    visited[seed] = 1;
    queue.assign(1, seed);
    for (std::size_t q = 0; q < queue.size(); ++q) {
      const std::uint32_t f = queue[q];
      for (std::uint32_t h = 3 * f; h < 3 * f + 3; ++h) {
        if (partner[h] < 0) continue;
        const auto p = static_cast<std::uint32_t>(partner[h]);
        const std::uint32_t g = p / 3;
        // Consistent when the two run the edge in opposite directions once turned.
        const bool opposite = corner_origin(kept, h) == corner_target(kept, p);
        const bool wanted_flip = opposite ? flip[f] : !flip[f];
        if (!visited[g] && orient) {
          visited[g] = 1;
          flip[g] = wanted_flip;
          queue.push_back(g);
        } else if (flip[g] != wanted_flip) {
          // Non-orientable (or orientation left alone): the two sides part here.
          partner[h] = partner[p] = -1;
          ++report.edges_cut;
        } else if (!visited[g]) {
          visited[g] = 1;
          queue.push_back(g);
        }
      }
    }
    // Either orientation of a sheet is consistent: keep the one that turns fewer faces (the
    // lowest face may be the one that was wrong).
    std::size_t turned_faces = 0;
    for (std::uint32_t f : queue) turned_faces += flip[f];
    if (2 * turned_faces > queue.size()) {
      for (std::uint32_t f : queue) flip[f] = !flip[f];
    }
  }
  return flip;
}

/// Turns the flipped faces of `kept` (corners 1 and 2 swapped) and their halfedges' partners.
void turn_faces(const std::vector<std::uint8_t>& flip, std::vector<Triangle>& kept,
                std::vector<std::int32_t>& partner, MeshRepairReport& report) {
  const auto nf = static_cast<std::uint32_t>(kept.size());
  // Turning face (a, b, c) into (a, c, b) reverses its halfedges: a -> b was its halfedge 0
  // and b -> a is now its halfedge 2, and so on (i becomes 2 - i). Partners follow.
  const auto turned = [&flip](std::uint32_t h) {
    return flip[h / 3] ? h - h % 3 + (2 - h % 3) : h;
  };
  std::vector<std::int32_t> turned_partner(partner.size(), -1);
  for (std::uint32_t h = 0; h < partner.size(); ++h) {
    if (partner[h] >= 0) {
      const std::uint32_t p = turned(static_cast<std::uint32_t>(partner[h]));
      turned_partner[turned(h)] = static_cast<std::int32_t>(p);
    }
  }
  partner = std::move(turned_partner);
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (flip[f]) {
      std::swap(kept[f][1], kept[f][2]);
      ++report.faces_flipped;
    }
  }

}

/// Step 4: one vertex per fan. Returns the source vertex of every vertex of the output
/// (copies appended after the input's), with `kept`'s corners moved to the copies.
std::vector<std::uint32_t> split_vertex_fans(std::vector<Triangle>& kept,
                                            const std::vector<std::int32_t>& partner,
                                            std::uint32_t nv, MeshRepairReport& report) {
  const auto nf = static_cast<std::uint32_t>(kept.size());
  // Corner h (of face h / 3, at the origin of halfedge h) shares its
  // vertex with the corner across each of its two edges at that vertex. No directed edge is
  // then used twice: two faces along a cut edge that stay in one fan at an end are that fan's
  // two ends, and a consistently oriented fan runs its end edges in opposite directions.
  UnionFind fans(3 * static_cast<std::size_t>(nf));
  for (std::uint32_t h = 0; h < 3 * nf; ++h) {
    if (partner[h] < 0) continue;
    // next(partner) leaves origin(h).
    fans.unite(h, TriangleMesh::next(static_cast<std::uint32_t>(partner[h])));
  }
  std::vector<std::uint32_t> corner_offsets(nv + 1, 0);
  for (const Triangle& t : kept) {
    for (std::uint32_t v : t) ++corner_offsets[v + 1];
  }
  for (std::uint32_t v = 0; v < nv; ++v) corner_offsets[v + 1] += corner_offsets[v];
  std::vector<std::uint32_t> corners(3 * static_cast<std::size_t>(nf));
  {
    std::vector<std::uint32_t> fill(corner_offsets.begin(), corner_offsets.end() - 1);
    for (std::uint32_t h = 0; h < 3 * nf; ++h) corners[fill[corner_origin(kept, h)]++] = h;
  }
  // The fan holding a vertex's lowest face keeps the vertex; the others get copies, in order
  // of the vertex they copy and then of their lowest face.
  std::vector<std::uint32_t> source_vertex(nv);
  std::iota(source_vertex.begin(), source_vertex.end(), 0u);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> fans_here;  // (lowest face, root)
  for (std::uint32_t v = 0; v < nv; ++v) {
    fans_here.clear();
    for (std::uint32_t i = corner_offsets[v]; i < corner_offsets[v + 1]; ++i) {
      const std::uint32_t h = corners[i];
      const std::uint32_t root = fans.find(h);
      auto it = std::find_if(fans_here.begin(), fans_here.end(),
                             [root](const auto& fan) { return fan.second == root; });
      if (it == fans_here.end()) {
        fans_here.push_back({h / 3, root});
      } else {
        it->first = std::min(it->first, h / 3);
      }
    }
    if (fans_here.size() < 2) continue;
    ++report.vertices_split;
    std::sort(fans_here.begin(), fans_here.end());
    for (std::size_t k = 1; k < fans_here.size(); ++k) {
      const auto copy = static_cast<std::uint32_t>(source_vertex.size());
      source_vertex.push_back(v);
      for (std::uint32_t i = corner_offsets[v]; i < corner_offsets[v + 1]; ++i) {
        const std::uint32_t h = corners[i];
        if (fans.find(h) == fans_here[k].second) kept[h / 3][h % 3] = copy;
      }
    }
  }
  return source_vertex;
}

}  // namespace

RepairedMesh repair_mesh(const std::vector<Vec3>& positions, const std::vector<Triangle>& faces,
                         const MeshRepairOptions& options) {
  if (faces.empty()) {
    throw MeshError(ErrorCode::EmptyMesh, "mesh has no faces (" + std::to_string(positions.size()) +
                                              " vertices, 0 triangles): nothing to repair");
  }
  const auto nv = static_cast<std::uint32_t>(positions.size());
  RepairedMesh out;
  MeshRepairReport& report = out.report;
  report.vertices_in = positions.size();
  report.faces_in = faces.size();

  // 1. Faces that repeat a vertex, then faces over the vertices of an earlier face.
  const std::vector<std::uint8_t> keep = faces_to_keep(faces, nv, report);
  std::vector<Triangle> kept;
  for (std::uint32_t f = 0; f < faces.size(); ++f) {
    if (keep[f]) {
      kept.push_back(faces[f]);
      out.source_face.push_back(f);
    }
  }

  // 2. and 3. Crowded edges are cut; each sheet (faces joined through edges of two faces) is
  // oriented by a breadth-first search from its lowest face, and cut where the search meets
  // itself the wrong way round.
  std::vector<std::int32_t> partner = pair_halfedges(kept, report.edges_cut);
  std::vector<std::uint8_t> flip = orient_sheets(kept, partner, options.orient, report);
  turn_faces(flip, kept, partner, report);
  out.flipped = std::move(flip);

  // 4. One vertex per fan.
  std::vector<std::uint32_t> source_vertex = split_vertex_fans(kept, partner, nv, report);
  report.vertices_added = source_vertex.size() - nv;

  out.positions.reserve(source_vertex.size());
  out.positions.assign(positions.begin(), positions.end());
  for (std::size_t v = nv; v < source_vertex.size(); ++v)
    out.positions.push_back(positions[source_vertex[v]]);
  out.faces = std::move(kept);
  out.source_vertex = std::move(source_vertex);
  report.vertices_out = out.positions.size();
  report.faces_out = out.faces.size();
  return out;
}

namespace {

/// "1 edge cut", "2 edges cut": `count`, the noun in the number it takes, then `what`.
std::string counted(std::size_t count, const char* one, const char* many, const char* what) {
  return std::to_string(count) + ' ' + (count == 1 ? one : many) + what;
}

}  // namespace

bool repair_fixes(ErrorCode code) {
  return code == ErrorCode::NonManifoldVertex || code == ErrorCode::NonManifoldEdge ||
         code == ErrorCode::InconsistentOrientation || code == ErrorCode::DegenerateFaceIndices;
}

std::string describe_repair_changes(const MeshRepairReport& report) {
  if (report.unchanged()) return "nothing changed";
  std::string text;
  auto add = [&text](std::size_t count, const char* one, const char* many, const char* what) {
    if (count == 0) return;
    if (!text.empty()) text += ", ";
    text += counted(count, one, many, what);
  };
  add(report.degenerate_faces_dropped, "degenerate face", "degenerate faces", " dropped");
  add(report.duplicate_faces_dropped, "duplicate face", "duplicate faces", " dropped");
  add(report.edges_cut, "edge", "edges", " cut");
  add(report.faces_flipped, "face", "faces", " flipped");
  if (report.vertices_split != 0) {
    add(report.vertices_split, "vertex", "vertices", " split");
    text += " (+" + counted(report.vertices_added, "copy", "copies", "") + ")";
  }
  return text;
}

}  // namespace geoprox
