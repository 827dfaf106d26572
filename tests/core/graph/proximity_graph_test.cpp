// Tests of core/graph/proximity_graph.h: Table 1 defaults, farthest-point sampling (spread,
// covering radius, farthest-point property), the graph (symmetry, sorted rows, degree, connectivity
// per mesh component, R), every edge's distance and end directions against fresh exact solves, the
// per-vertex cover table against fresh exact solves, thread-count determinism, two-component
// meshes, the automatic choice of the sampling method, bad options, and one round trip through the
// graph file (core/graph/graph_file.h has its own tests).
//
// Meshes: spot.obj (5856 faces, shipped), blade.off (shipped, poor triangulation), and synthetic
// ones from test_meshes.h (a jittered flat grid with a rectangular hole, a cube, a grid of caps).
// Sample counts are small (50-200) so the whole file runs in a few seconds in RelWithDebInfo.
//
// Tolerances: graph distances are exact geodesic distances, compared to a fresh exact solve to
// 1e-9 relative; directions are floats, compared with the fresh path's as angles around the
// sample (intrinsic, 1e-5 rad); cover distances are floats (1e-6 relative); r at the vertices is
// exact (1e-9), r over the faces an upper bound within 1e-3 (core/geodesic/covering_radius.h,
// tested there).
#include "core/geodesic/geodesic_tracing.h"
#include "core/graph/proximity_graph.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <numeric>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/graph/graph_file.h"
#include "core/mesh/mesh_io.h"
#include "tests/core/test_meshes.h"
#include "tests/core/test_support.h"

namespace geoprox {
namespace {

namespace fs = std::filesystem;
using namespace test_meshes;
using test_support::expect_same_graph;
using test_support::fmt;
using test_support::same_bits;
using test_support::shipped_mesh;
using test_support::spot;

constexpr double kRel = 1e-9;

/// |got - expected| <= rel * max(|expected|, floor).
bool close_rel(double got, double expected, double rel, double floor) {
  return std::abs(got - expected) <= rel * std::max(std::abs(expected), floor);
}

/// r when every vertex of a flat grid of h x h cells split along diagonals is a sample: the
/// farthest points are the middles of the diagonals, h / sqrt(2) from their ends (r is an upper
/// bound within 1e-3 of it).
void expect_grid_of_samples_radius(const ProximityGraph& g, double h) {
  EXPECT_EQ(g.stats.vertex_covering_radius, 0.0);
  EXPECT_GE(g.covering_radius, h / std::numbers::sqrt2 * (1 - 1e-12));
  EXPECT_LE(g.covering_radius, h / std::numbers::sqrt2 * (1 + 1e-3));
}

// ---------------------------------------------------------------------------------------------
// Meshes

/// Flat 30 x 24 grid, jittered, with a 10 x 6 cell hole: geodesics bend at the hole's corners
/// (boundary pseudo-sources), and the jitter breaks the grid's ties between shortest paths.
MeshData holed_jittered_grid_data() {
  GridOptions o;
  o.nx = 30;
  o.ny = 24;
  o.hx = o.hy = 0.1;
  o.jitter = 0.15;
  o.seed = 7;
  o.remove_cell = [](int i, int j) { return i >= 10 && i < 20 && j >= 9 && j < 15; };
  return flat_grid(o);
}

const TestMesh& holed_grid_mesh() {
  static const TestMesh m = make_test_mesh(holed_jittered_grid_data());
  return m;
}

/// Two components: the holed grid, and a cube moved away from it.
MeshData two_component_data() {
  Cube cube = cube_surface(6, 1.0);
  for (Vec3& p : cube.data.positions) p = p + Vec3{10, 0, 0};
  cube.data.face_tag.clear();
  return concatenate(holed_jittered_grid_data(), cube.data);
}

/// Mesh components as a label per vertex (-1 for isolated vertices).
std::vector<int> component_labels(const TriangleMesh& mesh, int& count) {
  std::vector<std::uint32_t> parent(mesh.num_vertices());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const Triangle& t : mesh.faces()) {
    for (int k = 0; k < 2; ++k) {
      const std::uint32_t a = find(t[k]), b = find(t[k + 1]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  std::vector<int> label(mesh.num_vertices(), -1);
  std::map<std::uint32_t, int> ids;
  count = 0;
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    if (mesh.is_isolated_vertex(v)) continue;
    auto [it, inserted] = ids.try_emplace(find(v), count);
    if (inserted) ++count;
    label[v] = it->second;
  }
  return label;
}

ProximityGraph build(const TestMesh& m, std::uint32_t samples, std::uint32_t neighbors,
                     SamplingMethod sampling, int threads = 0) {
  ProximityGraphOptions o;
  o.num_samples = samples;
  o.neighbors = neighbors;
  o.sampling = sampling;
  o.threads = threads;
  o.refine_long_faces = false;  // the graph on the mesh as given, whatever its samples leave
  return build_proximity_graph(*m.mesh, *m.geometry, o);
}

// Graphs shared by several tests (built once).
const ProximityGraph& spot_fmm_graph() {
  static const ProximityGraph g = build(spot(), 150, 10, SamplingMethod::FastMarching);
  return g;
}
const ProximityGraph& spot_exact_graph() {
  static const ProximityGraph g = build(spot(), 100, 10, SamplingMethod::Exact);
  return g;
}
const ProximityGraph& grid_graph() {
  static const ProximityGraph g = build(holed_grid_mesh(), 80, 8, SamplingMethod::FastMarching);
  return g;
}

/// Index of edge i -> j in the CSR rows, or -1.
std::int64_t find_edge(const ProximityGraph& g, std::uint32_t i, std::uint32_t j) {
  const auto b = g.edge_target.begin() + g.edge_offsets[i];
  const auto e = g.edge_target.begin() + g.edge_offsets[i + 1];
  const auto it = std::lower_bound(b, e, j);
  return it != e && *it == j ? it - g.edge_target.begin() : -1;
}

// ---------------------------------------------------------------------------------------------
// Checks shared by the tests

/// Array sizes, symmetry, no self loops, sorted rows, degree, R, connectivity within each mesh
/// component and no edge across components.
void check_structure(const TestMesh& m, const ProximityGraph& g, const std::string& what) {
  SCOPED_TRACE(what);
  const TriangleMesh& mesh = *m.mesh;
  const auto n = static_cast<std::uint32_t>(g.sample_vertex.size());
  ASSERT_GT(n, 0u);
  ASSERT_EQ(g.num_vertices, mesh.num_vertices());
  ASSERT_EQ(g.edge_offsets.size(), n + 1);
  ASSERT_EQ(g.edge_offsets.front(), 0u);
  ASSERT_EQ(g.edge_offsets.back(), g.edge_target.size());
  ASSERT_EQ(g.edge_distance.size(), g.edge_target.size());
  ASSERT_EQ(g.edge_direction.size(), g.edge_target.size());
  ASSERT_EQ(g.cover_offsets.size(), mesh.num_vertices() + 1);
  ASSERT_EQ(g.cover_offsets.front(), 0u);
  ASSERT_EQ(g.cover_offsets.back(), g.cover_sample.size());
  ASSERT_EQ(g.cover_distance.size(), g.cover_sample.size());
  const ProximityGraphView view = g.view();
  EXPECT_EQ(view.num_samples, n);
  EXPECT_EQ(view.num_edges(), g.edge_target.size());

  // Samples: distinct vertices in faces.
  std::vector<std::uint32_t> sorted = g.sample_vertex;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end())
      << "a vertex is sampled twice";
  for (std::uint32_t v : g.sample_vertex) {
    ASSERT_LT(v, mesh.num_vertices());
    EXPECT_FALSE(mesh.is_isolated_vertex(v)) << "isolated vertex " << v << " sampled";
  }

  int components = 0;
  const std::vector<int> label = component_labels(mesh, components);
  std::vector<std::uint32_t> samples_in(components, 0);
  for (std::uint32_t v : g.sample_vertex) ++samples_in[label[v]];
  EXPECT_EQ(g.stats.components, static_cast<std::size_t>(components));

  std::vector<std::uint32_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  double longest = 0;
  int failures = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t b = g.edge_offsets[i], e = g.edge_offsets[i + 1];
    ASSERT_LE(b, e);
    const std::uint32_t in_component = samples_in[label[g.sample_vertex[i]]];
    EXPECT_GE(e - b, std::min(g.neighbors, in_component - 1))
        << "sample " << i << " has degree " << e - b;
    for (std::uint32_t k = b; k < e; ++k) {
      const std::uint32_t j = g.edge_target[k];
      ASSERT_LT(j, n);
      if (failures > 10) continue;
      if (j == i) {
        ADD_FAILURE() << "self loop at sample " << i;
        ++failures;
      }
      if (k > b && !(g.edge_target[k - 1] < j)) {
        ADD_FAILURE() << "row " << i << " not strictly increasing at " << k;
        ++failures;
      }
      if (label[g.sample_vertex[i]] != label[g.sample_vertex[j]]) {
        ADD_FAILURE() << "edge " << i << " -> " << j << " joins two mesh components";
        ++failures;
      }
      const double d = g.edge_distance[k];
      if (!(std::isfinite(d) && d > 0)) {
        ADD_FAILURE() << "edge " << i << " -> " << j << " has distance " << fmt(d);
        ++failures;
      }
      longest = std::max(longest, d);
      const std::int64_t back = find_edge(g, j, i);
      if (back < 0) {
        ADD_FAILURE() << "edge " << i << " -> " << j << " has no reverse";
        ++failures;
      } else if (std::bit_cast<std::uint64_t>(g.edge_distance[static_cast<std::size_t>(back)]) !=
                 std::bit_cast<std::uint64_t>(d)) {
        ADD_FAILURE() << "edge " << i << " <-> " << j << " distances differ: " << fmt(d) << " vs "
                      << fmt(g.edge_distance[static_cast<std::size_t>(back)]);
        ++failures;
      }
      const std::uint32_t a = find(i), c = find(j);
      if (a != c) parent[std::max(a, c)] = std::min(a, c);
    }
  }
  EXPECT_EQ(failures, 0);
  EXPECT_EQ(g.longest_edge, longest) << "R is not the longest edge";
  EXPECT_EQ(view.longest_edge, g.longest_edge);
  EXPECT_EQ(view.covering_radius, g.covering_radius);

  // Connected within each component: one piece per component that has samples.
  std::vector<std::int64_t> piece_of_component(components, -1);
  for (std::uint32_t i = 0; i < n; ++i) {
    const int c = label[g.sample_vertex[i]];
    const std::uint32_t root = find(i);
    if (piece_of_component[c] < 0) piece_of_component[c] = root;
    EXPECT_EQ(piece_of_component[c], static_cast<std::int64_t>(root))
        << "sample " << i << " is not connected to the rest of mesh component " << c;
  }

  // r counts the faces' insides: never below the vertices' own distances.
  EXPECT_GE(g.covering_radius, g.stats.vertex_covering_radius);
  // The Theorem 4.2 bound, with R the link radius (every pair of samples within it is linked).
  const double denom = g.link_radius - 2 * g.covering_radius;
  if (denom > 0) {
    EXPECT_DOUBLE_EQ(view.error_bound(), 2 * g.covering_radius / denom);
  } else {
    EXPECT_TRUE(std::isinf(view.error_bound()));
  }
}

/// A face-frame direction at vertex v placed around v, intrinsically (from the face layouts,
/// never positions): `angle` counter-clockwise from the first halfedge of v's fan (for a boundary
/// vertex the one with no face clockwise of it) through the corner angles of the faces before
/// the direction's face; `within` the angle inside that face's corner (in [0, corner] when the
/// direction leaves v into the face); `total` the angle sum around v.
struct AroundVertex {
  double angle = 0, within = 0, corner = 0, total = 0;
  bool boundary = false;
};

/// nullopt if `face` does not have v as a corner.
std::optional<AroundVertex> around_vertex(const TestMesh& m, std::uint32_t v, std::uint32_t face,
                                          double x, double y) {
  const TriangleMesh& mesh = *m.mesh;
  const IntrinsicGeometry& g = *m.geometry;
  // Corner angle at the origin of halfedge h, and the angle of (x, y) from h within its face.
  auto corner_of = [&](std::uint32_t h, double dx, double dy, double* within) {
    const std::uint32_t f = h / 3;
    const int i = static_cast<int>(h % 3);
    const Vec2 c = g.face_corner(f, i), a = g.face_corner(f, (i + 1) % 3),
               b = g.face_corner(f, (i + 2) % 3);
    const double e1x = a.x - c.x, e1y = a.y - c.y, e2x = b.x - c.x, e2y = b.y - c.y;
    if (within != nullptr) {
      *within = std::atan2(e1x * dy - e1y * dx, e1x * dx + e1y * dy);
    }
    return std::atan2(std::abs(e1x * e2y - e1y * e2x), e1x * e2x + e1y * e2y);
  };
  const auto out = mesh.outgoing_halfedges(v);
  if (out.empty()) return std::nullopt;
  std::uint32_t start = out[0];
  AroundVertex r;
  for (std::uint32_t h : out) {
    if (mesh.twin(h) < 0) {
      start = h;
      r.boundary = true;
    }
  }
  bool found = false;
  std::uint32_t h = start;
  for (std::size_t step = 0; step < out.size(); ++step) {
    double within = 0;
    const double corner = corner_of(h, x, y, &within);
    if (h / 3 == face) {
      found = true;
      r.angle = r.total + within;
      r.within = within;
      r.corner = corner;
    }
    r.total += corner;
    const std::int32_t next = mesh.twin(TriangleMesh::prev(h));
    if (next < 0 || static_cast<std::uint32_t>(next) == start) break;
    h = static_cast<std::uint32_t>(next);
  }
  if (!found) return std::nullopt;
  return r;
}

/// Every edge's distance against a fresh exact solve from its sample (1e-9 relative), and
/// (optionally) the stored direction at i towards j: unit, in a face around sample i that it
/// leaves into (within the face's corner at i), and at the same angle around sample i as the
/// fresh path's direction at its source (1e-5 rad); or (0, 0), "unknown", at a corner of a
/// zero-area face only. Failures are counted per edge and kind; the first few are printed.
void check_edges_exact(const TestMesh& m, const ProximityGraph& g, bool directions,
                       const std::string& what) {
  SCOPED_TRACE(what);
  const TriangleMesh& mesh = *m.mesh;
  const double floor = 1e-4 * bbox_diagonal(mesh);
  ExactGeodesicSolver solver(mesh, *m.geometry);
  const auto n = static_cast<std::uint32_t>(g.sample_vertex.size());
  std::size_t checked = 0, bad_distance = 0, bad_face = 0, bad_unit = 0, bad_wedge = 0,
              bad_direction = 0, unknown = 0, fresh_elsewhere = 0, ties = 0;
  double worst_distance = 0, worst_direction = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t b = g.edge_offsets[i], e = g.edge_offsets[i + 1];
    if (b == e) continue;
    double reach = 0;
    for (std::uint32_t k = b; k < e; ++k) reach = std::max(reach, g.edge_distance[k]);
    ExactGeodesicOptions o;
    o.max_distance = reach * (1 + 1e-6) + 1e-12;
    solver.solve(SurfacePoint::vertex(g.sample_vertex[i]), o);
    const std::uint32_t vi = g.sample_vertex[i];
    for (std::uint32_t k = b; k < e; ++k) {
      const std::uint32_t j = g.edge_target[k];
      const std::uint32_t vj = g.sample_vertex[j];
      const std::string edge = "edge " + std::to_string(i) + " -> " + std::to_string(j) +
                               " (vertices " + std::to_string(vi) + " -> " +
                               std::to_string(vj) + ")";
      const double fresh = solver.distance(vj);
      ++checked;
      worst_distance =
          std::max(worst_distance, std::abs(g.edge_distance[k] - fresh) / std::max(fresh, floor));
      if (!close_rel(g.edge_distance[k], fresh, kRel, floor) && ++bad_distance <= 3) {
        ADD_FAILURE() << edge << ": stored distance " << fmt(g.edge_distance[k])
                      << ", fresh exact " << fmt(fresh);
      }
      if (!directions) continue;
      const GraphDirection& stored = g.edge_direction[k];
      ASSERT_LT(stored.face, mesh.num_faces());
      const std::string shown = "(face " + std::to_string(stored.face) + ": " +
                                fmt(stored.x) + ", " + fmt(stored.y) + ")";
      const Triangle& f = mesh.face(stored.face);
      if (f[0] != vi && f[1] != vi && f[2] != vi) {
        if (++bad_face <= 3) {
          ADD_FAILURE() << edge << ": direction " << shown
                        << " is in a face that does not contain the sample's vertex";
        }
        continue;
      }
      if (stored.x == 0 && stored.y == 0) {
        // "Unknown" (GraphDirection): allowed only where a zero-area face makes it so.
        if (!m.geometry->is_degenerate_vertex(vi) && ++bad_unit <= 3) {
          ADD_FAILURE() << edge << ": direction stored as unknown (0, 0), but sample vertex "
                        << vi << " is not a corner of a zero-area face";
        }
        ++unknown;
        continue;
      }
      if (std::abs(std::hypot(stored.x, stored.y) - 1) > 1e-6 && ++bad_unit <= 3) {
        ADD_FAILURE() << edge << ": direction " << shown << " is not a unit vector";
      }
      const auto here = around_vertex(m, vi, stored.face, stored.x, stored.y);
      GEOPROX_ASSERT(here.has_value(), "face checked above");
      if (!(here->within >= -1e-6 && here->within <= here->corner + 1e-6) && ++bad_wedge <= 3) {
        ADD_FAILURE() << edge << ": direction " << shown << " points outside its face's corner "
                      << "at the sample (" << here->within << " rad from its first edge, corner "
                      << here->corner << " rad)";
      }
      const GeodesicPath path = solver.path_to(SurfacePoint::vertex(vj));
      const FaceDirection& want = path.direction_at_source;
      const auto fresh_here = around_vertex(m, vi, want.face, want.x, want.y);
      if (!fresh_here) {
        // The solver describes a path leaving the long side of a zero-area face in the face
        // across it (GraphDirection: the graph then stores "unknown"): nothing to compare.
        ++fresh_elsewhere;
        continue;
      }
      // Compare as angles around the vertex (intrinsic: faces around a vertex are not coplanar).
      double err_dir = here->angle - fresh_here->angle;
      if (!here->boundary) err_dir = std::remainder(err_dir, here->total);
      err_dir = std::abs(err_dir);
      if (err_dir > 1e-5) {
        // Two shortest paths of the same length (spot is mirror-symmetric): which one a solve
        // reports depends on the order of equal keys. The stored direction is right if the
        // geodesic traced from it for the stored distance ends at the target.
        const GeodesicTrace trace = trace_geodesic(mesh, *m.geometry, SurfacePoint::vertex(vi),
                                                   {stored.face, stored.x, stored.y},
                                                   g.edge_distance[k]);
        const Vec3 end = trace.points.back().position, target = mesh.position(vj);
        const double miss = std::hypot(end.x - target.x, end.y - target.y, end.z - target.z);
        if (trace.stop == TraceStop::Completed && miss <= 1e-7 * bbox_diagonal(mesh)) {
          ++ties;
          continue;
        }
      }
      worst_direction = std::max(worst_direction, err_dir);
      if (err_dir > 1e-5 && ++bad_direction <= 3) {
        ADD_FAILURE() << edge << ": stored direction " << shown << ", fresh path's (face "
                      << want.face << ": " << fmt(want.x) << ", " << fmt(want.y)
                      << "), angles around the vertex " << fmt(here->angle) << " and "
                      << fmt(fresh_here->angle) << " rad";
      }
    }
  }
  EXPECT_EQ(bad_distance, 0u) << "edges with a wrong distance, of " << checked;
  EXPECT_EQ(bad_face, 0u) << "edges whose direction is in a face not at the sample, of "
                          << checked;
  EXPECT_EQ(bad_unit, 0u) << "edges whose direction is not unit, of " << checked;
  EXPECT_EQ(bad_wedge, 0u) << "edges whose direction points outside its face, of " << checked;
  EXPECT_EQ(bad_direction, 0u) << "edges whose direction differs from a fresh path's, of "
                               << checked;
  std::printf("[ info ] %s: %zu edges, worst distance error %.3g (relative), worst direction "
              "error %.3g rad, %zu unknown, %zu not comparable, %zu equal-length paths\n",
              what.c_str(), checked, worst_distance, worst_direction, unknown, fresh_elsewhere,
              ties);
}

/// Every cover entry against a fresh exact solve from its sample (float precision), rows
/// strictly increasing in sample, each sample covers its own vertex at 0, every vertex is covered
/// when R >= 2r, and then r is the largest smallest cover distance (to float precision).
void check_cover_table(const TestMesh& m, const ProximityGraph& g, const std::string& what) {
  SCOPED_TRACE(what);
  const TriangleMesh& mesh = *m.mesh;
  const auto n = static_cast<std::uint32_t>(g.sample_vertex.size());
  const auto nv = static_cast<std::uint32_t>(mesh.num_vertices());
  const double floor = 1e-6 * bbox_diagonal(mesh);
  // Entries by sample: (vertex, distance).
  std::vector<std::vector<std::pair<std::uint32_t, float>>> by_sample(n);
  int failures = 0;
  std::uint32_t uncovered = 0;
  double r_from_table = 0;
  for (std::uint32_t v = 0; v < nv; ++v) {
    const std::uint32_t b = g.cover_offsets[v], e = g.cover_offsets[v + 1];
    ASSERT_LE(b, e);
    if (mesh.is_isolated_vertex(v)) {
      EXPECT_EQ(b, e) << "isolated vertex " << v << " has covers";
      continue;
    }
    if (b == e) {
      ++uncovered;
      continue;
    }
    float best = std::numeric_limits<float>::infinity();
    for (std::uint32_t k = b; k < e; ++k) {
      const std::uint32_t s = g.cover_sample[k];
      ASSERT_LT(s, n);
      if (k > b && !(g.cover_sample[k - 1] < s) && ++failures <= 5) {
        ADD_FAILURE() << "cover row of vertex " << v << " not strictly increasing";
      }
      by_sample[s].push_back({v, g.cover_distance[k]});
      best = std::min(best, g.cover_distance[k]);
    }
    r_from_table = std::max(r_from_table, static_cast<double>(best));
  }
  // Every sample's solve reaches the link radius: a vertex that close to a sample is covered.
  if (g.stats.vertex_covering_radius <= g.link_radius) {
    EXPECT_EQ(uncovered, 0u) << "every vertex is within rho = " << fmt(g.link_radius)
                             << " of a sample, but " << uncovered << " vertices have no cover";
  }
  if (uncovered == 0) {
    // r at the vertices is the largest distance from a vertex to its nearest covering sample;
    // the table holds the floats at or just above the exact distances, and that rounding
    // commutes with min and max.
    const double r_vertices = g.stats.vertex_covering_radius;
    float r_up = static_cast<float>(r_vertices);
    if (static_cast<double>(r_up) < r_vertices) {
      r_up = std::nextafter(r_up, std::numeric_limits<float>::infinity());
    }
    EXPECT_EQ(r_up, static_cast<float>(r_from_table))
        << fmt(r_vertices) << " vs " << fmt(r_from_table);
  }

  ExactGeodesicSolver solver(mesh, *m.geometry);
  std::size_t checked = 0;
  double worst = 0;
  for (std::uint32_t s = 0; s < n; ++s) {
    const auto& entries = by_sample[s];
    const std::uint32_t vs = g.sample_vertex[s];
    const bool has_self = std::any_of(entries.begin(), entries.end(), [&](const auto& entry) {
      return entry.first == vs && entry.second == 0.0f;
    });
    if (!has_self && ++failures <= 5) {
      ADD_FAILURE() << "sample " << s << " does not cover its own vertex " << vs << " at 0";
    }
    double reach = 0;
    for (const auto& [v, d] : entries) reach = std::max(reach, static_cast<double>(d));
    ExactGeodesicOptions o;
    o.max_distance = reach * (1 + 1e-5) + 1e-12;
    solver.solve(SurfacePoint::vertex(vs), o);
    for (const auto& [v, d] : entries) {
      const double fresh = solver.distance(v);
      ++checked;
      worst = std::max(worst, std::abs(d - fresh) / std::max(fresh, floor));
      if (!close_rel(d, fresh, 1e-6, floor) && ++failures <= 5) {
        ADD_FAILURE() << "cover of vertex " << v << " by sample " << s << ": stored "
                      << fmt(d) << ", fresh exact " << fmt(fresh);
      }
      // Rounded up, never down: graph answers built from covers stay lengths of real paths.
      if (static_cast<double>(d) < fresh * (1 - 1e-12) && ++failures <= 5) {
        ADD_FAILURE() << "cover of vertex " << v << " by sample " << s << " is below the exact "
                      << "distance: stored " << fmt(d) << ", fresh exact " << fmt(fresh);
      }
    }
  }
  EXPECT_EQ(failures, 0) << failures << " mismatches over " << checked << " cover entries";
  std::printf("[ info ] %s: %zu cover entries (%.1f per vertex), worst error %.3g (relative)\n",
              what.c_str(), checked, static_cast<double>(checked) / nv, worst);
}

/// Exact distance of every vertex to its nearest sample (one multi-source exact solve).
std::vector<double> distance_to_samples(const TestMesh& m,
                                        const std::vector<std::uint32_t>& samples) {
  std::vector<GeodesicSource> sources;
  for (std::uint32_t v : samples) sources.push_back({SurfacePoint::vertex(v), 0.0});
  return exact_geodesic_distances(*m.mesh, *m.geometry, sources);
}

double max_finite(const TriangleMesh& mesh, const std::vector<double>& field) {
  double r = 0;
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    if (mesh.is_isolated_vertex(v)) continue;
    EXPECT_TRUE(std::isfinite(field[v])) << "vertex " << v << " not reached from any sample";
    if (std::isfinite(field[v])) r = std::max(r, field[v]);
  }
  return r;
}

// ---------------------------------------------------------------------------------------------
// Table 1

TEST(DefaultGraphSize, ReproducesTable1Rows) {
  using P = std::pair<std::uint32_t, std::uint32_t>;
  EXPECT_EQ(default_graph_size(10'000), (P{1300, 22}));
  EXPECT_EQ(default_graph_size(20'000), (P{1500, 21}));
  EXPECT_EQ(default_graph_size(50'000), (P{2300, 18}));
  EXPECT_EQ(default_graph_size(100'000), (P{5000, 18}));
  EXPECT_EQ(default_graph_size(200'000), (P{10000, 18}));
  EXPECT_EQ(default_graph_size(300'000), (P{15000, 18}));
}

TEST(DefaultGraphSize, InterpolatesBetweenRowsAndClampsAtTheEnds) {
  using P = std::pair<std::uint32_t, std::uint32_t>;
  // Clamped below the first and above the last row.
  EXPECT_EQ(default_graph_size(0), (P{1300, 22}));
  EXPECT_EQ(default_graph_size(5'856), (P{1300, 22}));
  EXPECT_EQ(default_graph_size(1'000'000), (P{15000, 18}));
  // Midpoints (linear in the face count, rounded).
  EXPECT_EQ(default_graph_size(15'000).first, 1400u);
  EXPECT_EQ(default_graph_size(35'000).first, 1900u);
  EXPECT_EQ(default_graph_size(35'000).second, 20u);  // 19.5 rounds up
  EXPECT_EQ(default_graph_size(75'000), (P{3650, 18}));
  EXPECT_EQ(default_graph_size(150'000), (P{7500, 18}));
  EXPECT_EQ(default_graph_size(250'000), (P{12500, 18}));
  EXPECT_EQ(default_graph_size(12'000), (P{1340, 22}));  // 21.8 -> 22
  EXPECT_EQ(default_graph_size(26'000), (P{1660, 20}));  // 20.4 -> 20
  // n_P never decreases with the face count; m_P stays within the table's range.
  std::uint32_t previous_samples = 0;
  for (std::size_t faces = 0; faces <= 400'000; faces += 997) {
    const auto [samples, neighbors] = default_graph_size(faces);
    EXPECT_GE(samples, previous_samples) << faces;
    EXPECT_GE(neighbors, 18u) << faces;
    EXPECT_LE(neighbors, 22u) << faces;
    previous_samples = samples;
  }
}

TEST(ProximityGraph, DefaultsComeFromTable1) {
  // A 12 x 12 grid has 288 faces: Table 1 asks for 1300 samples, more than its 169 vertices, so
  // the default is clamped to every vertex (only an explicit count is refused).
  const TestMesh m = make_test_mesh(flat_grid({.nx = 12, .ny = 12}));
  const ProximityGraph g = build_proximity_graph(*m.mesh, *m.geometry);
  EXPECT_EQ(g.neighbors, 22u);
  EXPECT_EQ(g.sample_vertex.size(), m.mesh->num_vertices());
  expect_grid_of_samples_radius(g, 0.1);
  check_structure(m, g, "12x12 grid, defaults");
}

// ---------------------------------------------------------------------------------------------
// Sampling

TEST(ProximityGraph, ExactSamplingCoveringRadiusIsExact) {
  // With exact sampling r is the largest distance from any vertex to its nearest sample.
  const TestMesh& m = spot();
  const ProximityGraph& g = spot_exact_graph();
  EXPECT_EQ(g.stats.sampling_used, SamplingMethod::Exact);
  ASSERT_EQ(g.sample_vertex.size(), 100u);
  const double r = max_finite(*m.mesh, distance_to_samples(m, g.sample_vertex));
  EXPECT_GT(r, 0);
  EXPECT_TRUE(close_rel(g.stats.vertex_covering_radius, r, kRel, 0))
      << "vertex_covering_radius " << fmt(g.stats.vertex_covering_radius)
      << ", max over vertices of the exact "
      << "distance to the nearest sample " << fmt(r) << " (relative difference "
      << std::abs(g.stats.vertex_covering_radius - r) / r << "; rounded to float it would be "
      << fmt(static_cast<float>(r)) << ")";
}

TEST(ProximityGraph, FastMarchingSamplingCoveringRadiusIsTheExactCoveringDistance) {
  for (const auto& [name, mesh, graph] :
       {std::tuple<const char*, const TestMesh*, const ProximityGraph*>{"spot", &spot(),
                                                                          &spot_fmm_graph()},
        {"holed grid", &holed_grid_mesh(), &grid_graph()}}) {
    SCOPED_TRACE(name);
    EXPECT_EQ(graph->stats.sampling_used, SamplingMethod::FastMarching);
    const double r = max_finite(*mesh->mesh, distance_to_samples(*mesh, graph->sample_vertex));
    EXPECT_TRUE(close_rel(graph->stats.vertex_covering_radius, r, 1e-6, 0))
        << "vertex_covering_radius " << fmt(graph->stats.vertex_covering_radius)
        << ", exact covering distance "
        << fmt(r);
  }
}

TEST(ProximityGraph, ExactSamplingIsFarthestPointSampling) {
  // Replays farthest-point sampling with full single-source exact solves: each sample must be a
  // farthest vertex from the previous ones (up to ties), so the distance at which it is picked
  // never increases; the last field's maximum is r.
  const TestMesh& m = spot();
  const ProximityGraph g = build(m, 50, 6, SamplingMethod::Exact);
  ASSERT_EQ(g.sample_vertex.size(), 50u);
  const TriangleMesh& mesh = *m.mesh;
  const auto nv = static_cast<std::uint32_t>(mesh.num_vertices());
  ExactGeodesicSolver solver(mesh, *m.geometry);
  std::vector<double> field(nv, kInfinity);
  double previous_pick = kInfinity;
  for (std::size_t k = 0; k < g.sample_vertex.size(); ++k) {
    const std::uint32_t s = g.sample_vertex[k];
    if (k > 0) {
      const double farthest = *std::max_element(field.begin(), field.end());
      EXPECT_TRUE(close_rel(field[s], farthest, kRel, 0))
          << "sample " << k << " (vertex " << s << ") is at " << fmt(field[s])
          << " from the previous samples; the farthest vertex is at " << fmt(farthest);
      EXPECT_LE(field[s], previous_pick * (1 + kRel)) << "sample " << k;
      previous_pick = field[s];
    } else {
      EXPECT_EQ(s, 0u) << "the first sample is the lowest vertex id (all at infinity)";
    }
    solver.solve(SurfacePoint::vertex(s));
    for (std::uint32_t v = 0; v < nv; ++v) field[v] = std::min(field[v], solver.distance(v));
  }
  // r itself to float precision here (ExactSamplingCoveringRadiusIsExact asks for 1e-9).
  const double r = *std::max_element(field.begin(), field.end());
  EXPECT_TRUE(close_rel(g.stats.vertex_covering_radius, r, 1e-6, 0))
      << fmt(g.stats.vertex_covering_radius) << " vs " << fmt(r);
  // Samples are at least r apart (each was at least r from all earlier ones).
  EXPECT_GE(previous_pick, r * (1 - kRel));
}

TEST(ProximityGraph, CoveringRadiusShrinksWithMoreSamples) {
  // Exact sampling is deterministic and greedy: the first 50 of 200 samples are the 50 samples,
  // and r(n) does not increase with n.
  const TestMesh& m = spot();
  const ProximityGraph g50 = build(m, 50, 4, SamplingMethod::Exact);
  const ProximityGraph& g100 = spot_exact_graph();
  const ProximityGraph g200 = build(m, 200, 4, SamplingMethod::Exact);
  ASSERT_EQ(g200.sample_vertex.size(), 200u);
  EXPECT_TRUE(std::equal(g50.sample_vertex.begin(), g50.sample_vertex.end(),
                         g200.sample_vertex.begin()));
  EXPECT_TRUE(std::equal(g100.sample_vertex.begin(), g100.sample_vertex.end(),
                         g200.sample_vertex.begin()));
  EXPECT_GE(g50.covering_radius, g100.covering_radius);
  EXPECT_GE(g100.covering_radius, g200.covering_radius);
  EXPECT_GT(g200.covering_radius, 0);
  // Evenly spread: on a surface of area A, n disks of radius r cover it, so n pi r^2 >~ A;
  // and r(200) is roughly half r(50) (area per sample / 4).
  const double ratio = g200.covering_radius / g50.covering_radius;
  EXPECT_GT(ratio, 0.3);
  EXPECT_LT(ratio, 0.8);
  std::printf("[ info ] spot exact sampling: r(50) = %.6g, r(100) = %.6g, r(200) = %.6g\n",
              g50.covering_radius, g100.covering_radius, g200.covering_radius);
}

TEST(ProximityGraph, FastMarchingSamplingSpreadsEvenly) {
  // FMM sampling is only approximately farthest-point on exact distances: every sample pair is
  // still at least ~r apart, and r is close to the exact-sampling one.
  const TestMesh& m = spot();
  const ProximityGraph& fmm = spot_fmm_graph();
  const ProximityGraph exact = build(m, 150, 4, SamplingMethod::Exact);
  // Over the vertices, which is what sampling spreads the samples over.
  const double r_fmm = fmm.stats.vertex_covering_radius;
  EXPECT_NEAR(r_fmm / exact.stats.vertex_covering_radius, 1.0, 0.1);
  double shortest = kInfinity;
  for (double d : fmm.edge_distance) shortest = std::min(shortest, d);
  EXPECT_GT(shortest, 0.8 * r_fmm)
      << "two samples at " << fmt(shortest) << " with r = " << fmt(r_fmm);
}

// ---------------------------------------------------------------------------------------------
// Graph

TEST(ProximityGraph, GraphSizeForError) {
  // The fit of docs/accuracy.md: mean = 0.4169 m^-1.577, the smallest m_P meeting the target.
  const GraphSizeForError half = graph_size_for_error(100'000, 0.005);
  EXPECT_EQ(half.neighbors, 17u);
  EXPECT_EQ(half.num_samples, 5000u);
  EXPECT_LE(half.predicted_mean, 0.005);
  EXPECT_GT(0.4169 * std::pow(16.0, -1.577), 0.005);  // 16 would not do
  EXPECT_NEAR(half.predicted_mean, 0.4169 * std::pow(17.0, -1.577), 1e-12);
  EXPECT_NEAR(half.predicted_p99, 0.5693 * std::pow(17.0, -1.288), 1e-12);
  EXPECT_EQ(graph_size_for_error(100'000, 0.009).neighbors, 12u);
  EXPECT_EQ(graph_size_for_error(10'000, 0.5).neighbors, 4u);     // clamped low
  EXPECT_EQ(graph_size_for_error(10'000, 1e-6).neighbors, 64u);   // clamped high
  EXPECT_EQ(graph_size_for_error(10'000, 0.005).num_samples, 1300u);
  for (double bad : {0.0, -0.1, 1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    try {
      graph_size_for_error(10'000, bad);
      ADD_FAILURE() << "accepted target error " << bad;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.reason(), "BadTargetError");
    }
  }
}

TEST(ProximityGraph, StructureOnSpot) {
  check_structure(spot(), spot_fmm_graph(), "spot fmm 150/10");
  check_structure(spot(), spot_exact_graph(), "spot exact 100/10");
  const ProximityGraph& g = spot_fmm_graph();
  EXPECT_EQ(g.neighbors, 10u);
  EXPECT_EQ(g.sample_vertex.size(), 150u);
  // Theorem 4.2 needs rho > 2r for a finite bound; spot's even faces give it.
  EXPECT_GT(g.link_radius, 2 * g.covering_radius);
  EXPECT_TRUE(std::isfinite(g.view().error_bound()));
  // Nowhere farther than rho from a sample: no warning.
  EXPECT_EQ(g.stats.faces_beyond_link, 0u);
  EXPECT_EQ(sparse_sampling_warning(g.view(), &g.stats), "");
  std::printf("[ info ] spot 150/10: %zu edges, R = %.6g, rho = %.6g, r = %.6g (vertices %.6g), "
              "bound = %.4g\n",
              g.edge_target.size(), g.longest_edge, g.link_radius, g.covering_radius,
              g.stats.vertex_covering_radius, g.view().error_bound());
}

TEST(ProximityGraph, LongFacesLeaveGapsAndAWarning) {
  // Every vertex is a sample (Table 1 asks for more), and 90% of the strip is eleven long faces
  // with none inside: their middles are 4.51 from every sample, beyond the link radius.
  // (Without the refinement the build makes then: core/graph/refined_surface.h.)
  const TestMesh m = make_test_mesh(long_faced_strip());
  ProximityGraphOptions options;
  options.refine_long_faces = false;
  const ProximityGraph g = build_proximity_graph(*m.mesh, *m.geometry, options);
  ASSERT_EQ(g.sample_vertex.size(), m.mesh->num_vertices());
  check_structure(m, g, "long-faced strip");
  EXPECT_EQ(g.stats.vertex_covering_radius, 0.0);
  EXPECT_GE(g.covering_radius, 99.25 / 18 - 1);
  EXPECT_LE(g.covering_radius, (99.25 / 18 - 1) * (1 + 1e-3));
  ASSERT_LT(g.link_radius, g.covering_radius);
  EXPECT_TRUE(std::isinf(g.view().error_bound()));
  EXPECT_EQ(g.stats.faces_beyond_link, 11u);
  EXPECT_NEAR(g.stats.area_fraction_beyond_link, 0.9, 1e-12);
  const std::string warning = sparse_sampling_warning(g.view(), &g.stats);
  EXPECT_NE(warning.find("11 faces (90% of the area)"), std::string::npos) << warning;
  EXPECT_NE(warning.find("without --no-refine"), std::string::npos) << warning;
  // Without the build's stats (a graph file): r and rho alone.
  const std::string from_file = sparse_sampling_warning(g.view());
  EXPECT_NE(from_file.find("beyond the link radius"), std::string::npos) << from_file;
}

TEST(ProximityGraph, StructureOnHoledGrid) {
  check_structure(holed_grid_mesh(), grid_graph(), "holed grid 80/8");
}

TEST(ProximityGraph, EdgesAreExactGeodesicsOnSpot) {
  check_edges_exact(spot(), spot_fmm_graph(), /*directions=*/true, "spot fmm 150/10");
}

TEST(ProximityGraph, EdgesAreExactGeodesicsOnHoledGrid) {
  check_edges_exact(holed_grid_mesh(), grid_graph(), /*directions=*/true, "holed grid 80/8");
}

TEST(ProximityGraph, RepairConnectsSparseGraphs) {
  // With one neighbour each, the nearest-neighbour pairs alone form many pieces: the repair must
  // join them with genuine geodesic edges.
  for (const auto& [name, mesh] : {std::pair<const char*, const TestMesh*>{"spot", &spot()},
                                  {"holed grid", &holed_grid_mesh()}}) {
    const ProximityGraph g = build(*mesh, 60, 1, SamplingMethod::FastMarching);
    check_structure(*mesh, g, std::string(name) + " 60/1");
    check_edges_exact(*mesh, g, /*directions=*/true, std::string(name) + " 60/1");
  }
}

TEST(ProximityGraph, CoverTableHoldsExactDistances) {
  check_cover_table(spot(), spot_fmm_graph(), "spot fmm 150/10");
  check_cover_table(spot(), spot_exact_graph(), "spot exact 100/10");
  check_cover_table(holed_grid_mesh(), grid_graph(), "holed grid 80/8");
}

// The link radius rho: pi rho^2 = m_st * area / n_P; every sample's solve reaches it, so each
// vertex's cover row lists every sample within rho of it and each sample has an edge to every
// sample within rho (what queries rely on for exact answers below rho and field == p2p).
void check_link_radius(const TestMesh& m, const ProximityGraph& g, const std::string& what) {
  SCOPED_TRACE(what);
  const TriangleMesh& mesh = *m.mesh;
  double area = 0;
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) area += m.geometry->face_area(f);
  const auto n = static_cast<std::uint32_t>(g.sample_vertex.size());
  // n_P: the farthest-point samples, not the corner samples on top of them.
  const auto spread = static_cast<double>(n - g.stats.corner_samples);
  const double expected = std::sqrt(2.0 * g.neighbors * area / (std::numbers::pi * spread));
  EXPECT_NEAR(g.link_radius, expected, 1e-12 * expected);
  ExactGeodesicSolver solver(mesh, *m.geometry);
  std::vector<std::int32_t> sample_of(mesh.num_vertices(), -1);
  for (std::uint32_t i = 0; i < n; ++i) {
    sample_of[g.sample_vertex[i]] = static_cast<std::int32_t>(i);
  }
  int failures = 0;
  std::size_t within = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    ExactGeodesicOptions o;
    o.max_distance = g.link_radius;
    solver.solve(SurfacePoint::vertex(g.sample_vertex[i]), o);
    for (std::uint32_t v : solver.touched_vertices()) {
      const double d = solver.distance(v);
      if (!(d < g.link_radius * (1 - 1e-9))) continue;  // clear of the boundary's rounding
      ++within;
      bool covered = false;
      for (std::uint32_t k = g.cover_offsets[v]; k < g.cover_offsets[v + 1]; ++k) {
        covered = covered || g.cover_sample[k] == i;
      }
      if (!covered && ++failures <= 5) {
        ADD_FAILURE() << "vertex " << v << " at " << fmt(d) << " < rho = " << fmt(g.link_radius)
                      << " from sample " << i << " is not in its cover row";
      }
      const std::int32_t j = sample_of[v];
      if (j >= 0 && static_cast<std::uint32_t>(j) != i) {
        bool edge = false;
        for (std::uint32_t e = g.edge_offsets[i]; e < g.edge_offsets[i + 1]; ++e) {
          edge = edge || g.edge_target[e] == static_cast<std::uint32_t>(j);
        }
        if (!edge && ++failures <= 5) {
          ADD_FAILURE() << "samples " << i << " and " << j << " are " << fmt(d)
                        << " apart, within rho, but not joined by an edge";
        }
      }
    }
  }
  EXPECT_EQ(failures, 0);
  EXPECT_GT(within, n);  // the disks hold more than the samples themselves
}

TEST(ProximityGraph, CoversAndEdgesReachTheLinkRadius) {
  check_link_radius(spot(), spot_fmm_graph(), "spot fmm 150/10");
  check_link_radius(holed_grid_mesh(), grid_graph(), "holed grid 80/8");
  // An explicit m_st changes rho accordingly.
  ProximityGraphOptions options;
  options.num_samples = 120;
  options.neighbors = 6;
  options.link_samples = 30;
  const ProximityGraph g = build_proximity_graph(*spot().mesh, *spot().geometry, options);
  double area = 0;
  for (std::uint32_t f = 0; f < spot().mesh->num_faces(); ++f) {
    area += spot().geometry->face_area(f);
  }
  EXPECT_NEAR(g.link_radius, std::sqrt(30 * area / (std::numbers::pi * 120)), 1e-12);
}

TEST(ProximityGraph, LinkRadiusForIsTheRadiusBuildsAndQueriesUse) {
  // pi rho^2 = m_st * area / n_P, with m_st = 2 m_P by default.
  EXPECT_DOUBLE_EQ(link_radius_for(std::numbers::pi, 1, 1), std::sqrt(2.0));
  EXPECT_DOUBLE_EQ(link_radius_for(std::numbers::pi, 1, 1, 8), std::sqrt(8.0));
  EXPECT_EQ(link_radius_for(4.0, 3, 5), link_radius_for(4.0, 3, 7, 10));
  double area = 0;
  for (std::uint32_t f = 0; f < spot().mesh->num_faces(); ++f) {
    area += spot().geometry->face_area(f);
  }
  const ProximityGraph& g = spot_fmm_graph();
  EXPECT_EQ(g.link_radius, link_radius_for(area, 150, 10));
  ProximityGraphOptions options;
  options.num_samples = 150;
  options.neighbors = 10;
  EXPECT_EQ(resolve_graph_size(*spot().mesh, *spot().geometry, options).link_radius,
            g.link_radius);
  options.link_samples = 30;
  EXPECT_EQ(resolve_graph_size(*spot().mesh, *spot().geometry, options).link_radius,
            link_radius_for(area, 150, 10, 30));
}

TEST(ProximityGraph, IdenticalForOneAndTwoThreads) {
  const TestMesh& m = spot();
  const ProximityGraph a = build(m, 150, 10, SamplingMethod::FastMarching, 1);
  const ProximityGraph b = build(m, 150, 10, SamplingMethod::FastMarching, 2);
  expect_same_graph(a.view(), b);
  // And the same as the shared graph built with the default thread count.
  EXPECT_TRUE(same_bits(a.edge_distance, spot_fmm_graph().edge_distance));
  EXPECT_TRUE(same_bits(a.cover_distance, spot_fmm_graph().cover_distance));
}

TEST(ProximityGraph, TwoComponentsGetAGraphEach) {
  const TestMesh m = make_test_mesh(two_component_data());
  int components = 0;
  const std::vector<int> label = component_labels(*m.mesh, components);
  ASSERT_EQ(components, 2);
  for (SamplingMethod method : {SamplingMethod::FastMarching, SamplingMethod::Exact}) {
    const ProximityGraph g = build(m, 90, 8, method);
    const std::string what =
        method == SamplingMethod::Exact ? "two components, exact" : "two components, fmm";
    EXPECT_EQ(g.stats.components, 2u);
    std::uint32_t in_first = 0, in_second = 0;
    for (std::uint32_t v : g.sample_vertex) (label[v] == 0 ? in_first : in_second)++;
    EXPECT_GT(in_first, 8u) << what;
    EXPECT_GT(in_second, 8u) << what;
    // The corner samples (the hole's corners) come first, in the first component; their solves
    // stop at the link radius. Then the vertices still infinitely far come first: the rest of
    // the first component (exact sampling) and the other one, before any second farthest point.
    EXPECT_EQ(g.stats.corner_samples, 4u) << what;
    const std::size_t first = g.stats.corner_samples;
    for (std::size_t k = 0; k < first; ++k) EXPECT_EQ(label[g.sample_vertex[k]], 0) << what;
    EXPECT_TRUE(label[g.sample_vertex[first]] == 1 || label[g.sample_vertex[first + 1]] == 1)
        << what;
    // Connected within each component, no edge across (check_structure), exact edges.
    check_structure(m, g, what);
    check_edges_exact(m, g, /*directions=*/false, what);
    check_cover_table(m, g, what);
    // Covers never cross components either.
    for (std::uint32_t v = 0; v < m.mesh->num_vertices(); ++v) {
      for (std::uint32_t k = g.cover_offsets[v]; k < g.cover_offsets[v + 1]; ++k) {
        ASSERT_EQ(label[g.sample_vertex[g.cover_sample[k]]], label[v]) << what << " vertex " << v;
      }
    }
    const double r = max_finite(*m.mesh, distance_to_samples(m, g.sample_vertex));
    EXPECT_TRUE(close_rel(g.stats.vertex_covering_radius, r, 1e-6, 0))
        << what << ": " << fmt(g.stats.vertex_covering_radius) << " vs " << fmt(r);
  }
}

TEST(ProximityGraph, IsolatedVerticesAreIgnored) {
  MeshData data = flat_grid({.nx = 10, .ny = 10});
  data.positions.push_back({5, 5, 5});  // used by no face
  const TestMesh m = make_test_mesh(std::move(data));
  const auto isolated = static_cast<std::uint32_t>(m.mesh->num_vertices() - 1);
  ASSERT_TRUE(m.mesh->is_isolated_vertex(isolated));
  const ProximityGraph g = build(m, 20, 5, SamplingMethod::FastMarching);
  check_structure(m, g, "grid with an isolated vertex");
  check_cover_table(m, g, "grid with an isolated vertex");
  EXPECT_TRUE(std::isfinite(g.covering_radius));
  // All usable vertices as samples is allowed; one more is not.
  const ProximityGraph all = build(m, isolated, 4, SamplingMethod::Exact);
  EXPECT_EQ(all.sample_vertex.size(), isolated);
  expect_grid_of_samples_radius(all, 0.1);
  EXPECT_THROW(build(m, isolated + 1, 4, SamplingMethod::Exact), InvalidInput);
}

// ---------------------------------------------------------------------------------------------
// Sampling method

TEST(ProximityGraph, AutomaticSamplingUsesFastMarchingOnGoodMeshes) {
  ProximityGraphOptions o;
  o.num_samples = 30;
  o.neighbors = 4;
  const ProximityGraph g = build_proximity_graph(*spot().mesh, *spot().geometry, o);
  EXPECT_EQ(g.stats.sampling_used, SamplingMethod::FastMarching);
}

TEST(ProximityGraph, AutomaticSamplingUsesExactOnPoorMeshes) {
  ProximityGraphOptions o;
  o.num_samples = 40;
  o.neighbors = 4;
  {
    // blade.off: mean Lo quality 0.022 (data/meshes/README.md).
    const TestMesh blade = shipped_mesh("blade.off");
    const ProximityGraph g = build_proximity_graph(*blade.mesh, *blade.geometry, o);
    EXPECT_EQ(g.stats.sampling_used, SamplingMethod::Exact);
    check_structure(blade, g, "blade.off automatic");
  }
  {
    // A grid of caps: three of the four faces of every cell are obtuse, one nearly flat.
    const TestMesh caps = make_test_mesh(cap_grid(8, 8, 0.125, 1e-3));
    const ProximityGraph g = build_proximity_graph(*caps.mesh, *caps.geometry, o);
    EXPECT_EQ(g.stats.sampling_used, SamplingMethod::Exact);
    check_structure(caps, g, "cap grid automatic");
    // Forcing the method overrides the quality test.
    o.sampling = SamplingMethod::FastMarching;
    EXPECT_EQ(build_proximity_graph(*caps.mesh, *caps.geometry, o).stats.sampling_used,
              SamplingMethod::FastMarching);
  }
}

TEST(ProximityGraph, CapsAndZeroAreaFaces) {
  // Nearly flat caps in every cell and two zero-area faces: the graph is still exact, and a
  // direction is either a real one or "unknown" at a corner of a zero-area face.
  const TestMesh m = make_test_mesh(cap_grid(10, 10, 0.125, 1e-3, {{2, 3}, {6, 7}}));
  ASSERT_TRUE(m.geometry->is_degenerate_face(4 * (3 * 10 + 2) + 2));
  const ProximityGraph g = build(m, 60, 8, SamplingMethod::Automatic);
  EXPECT_EQ(g.stats.sampling_used, SamplingMethod::Exact);
  check_structure(m, g, "cap grid with zero-area faces");
  check_edges_exact(m, g, /*directions=*/true, "cap grid with zero-area faces");
  check_cover_table(m, g, "cap grid with zero-area faces");
  const double r = max_finite(*m.mesh, distance_to_samples(m, g.sample_vertex));
  EXPECT_TRUE(close_rel(g.stats.vertex_covering_radius, r, 1e-6, 0))
      << fmt(g.stats.vertex_covering_radius) << " vs " << fmt(r);
}

// ---------------------------------------------------------------------------------------------
// Bad options

TEST(ProximityGraph, RefusesMoreSamplesThanVertices) {
  const TestMesh m = make_test_mesh(flat_grid({.nx = 4, .ny = 4}));  // 25 vertices
  try {
    build(m, 26, 4, SamplingMethod::FastMarching);
    FAIL() << "26 samples on 25 vertices accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.reason(), "TooManySamples");
    EXPECT_NE(std::string(e.what()).find("26"), std::string::npos) << e.what();
  }
  // Exactly every vertex, with more neighbours than there are other samples: a complete graph.
  const ProximityGraph g = build(m, 25, 30, SamplingMethod::FastMarching);
  EXPECT_EQ(g.sample_vertex.size(), 25u);
  EXPECT_EQ(g.edge_target.size(), 25u * 24u);
  expect_grid_of_samples_radius(g, 0.1);
  check_structure(m, g, "complete graph");
  check_edges_exact(m, g, /*directions=*/false, "complete graph");
}

TEST(ProximityGraph, SamplesOnlyAmongCandidateVertices) {
  const TestMesh& m = spot();
  const std::uint32_t candidates = static_cast<std::uint32_t>(m.mesh->num_vertices() / 3);
  for (SamplingMethod method : {SamplingMethod::FastMarching, SamplingMethod::Exact}) {
    ProximityGraphOptions o;
    o.num_samples = 60;
    o.neighbors = 8;
    o.sampling = method;
    o.candidate_vertices = candidates;
    const ProximityGraph g = build_proximity_graph(*m.mesh, *m.geometry, o);
    const std::string what =
        method == SamplingMethod::Exact ? "candidates, exact" : "candidates, fmm";
    ASSERT_EQ(g.sample_vertex.size(), 60u) << what;
    for (std::uint32_t v : g.sample_vertex) EXPECT_LT(v, candidates) << what;
    check_structure(m, g, what);
    check_cover_table(m, g, what);
    // The covering radius is still over every vertex, candidate or not.
    const double r = max_finite(*m.mesh, distance_to_samples(m, g.sample_vertex));
    EXPECT_TRUE(close_rel(g.stats.vertex_covering_radius, r, 1e-6, 0))
        << what << ": " << fmt(g.stats.vertex_covering_radius) << " vs " << fmt(r);
    // With every vertex a candidate, samples spread better over the vertices (what farthest-
    // point sampling spreads them over): a smaller covering radius there.
    o.candidate_vertices = 0;
    EXPECT_LT(build_proximity_graph(*m.mesh, *m.geometry, o).stats.vertex_covering_radius,
              g.stats.vertex_covering_radius)
        << what;
  }
  ProximityGraphOptions too_many;
  too_many.num_samples = 11;
  too_many.neighbors = 4;
  too_many.candidate_vertices = 10;
  try {
    build_proximity_graph(*m.mesh, *m.geometry, too_many);
    FAIL() << "11 samples among 10 candidates accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.reason(), "TooManySamples");
    EXPECT_NE(std::string(e.what()).find("10 candidate vertices"), std::string::npos) << e.what();
  }
  // A component without candidates could never be reached: refused, naming a vertex of it.
  const TestMesh two = make_test_mesh(two_component_data());
  ProximityGraphOptions first_only;
  first_only.num_samples = 20;
  first_only.neighbors = 4;
  first_only.candidate_vertices = static_cast<std::uint32_t>(
      make_test_mesh(holed_jittered_grid_data()).mesh->num_vertices());
  try {
    build_proximity_graph(*two.mesh, *two.geometry, first_only);
    FAIL() << "a component without candidates accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("no candidate vertex"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// File round trip

TEST(ProximityGraph, RoundTripThroughGraphFile) {
  const TestMesh& m = spot();
  const ProximityGraph& g = spot_fmm_graph();
  std::string dir = (fs::temp_directory_path() / "geoprox-proximity-graph-XXXXXX").string();
  ASSERT_NE(::mkdtemp(dir.data()), nullptr);
  const std::string path = dir + "/spot.geoprox";
  {
    write_graph_file(path, *m.mesh, *m.geometry, g, {SamplingMethod::Automatic, "spot.obj"});
    const MappedGraphFile file = MappedGraphFile::open(path);
    file.verify_mesh(*m.mesh, *m.geometry);
    expect_same_graph(file.view(), g);
    EXPECT_EQ(file.params().sampling, g.stats.sampling_used);
    EXPECT_EQ(file.params().num_samples, g.sample_vertex.size());
    EXPECT_EQ(file.params().neighbors, g.neighbors);
  }
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
}  // namespace geoprox
