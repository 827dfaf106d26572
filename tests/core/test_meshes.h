// Synthetic triangle meshes for the geodesic tests, and the analytic (reference) geodesic
// distances on them. Header-only: tests/CMakeLists.txt globs only *_test.cpp.
//
// Every builder is deterministic (its own splitmix64 generator, no <random> distributions whose
// output differs between standard libraries) and returns a MeshData; make_test_mesh() turns it
// into a TriangleMesh + IntrinsicGeometry at stable addresses.
//
// Reference distances, each exact for the faceted surface the builder makes:
//  - PlanarDomain: a flat axis-aligned rectangle minus open axis-aligned boxes (holes, notches).
//    Shortest paths in a polygonal domain are straight between reflex corners, so Dijkstra over
//    {a, b, box corners} with a visibility test is exact.
//  - ConvexPolyhedron: the shortest path between two points of a convex polyhedron crosses every
//    face at most once and never passes through a vertex, so it is the straight segment in one
//    unfolding of a face sequence; the minimum over all valid unfoldings is exact (cube).
//  - prism_distance: the lateral surface of a prism (polygonal cylinder, no caps) unrolls onto a
//    flat strip of width = perimeter with the two sides glued.
//  - FanDevelopment: a "fan" surface (apex joined to a closed rim whose points are all at the same
//    distance from the apex, generators subdivided into rings) is a flat cone of total angle
//    Theta with the apex as its only singular vertex. Theta < 2 pi: a faceted cone; Theta > 2 pi:
//    a saddle vertex, around which geodesics bend when the points are >= pi apart.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/surface_point.h"

namespace geoprox::test_meshes {

// ---------------------------------------------------------------------------------------------
// Small helpers

/// splitmix64: deterministic on every platform.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next_u64() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform in [0, 1).
  double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Uniform integer in [0, n).
  std::uint32_t below(std::uint32_t n) { return static_cast<std::uint32_t>(next_u64() % n); }
  /// Random barycentrics, each >= margin (margin < 1/3), summing to 1.
  std::array<double, 3> barycentrics(double margin = 0.02) {
    double a = uniform(), b = uniform();
    if (a + b > 1) {
      a = 1 - a;
      b = 1 - b;
    }
    const double scale = 1 - 3 * margin;
    std::array<double, 3> out{margin + scale * a, margin + scale * b, 0};
    out[2] = 1 - out[0] - out[1];
    return out;
  }

 private:
  std::uint64_t state_;
};

inline double dist(const Vec3& a, const Vec3& b) { return norm(a - b); }
inline Vec3 normalized(const Vec3& a) { return (1.0 / norm(a)) * a; }

struct P2 {
  double x = 0, y = 0;
};
inline P2 operator+(P2 a, P2 b) { return {a.x + b.x, a.y + b.y}; }
inline P2 operator-(P2 a, P2 b) { return {a.x - b.x, a.y - b.y}; }
inline P2 operator*(double s, P2 a) { return {s * a.x, s * a.y}; }
inline double dot2(P2 a, P2 b) { return a.x * b.x + a.y * b.y; }
inline double cross2(P2 a, P2 b) { return a.x * b.y - a.y * b.x; }
inline double norm2(P2 a) { return std::hypot(a.x, a.y); }

// ---------------------------------------------------------------------------------------------
// Mesh containers

struct MeshData {
  std::vector<Vec3> positions;
  std::vector<Triangle> faces;
  /// Builder-specific label of each face (cube face, prism strip, fan sector), or empty.
  std::vector<int> face_tag;
};

/// A mesh and its intrinsic geometry at stable addresses (the geometry points at the mesh).
struct TestMesh {
  std::unique_ptr<TriangleMesh> mesh;
  std::unique_ptr<IntrinsicGeometry> geometry;
  std::vector<int> face_tag;
};

inline TestMesh make_test_mesh(MeshData data) {
  TestMesh out;
  out.face_tag = std::move(data.face_tag);
  out.mesh = std::make_unique<TriangleMesh>(std::move(data.positions), std::move(data.faces));
  out.geometry = std::make_unique<IntrinsicGeometry>(*out.mesh);
  return out;
}

/// Removes vertices that no face uses and renumbers the rest in order (face order kept).
inline MeshData compact(MeshData data) {
  std::vector<std::int64_t> remap(data.positions.size(), -1);
  for (const Triangle& t : data.faces) {
    for (std::uint32_t v : t) remap[v] = 0;
  }
  std::vector<Vec3> positions;
  for (std::size_t v = 0; v < remap.size(); ++v) {
    if (remap[v] == 0) {
      remap[v] = static_cast<std::int64_t>(positions.size());
      positions.push_back(data.positions[v]);
    }
  }
  for (Triangle& t : data.faces) {
    for (std::uint32_t& v : t) v = static_cast<std::uint32_t>(remap[v]);
  }
  data.positions = std::move(positions);
  return data;
}

/// Appends `b` to `a` (vertex ids of b shifted), keeping face tags if both have them.
inline MeshData concatenate(MeshData a, const MeshData& b) {
  const auto shift = static_cast<std::uint32_t>(a.positions.size());
  a.positions.insert(a.positions.end(), b.positions.begin(), b.positions.end());
  for (Triangle t : b.faces) {
    for (std::uint32_t& v : t) v += shift;
    a.faces.push_back(t);
  }
  if (!a.face_tag.empty() && !b.face_tag.empty()) {
    a.face_tag.insert(a.face_tag.end(), b.face_tag.begin(), b.face_tag.end());
  } else {
    a.face_tag.clear();
  }
  return a;
}

/// Signed area of a triangle projected to the xy plane (used to check flat builders).
inline double signed_area_xy(const Vec3& a, const Vec3& b, const Vec3& c) {
  return 0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
}

// ---------------------------------------------------------------------------------------------
// Flat grids in the plane z = z0

/// Every member has a default, so designated initializers (GridOptions{.nx = 4, .hx = 0.5}) are
/// fine under -Wextra.
struct GridOptions {
  int nx = 10, ny = 10;   ///< cells
  double hx = 0.1, hy = 0.1;
  double x0 = 0, y0 = 0, z0 = 0;
  /// Interior vertices move in-plane by up to jitter*h per axis (keep <= 0.2: no flips).
  double jitter = 0;
  std::uint64_t seed = 1;
  /// Diagonal direction alternates cell by cell (else every cell is split along p00-p11).
  bool alternate_diagonals = true;
  /// Cells (i, j) for which this returns true are left out (holes, notches).
  std::function<bool(int, int)> remove_cell = nullptr;
  /// Explicit vertex coordinates per column / row (size nx+1 / ny+1), overriding hx / hy:
  /// non-uniform grids, e.g. needle columns.
  std::vector<double> xs = {}, ys = {};
};

inline std::uint32_t grid_vertex(const GridOptions& o, int i, int j) {
  return static_cast<std::uint32_t>(j * (o.nx + 1) + i);
}

/// A flat (nx x ny)-cell grid, faces counter-clockwise seen from +z. Vertex (i, j) has id
/// j*(nx+1)+i unless cells are removed (then unused vertices are compacted away).
inline MeshData flat_grid(const GridOptions& o) {
  if ((!o.xs.empty() && o.xs.size() != static_cast<std::size_t>(o.nx + 1)) ||
      (!o.ys.empty() && o.ys.size() != static_cast<std::size_t>(o.ny + 1))) {
    throw std::logic_error("flat_grid: xs/ys must have nx+1/ny+1 entries");
  }
  MeshData d;
  Rng rng(o.seed);
  for (int j = 0; j <= o.ny; ++j) {
    for (int i = 0; i <= o.nx; ++i) {
      double x = o.xs.empty() ? o.x0 + i * o.hx : o.xs[i];
      double y = o.ys.empty() ? o.y0 + j * o.hy : o.ys[j];
      const double jx = rng.uniform(-1, 1), jy = rng.uniform(-1, 1);
      if (o.jitter > 0 && i > 0 && j > 0 && i < o.nx && j < o.ny) {
        x += o.jitter * o.hx * jx;
        y += o.jitter * o.hy * jy;
      }
      d.positions.push_back({x, y, o.z0});
    }
  }
  for (int j = 0; j < o.ny; ++j) {
    for (int i = 0; i < o.nx; ++i) {
      if (o.remove_cell && o.remove_cell(i, j)) continue;
      const std::uint32_t p00 = grid_vertex(o, i, j), p10 = grid_vertex(o, i + 1, j),
                          p11 = grid_vertex(o, i + 1, j + 1), p01 = grid_vertex(o, i, j + 1);
      if (o.alternate_diagonals && (i + j) % 2 == 1) {
        d.faces.push_back({p00, p10, p01});
        d.faces.push_back({p10, p11, p01});
      } else {
        d.faces.push_back({p00, p10, p11});
        d.faces.push_back({p00, p11, p01});
      }
    }
  }
  for (const Triangle& t : d.faces) {
    if (!(signed_area_xy(d.positions[t[0]], d.positions[t[1]], d.positions[t[2]]) > 0)) {
      throw std::logic_error("flat_grid: jitter flipped a triangle");
    }
  }
  if (o.remove_cell) d = compact(std::move(d));
  return d;
}

/// A flat 10 x 1 strip of two parts: a 10 x 10 grid of 0.1 cells on [0, 1]^2, then [1, 10] x
/// [0, 1] as eleven long faces fanning from the corners (10, 0) and (10, 1) to the grid's right
/// column. With every vertex a sample, the point farthest from them is (5.5139, 0.5), 4.5139
/// away (99.25 / 18 - 1: as far from the vertex (1, 0.5) as from (10, 0) and (10, 1)), and 90%
/// of the area holds no vertex at all.
inline MeshData long_faced_strip() {
  const GridOptions grid{.nx = 10, .ny = 10};
  MeshData d = flat_grid(grid);
  const auto bottom = static_cast<std::uint32_t>(d.positions.size());
  d.positions.push_back({10, 0, 0});
  d.positions.push_back({10, 1, 0});
  for (int j = 0; j < 10; ++j) {
    d.faces.push_back({grid_vertex(grid, 10, j), bottom, grid_vertex(grid, 10, j + 1)});
  }
  d.faces.push_back({grid_vertex(grid, 10, 10), bottom, bottom + 1});
  return d;
}

/// A flat grid whose cells are split into four triangles around a point M near the diagonal
/// p00-p11: (p00,p10,M), (p10,p11,M), (p00,M,p11), (p00,p11,p01). M is the diagonal's midpoint
/// pushed towards p10 by `offset` * h (in both axes). offset = 1e-7: (p00,M,p11) is a cap with an
/// angle of nearly 180 degrees at M. Cells listed in `zero_area_cells` get offset 0 exactly: a
/// degenerate (zero-area) face. The surface stays the flat rectangle.
inline MeshData cap_grid(int nx, int ny, double h, double offset,
                         const std::vector<std::pair<int, int>>& zero_area_cells = {}) {
  MeshData d;
  for (int j = 0; j <= ny; ++j) {
    for (int i = 0; i <= nx; ++i) d.positions.push_back({i * h, j * h, 0});
  }
  auto v = [&](int i, int j) { return static_cast<std::uint32_t>(j * (nx + 1) + i); };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const bool zero = std::find(zero_area_cells.begin(), zero_area_cells.end(),
                                  std::pair<int, int>{i, j}) != zero_area_cells.end();
      const double o = zero ? 0.0 : offset;
      const auto m = static_cast<std::uint32_t>(d.positions.size());
      // Midpoint of p00=(i,j)h and p11=(i+1,j+1)h, exactly representable for h a power of 2.
      d.positions.push_back({(i + 0.5 + o) * h, (j + 0.5 - o) * h, 0});
      d.faces.push_back({v(i, j), v(i + 1, j), m});
      d.faces.push_back({v(i + 1, j), v(i + 1, j + 1), m});
      d.faces.push_back({v(i, j), m, v(i + 1, j + 1)});
      d.faces.push_back({v(i, j), v(i + 1, j + 1), v(i, j + 1)});
    }
  }
  return d;
}

/// A random ugly triangulation of a flat rectangle (z = 0), for stress tests whose truth is the
/// straight line: columns and rows of random widths, some 1e-3 to 10^-thinnest of the others
/// (needles and slivers) and some exactly zero (coincident vertices: zero-length edges,
/// zero-area faces); each cell split along either diagonal, or into four triangles around a
/// point M inside the half (p00, p10, p11) at a random distance from the diagonal p00-p11 (1e-4
/// to 10^-(thinnest+1) of the cell: a cap; or zero: zero-area). The surface is the rectangle
/// whatever the split; M computed in floating point may lie off the diagonal by a rounding,
/// which flips a zero-area face by as much. With thinnest 15 the thinnest columns are an ulp
/// or two of their coordinates wide.
inline MeshData ugly_rectangle(std::uint64_t seed, double thinnest = 6) {
  Rng rng(seed);
  const int nx = 3 + static_cast<int>(rng.below(7)), ny = 3 + static_cast<int>(rng.below(7));
  auto widths = [&](int n) {
    std::vector<double> at{0};
    for (int i = 0; i < n; ++i) {
      const double r = rng.uniform();
      double w = rng.uniform(0.05, 0.3);
      if (r < 0.2) w = std::pow(10.0, -rng.uniform(3, thinnest));  // needle or sliver
      else if (r < 0.27) w = 0;                          // coincident vertices
      at.push_back(at.back() + w);
    }
    if (at.back() == 0) at.back() = 0.1;  // keep the rectangle two-dimensional
    return at;
  };
  const std::vector<double> xs = widths(nx), ys = widths(ny);
  MeshData d;
  for (int j = 0; j <= ny; ++j) {
    for (int i = 0; i <= nx; ++i) d.positions.push_back({xs[i], ys[j], 0});
  }
  auto v = [&](int i, int j) { return static_cast<std::uint32_t>(j * (nx + 1) + i); };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const std::uint32_t p00 = v(i, j), p10 = v(i + 1, j), p11 = v(i + 1, j + 1), p01 = v(i, j + 1);
      const double r = rng.uniform();
      if (r < 0.35) {
        d.faces.push_back({p00, p10, p11});
        d.faces.push_back({p00, p11, p01});
      } else if (r < 0.7) {
        d.faces.push_back({p00, p10, p01});
        d.faces.push_back({p10, p11, p01});
      } else {
        // M = w0 p00 + w1 p10 + w2 p11, w1 its weight off the diagonal.
        const double u = rng.uniform(0.05, 0.95);
        const double pick = rng.uniform();
        const double e = pick < 0.3 ? 0.0
                         : pick < 0.7 ? std::pow(10.0, -rng.uniform(4, thinnest + 1))
                                      : rng.uniform(0.01, 0.5);
        const Vec3 a = d.positions[p00], b = d.positions[p10], c = d.positions[p11];
        const double w0 = (1 - e) * (1 - u), w2 = (1 - e) * u;
        const auto m = static_cast<std::uint32_t>(d.positions.size());
        d.positions.push_back({w0 * a.x + e * b.x + w2 * c.x, w0 * a.y + e * b.y + w2 * c.y, 0});
        d.faces.push_back({p00, p10, m});
        d.faces.push_back({p10, p11, m});
        d.faces.push_back({p00, m, p11});
        d.faces.push_back({p00, p11, p01});
      }
    }
  }
  return d;
}

/// The same triangulation lifted to a bumpy height field: z = a few random Gaussian bumps and
/// dents (saddles and cones among the vertices), for invariants that need no analytic truth.
inline MeshData ugly_bumps(std::uint64_t seed, double thinnest = 6) {
  MeshData d = ugly_rectangle(seed, thinnest);
  Rng rng(seed ^ 0xB0B5ull);
  double wx = 0, wy = 0;
  for (const Vec3& p : d.positions) {
    wx = std::max(wx, p.x);
    wy = std::max(wy, p.y);
  }
  const int bumps = 2 + static_cast<int>(rng.below(5));
  std::vector<std::array<double, 4>> b;  // centre x, centre y, height, width
  for (int k = 0; k < bumps; ++k) {
    b.push_back({rng.uniform(0, wx), rng.uniform(0, wy), rng.uniform(-0.3, 0.3) * std::max(wx, wy),
                 rng.uniform(0.05, 0.4) * std::max(wx, wy)});
  }
  for (Vec3& p : d.positions) {
    for (const auto& [cx, cy, h, w] : b) {
      p.z += h * std::exp(-((p.x - cx) * (p.x - cx) + (p.y - cy) * (p.y - cy)) / (w * w));
    }
  }
  return d;
}

// ---------------------------------------------------------------------------------------------
// Planar domains: rectangle minus open boxes

struct Box {
  double x0, y0, x1, y1;
};

struct PlanarDomain {
  double x0 = 0, y0 = 0, x1 = 1, y1 = 1;
  std::vector<Box> holes;  ///< open boxes removed from the closed rectangle (disjoint)

  /// True if the closed segment ab meets no hole's open interior (grazing a corner or running
  /// along a side is allowed: it stays on the surface).
  bool visible(P2 a, P2 b) const {
    for (const Box& box : holes) {
      double lo = 0, hi = 1;
      const double d[2] = {b.x - a.x, b.y - a.y};
      const double p[2] = {a.x, a.y};
      const double mn[2] = {box.x0, box.y0};
      const double mx[2] = {box.x1, box.y1};
      bool outside = false;
      for (int k = 0; k < 2 && !outside; ++k) {
        if (std::abs(d[k]) < 1e-300) {
          if (!(p[k] > mn[k] + 1e-12 && p[k] < mx[k] - 1e-12)) outside = true;
        } else {
          double t0 = (mn[k] - p[k]) / d[k], t1 = (mx[k] - p[k]) / d[k];
          if (t0 > t1) std::swap(t0, t1);
          lo = std::max(lo, t0);
          hi = std::min(hi, t1);
        }
      }
      if (outside) continue;
      // Inside the open box for t in (lo, hi); a positive-length overlap (relative to the
      // segment) means the segment cuts through the hole.
      if (hi - lo > 1e-12) return false;
    }
    return true;
  }

  /// Exact shortest-path distance inside the domain (Dijkstra over a, b and the hole corners).
  double distance(P2 a, P2 b) const {
    std::vector<P2> nodes{a, b};
    for (const Box& box : holes) {
      nodes.push_back({box.x0, box.y0});
      nodes.push_back({box.x1, box.y0});
      nodes.push_back({box.x1, box.y1});
      nodes.push_back({box.x0, box.y1});
    }
    const std::size_t n = nodes.size();
    std::vector<double> best(n, std::numeric_limits<double>::infinity());
    std::vector<bool> done(n, false);
    best[0] = 0;
    for (std::size_t it = 0; it < n; ++it) {
      std::size_t u = n;
      for (std::size_t k = 0; k < n; ++k) {
        if (!done[k] && (u == n || best[k] < best[u])) u = k;
      }
      if (u == n || !std::isfinite(best[u])) break;
      done[u] = true;
      for (std::size_t k = 0; k < n; ++k) {
        if (done[k] || !visible(nodes[u], nodes[k])) continue;
        best[k] = std::min(best[k], best[u] + norm2(nodes[k] - nodes[u]));
      }
    }
    return best[1];
  }
};

/// Flat grid of nx x ny cells of size h at the origin with the cells inside each box (in cell
/// units [i0, i1) x [j0, j1)) removed, and the matching PlanarDomain.
struct HoledGrid {
  MeshData data;
  PlanarDomain domain;
};
inline HoledGrid holed_grid(int nx, int ny, double h,
                            const std::vector<std::array<int, 4>>& removed_cell_boxes) {
  GridOptions o;
  o.nx = nx;
  o.ny = ny;
  o.hx = o.hy = h;
  o.remove_cell = [removed_cell_boxes](int i, int j) {
    for (const auto& b : removed_cell_boxes) {
      if (i >= b[0] && i < b[2] && j >= b[1] && j < b[3]) return true;
    }
    return false;
  };
  HoledGrid out;
  out.data = flat_grid(o);
  out.domain.x0 = 0;
  out.domain.y0 = 0;
  out.domain.x1 = nx * h;
  out.domain.y1 = ny * h;
  for (const auto& b : removed_cell_boxes) {
    out.domain.holes.push_back({b[0] * h, b[1] * h, b[2] * h, b[3] * h});
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Convex polyhedra (cube) and their exact geodesic distance by unfolding

struct ConvexPolyhedron {
  /// Each face's corners, counter-clockwise seen from outside.
  std::vector<std::vector<Vec3>> faces;

  /// Faces whose closed polygon contains p (within tol of the plane and inside every edge).
  std::vector<int> faces_containing(const Vec3& p, double tol = 1e-12) const {
    std::vector<int> out;
    for (std::size_t f = 0; f < faces.size(); ++f) {
      const auto& c = faces[f];
      const Vec3 n = normalized(cross(c[1] - c[0], c[2] - c[0]));
      if (std::abs(dot(p - c[0], n)) > tol) continue;
      bool inside = true;
      for (std::size_t k = 0; k < c.size() && inside; ++k) {
        const Vec3& a = c[k];
        const Vec3& b = c[(k + 1) % c.size()];
        if (dot(cross(b - a, p - a), n) < -tol * norm(b - a)) inside = false;
      }
      if (inside) out.push_back(static_cast<int>(f));
    }
    return out;
  }

  /// Exact geodesic distance between p (on face fp) and q (on face fq).
  double distance_on(int fp, const Vec3& p, int fq, const Vec3& q) const {
    if (fp == fq) return dist(p, q);
    double best = std::numeric_limits<double>::infinity();
    std::vector<int> sequence{fp};
    std::vector<Frame> frames{initial_frame(fp)};
    std::vector<std::pair<P2, P2>> edges;
    search(fq, p, q, sequence, frames, edges, best);
    return best;
  }

  /// Exact geodesic distance between two surface points (any faces containing them).
  double distance(const Vec3& p, const Vec3& q) const {
    double best = std::numeric_limits<double>::infinity();
    for (int fp : faces_containing(p)) {
      for (int fq : faces_containing(q)) best = std::min(best, distance_on(fp, p, fq, q));
    }
    if (!std::isfinite(best)) throw std::logic_error("ConvexPolyhedron: point not on surface");
    return best;
  }

 private:
  // Rigid map of a face into the unfolding plane: image(p) = o2 + ((p-o3).ex3) ex2 + ((p-o3).ey3) ey2.
  struct Frame {
    Vec3 o3, ex3, ey3;
    P2 o2, ex2, ey2;
    P2 map(const Vec3& p) const {
      const Vec3 d = p - o3;
      return o2 + dot(d, ex3) * ex2 + dot(d, ey3) * ey2;
    }
  };

  Vec3 centroid(int f) const {
    Vec3 c{0, 0, 0};
    for (const Vec3& v : faces[f]) c = c + v;
    return (1.0 / static_cast<double>(faces[f].size())) * c;
  }

  Frame initial_frame(int f) const {
    const auto& c = faces[f];
    Frame fr;
    fr.o3 = c[0];
    fr.ex3 = normalized(c[1] - c[0]);
    const Vec3 n = normalized(cross(c[1] - c[0], c[2] - c[0]));
    fr.ey3 = cross(n, fr.ex3);
    fr.o2 = {0, 0};
    fr.ex2 = {1, 0};
    fr.ey2 = {0, 1};
    return fr;
  }

  static bool same_point(const Vec3& a, const Vec3& b) { return dist(a, b) < 1e-12; }

  /// The shared edge of faces f and g, if any.
  bool shared_edge(int f, int g, Vec3& a, Vec3& b) const {
    const auto& cf = faces[f];
    const auto& cg = faces[g];
    for (std::size_t i = 0; i < cf.size(); ++i) {
      const Vec3& p = cf[i];
      const Vec3& q = cf[(i + 1) % cf.size()];
      for (std::size_t k = 0; k < cg.size(); ++k) {
        if (same_point(cg[k], q) && same_point(cg[(k + 1) % cg.size()], p)) {
          a = p;
          b = q;
          return true;
        }
      }
    }
    return false;
  }

  void search(int fq, const Vec3& p, const Vec3& q, std::vector<int>& sequence,
              std::vector<Frame>& frames, std::vector<std::pair<P2, P2>>& edges,
              double& best) const {
    const int f = sequence.back();
    for (int g = 0; g < static_cast<int>(faces.size()); ++g) {
      if (std::find(sequence.begin(), sequence.end(), g) != sequence.end()) continue;
      Vec3 a, b;
      if (!shared_edge(f, g, a, b)) continue;
      const Frame& cur = frames.back();
      const P2 a2 = cur.map(a), b2 = cur.map(b);
      Frame next;
      next.o3 = a;
      next.ex3 = normalized(b - a);
      const Vec3 w = centroid(g) - a;
      next.ey3 = normalized(w - dot(w, next.ex3) * next.ex3);
      next.o2 = a2;
      next.ex2 = (1.0 / norm2(b2 - a2)) * (b2 - a2);
      next.ey2 = {-next.ex2.y, next.ex2.x};
      if (dot2(next.ey2, cur.map(centroid(f)) - a2) > 0) next.ey2 = -1.0 * next.ey2;
      sequence.push_back(g);
      frames.push_back(next);
      edges.push_back({a2, b2});
      if (g == fq) {
        const double length = valid_length(frames.front().map(p), next.map(q), edges);
        best = std::min(best, length);
      } else {
        search(fq, p, q, sequence, frames, edges, best);
      }
      sequence.pop_back();
      frames.pop_back();
      edges.pop_back();
    }
  }

  /// Length of segment st if it crosses every edge in order, else infinity.
  static double valid_length(P2 s, P2 t, const std::vector<std::pair<P2, P2>>& edges) {
    const P2 d = t - s;
    double last = -1e-12;
    for (const auto& [a, b] : edges) {
      const P2 e = b - a;
      const double den = cross2(d, e);
      if (std::abs(den) < 1e-14 * (norm2(d) * norm2(e) + 1e-300)) {
        return std::numeric_limits<double>::infinity();
      }
      const P2 as = a - s;
      const double lambda = cross2(as, e) / den;  // along st
      const double mu = cross2(as, d) / den;      // along ab
      if (lambda < last - 1e-12 || lambda > 1 + 1e-12 || mu < -1e-12 || mu > 1 + 1e-12) {
        return std::numeric_limits<double>::infinity();
      }
      last = std::max(last, lambda);
    }
    return norm2(d);
  }
};

// ---------------------------------------------------------------------------------------------
// Subdivided cube surface [0, side]^3

struct Cube {
  MeshData data;  ///< face_tag: cube face 0..5
  ConvexPolyhedron polyhedron;
};

/// Cube surface, each of the 6 faces an n x n grid (diagonals alternate), outward oriented and
/// welded (every lattice point is one vertex). Cube faces: 0 z=0, 1 z=side, 2 y=0, 3 y=side,
/// 4 x=0, 5 x=side.
inline Cube cube_surface(int n, double side) {
  using I3 = std::array<int, 3>;
  // Origin, U, V in lattice units (U x V = outward normal).
  const std::array<std::array<I3, 3>, 6> defs{{
      {{{0, 0, 0}, {0, 1, 0}, {1, 0, 0}}},  // z = 0, -z
      {{{0, 0, n}, {1, 0, 0}, {0, 1, 0}}},  // z = n, +z
      {{{0, 0, 0}, {1, 0, 0}, {0, 0, 1}}},  // y = 0, -y
      {{{0, n, 0}, {0, 0, 1}, {1, 0, 0}}},  // y = n, +y
      {{{0, 0, 0}, {0, 0, 1}, {0, 1, 0}}},  // x = 0, -x
      {{{n, 0, 0}, {0, 1, 0}, {0, 0, 1}}},  // x = n, +x
  }};
  Cube cube;
  std::map<I3, std::uint32_t> index;
  const double h = side / n;
  auto vertex = [&](const I3& p) {
    auto [it, fresh] = index.emplace(p, static_cast<std::uint32_t>(cube.data.positions.size()));
    if (fresh) cube.data.positions.push_back({p[0] * h, p[1] * h, p[2] * h});
    return it->second;
  };
  for (int f = 0; f < 6; ++f) {
    const auto& [o, u, v] = defs[f];
    auto at = [&](int i, int j) {
      return I3{o[0] + i * u[0] + j * v[0], o[1] + i * u[1] + j * v[1], o[2] + i * u[2] + j * v[2]};
    };
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        const std::uint32_t p00 = vertex(at(i, j)), p10 = vertex(at(i + 1, j)),
                            p11 = vertex(at(i + 1, j + 1)), p01 = vertex(at(i, j + 1));
        if ((i + j) % 2 == 1) {
          cube.data.faces.push_back({p00, p10, p01});
          cube.data.faces.push_back({p10, p11, p01});
        } else {
          cube.data.faces.push_back({p00, p10, p11});
          cube.data.faces.push_back({p00, p11, p01});
        }
        cube.data.face_tag.push_back(f);
        cube.data.face_tag.push_back(f);
      }
    }
    std::vector<Vec3> corners;
    for (const I3& c : {at(0, 0), at(n, 0), at(n, n), at(0, n)}) {
      corners.push_back({c[0] * h, c[1] * h, c[2] * h});
    }
    cube.polyhedron.faces.push_back(corners);
  }
  return cube;
}

// ---------------------------------------------------------------------------------------------
// Prism (polygonal cylinder without caps)

struct Prism {
  MeshData data;  ///< face_tag: strip (segment) index j, between rim vertices j and j+1
  double radius = 1, height = 1;
  int segments = 0;
  double side = 0;  ///< chord length of one strip
  double perimeter() const { return segments * side; }
  Vec3 rim(int j) const {
    const double a = 2 * std::numbers::pi * (j % segments) / segments;
    return {radius * std::cos(a), radius * std::sin(a), 0};
  }
  /// Unrolled coordinates (arc position along the perimeter, height) of a point on strip j.
  P2 unroll(const Vec3& p, int strip) const {
    const Vec3 a = rim(strip), b = rim(strip + 1);
    const Vec3 along = normalized(b - a);
    return {strip * side + dot(p - a, along), p.z};
  }
  /// Exact distance on the faceted lateral surface between unrolled points.
  double distance(P2 a, P2 b) const {
    const double per = perimeter();
    double dx = std::fmod(std::abs(a.x - b.x), per);
    dx = std::min(dx, per - dx);
    return std::hypot(dx, a.y - b.y);
  }
};

/// Open prism: `segments` planar strips around the z axis, `rings` rows of quads from z = 0 to
/// z = height, outward oriented. Vertex (ring k, rim j) has id k*segments + j.
inline Prism prism_surface(double radius, double height, int segments, int rings) {
  Prism pr;
  pr.radius = radius;
  pr.height = height;
  pr.segments = segments;
  pr.side = 2 * radius * std::sin(std::numbers::pi / segments);
  for (int k = 0; k <= rings; ++k) {
    for (int j = 0; j < segments; ++j) {
      Vec3 p = pr.rim(j);
      p.z = height * k / rings;
      pr.data.positions.push_back(p);
    }
  }
  auto v = [&](int k, int j) { return static_cast<std::uint32_t>(k * segments + j % segments); };
  for (int k = 0; k < rings; ++k) {
    for (int j = 0; j < segments; ++j) {
      const std::uint32_t p00 = v(k, j), p10 = v(k, j + 1), p11 = v(k + 1, j + 1),
                          p01 = v(k + 1, j);
      if ((j + k) % 2 == 0) {
        pr.data.faces.push_back({p00, p10, p11});
        pr.data.faces.push_back({p00, p11, p01});
      } else {
        pr.data.faces.push_back({p00, p10, p01});
        pr.data.faces.push_back({p10, p11, p01});
      }
      pr.data.face_tag.push_back(j);
      pr.data.face_tag.push_back(j);
    }
  }
  return pr;
}

// ---------------------------------------------------------------------------------------------
// Fans: faceted cones (Theta < 2 pi) and saddles (Theta > 2 pi)

struct Fan {
  MeshData data;  ///< face_tag: sector j, between rim points j and j+1; vertex 0 is the apex
  Vec3 apex;
  std::vector<Vec3> rim;
  std::vector<double> sector_start;  ///< developed angle where sector j starts
  double total_angle = 0;            ///< Theta, the apex's angle sum

  static double angle_between(const Vec3& a, const Vec3& b) {
    return std::atan2(norm(cross(a, b)), dot(a, b));
  }
  /// Developed polar coordinates (r, phi) of a point on sector j.
  P2 develop(const Vec3& p, int sector) const {
    const Vec3 d = p - apex;
    const double r = norm(d);
    if (r == 0) return {0, 0};
    return {r, sector_start[sector] + angle_between(rim[sector] - apex, d)};
  }
  /// Angle between developed points around the apex, the shorter way round.
  double separation(P2 a, P2 b) const {
    const double delta = std::fmod(std::abs(a.y - b.y), total_angle);
    return std::min(delta, total_angle - delta);
  }
  /// Exact distance on the flat cone of angle Theta between developed points.
  double distance(P2 a, P2 b) const {
    const double delta = separation(a, b);
    if (delta >= std::numbers::pi) return a.x + b.x;  // around (through) the apex
    const double s = std::sin(delta / 2);
    return std::sqrt((a.x - b.x) * (a.x - b.x) + 4 * a.x * b.x * s * s);
  }
};

/// Apex joined to a closed rim; generators subdivided into `rings` rings (ring k at fraction
/// k/rings), quads split alternately. Rim points must be equidistant from the apex. Vertex 0 is
/// the apex, ring k >= 1 vertex j has id 1 + (k-1)*rim.size() + j. Orientation follows the rim
/// order (counter-clockwise seen from the side the normal (rim[j]-apex) x (rim[j+1]-apex) points).
inline Fan fan_surface(const Vec3& apex, const std::vector<Vec3>& rim, int rings) {
  Fan fan;
  fan.apex = apex;
  fan.rim = rim;
  const int n = static_cast<int>(rim.size());
  const double r0 = dist(rim[0], apex);
  for (const Vec3& p : rim) {
    if (std::abs(dist(p, apex) - r0) > 1e-12 * r0) {
      throw std::logic_error("fan_surface: rim points must be equidistant from the apex");
    }
  }
  double acc = 0;
  for (int j = 0; j < n; ++j) {
    fan.sector_start.push_back(acc);
    acc += Fan::angle_between(rim[j] - apex, rim[(j + 1) % n] - apex);
  }
  fan.total_angle = acc;
  fan.data.positions.push_back(apex);
  for (int k = 1; k <= rings; ++k) {
    const double t = static_cast<double>(k) / rings;
    for (int j = 0; j < n; ++j) fan.data.positions.push_back(apex + t * (rim[j] - apex));
  }
  auto v = [&](int k, int j) {
    return k == 0 ? 0u : static_cast<std::uint32_t>(1 + (k - 1) * n + (j % n));
  };
  for (int j = 0; j < n; ++j) {
    fan.data.faces.push_back({v(0, 0), v(1, j), v(1, j + 1)});
    fan.data.face_tag.push_back(j);
    for (int k = 1; k < rings; ++k) {
      if ((j + k) % 2 == 0) {
        fan.data.faces.push_back({v(k, j), v(k + 1, j), v(k + 1, j + 1)});
        fan.data.faces.push_back({v(k, j), v(k + 1, j + 1), v(k, j + 1)});
      } else {
        fan.data.faces.push_back({v(k, j), v(k + 1, j), v(k, j + 1)});
        fan.data.faces.push_back({v(k, j + 1), v(k + 1, j), v(k + 1, j + 1)});
      }
      fan.data.face_tag.push_back(j);
      fan.data.face_tag.push_back(j);
    }
  }
  return fan;
}

/// Faceted cone: apex at (0, 0, height) over a regular `segments`-gon of radius `radius` at z=0.
inline Fan cone_surface(double radius, double height, int segments, int rings) {
  std::vector<Vec3> rim;
  for (int j = 0; j < segments; ++j) {
    const double a = 2 * std::numbers::pi * j / segments;
    rim.push_back({radius * std::cos(a), radius * std::sin(a), 0});
  }
  return fan_surface({0, 0, height}, rim, rings);
}

/// Saddle: apex at the origin, `segments` (even) rim points on the unit sphere at alternating
/// heights +-z (a zig-zag crown), so the apex's angle sum exceeds 2 pi for z large enough.
inline Fan saddle_surface(int segments, double z, int rings) {
  std::vector<Vec3> rim;
  for (int j = 0; j < segments; ++j) {
    const double a = 2 * std::numbers::pi * j / segments;
    rim.push_back(normalized(Vec3{std::cos(a), std::sin(a), (j % 2 == 0 ? z : -z)}));
  }
  return fan_surface({0, 0, 0}, rim, rings);
}

// ---------------------------------------------------------------------------------------------
// Point helpers on any mesh

/// Faces incident to a surface point (a face point with a zero barycentric also touches the
/// neighbours across that edge; an edge point at t = 0 or 1 touches its vertex's faces).
inline std::vector<std::uint32_t> incident_faces(const TriangleMesh& mesh, const SurfacePoint& p,
                                                 double eps = 1e-12) {
  std::vector<std::uint32_t> out;
  auto vertex_faces = [&](std::uint32_t v) {
    for (std::uint32_t h : mesh.outgoing_halfedges(v)) out.push_back(TriangleMesh::face_of(h));
  };
  auto edge_faces = [&](std::uint32_t e) {
    const std::uint32_t h = mesh.edge_halfedge(e);
    out.push_back(TriangleMesh::face_of(h));
    if (mesh.twin(h) >= 0) out.push_back(TriangleMesh::face_of(static_cast<std::uint32_t>(mesh.twin(h))));
  };
  switch (p.kind) {
    case SurfacePoint::Kind::Vertex:
      vertex_faces(p.id);
      break;
    case SurfacePoint::Kind::Edge:
      edge_faces(p.id);
      if (p.t <= eps) vertex_faces(mesh.edge_origin(p.id));
      if (p.t >= 1 - eps) vertex_faces(mesh.edge_target(p.id));
      break;
    case SurfacePoint::Kind::Face: {
      out.push_back(p.id);
      int zeros = 0;
      for (int c = 0; c < 3; ++c) {
        if (p.bary[c] <= eps) ++zeros;
      }
      for (int c = 0; c < 3; ++c) {
        // Edge opposite corner c is halfedge 3f + (c+1)%3.
        if (p.bary[c] <= eps) {
          edge_faces(mesh.edge_of(3 * p.id + (c + 1) % 3));
          if (zeros == 2) {
            for (int k = 0; k < 3; ++k) {
              if (p.bary[k] > eps) vertex_faces(mesh.face(p.id)[k]);
            }
          }
        }
      }
      break;
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

/// 3D direction of a face-frame direction (x towards corner 1, y towards corner 2's side).
inline Vec3 face_direction_3d(const TriangleMesh& mesh, std::uint32_t f, double x, double y) {
  const Triangle& t = mesh.face(f);
  const Vec3 p0 = mesh.position(t[0]), p1 = mesh.position(t[1]), p2 = mesh.position(t[2]);
  const Vec3 ex = normalized(p1 - p0);
  const Vec3 w = p2 - p0;
  const Vec3 ey = normalized(w - dot(w, ex) * ex);
  return x * ex + y * ey;
}

/// Random point inside a random face (barycentrics >= margin).
inline SurfacePoint random_face_point(const TriangleMesh& mesh, Rng& rng, double margin = 0.02) {
  const std::uint32_t f = rng.below(static_cast<std::uint32_t>(mesh.num_faces()));
  const auto b = rng.barycentrics(margin);
  return SurfacePoint::face(f, b[0], b[1], b[2]);
}

/// Diagonal of the bounding box: a length scale for tolerances.
inline double bbox_diagonal(const TriangleMesh& mesh) {
  Vec3 lo = mesh.position(0), hi = mesh.position(0);
  for (const Vec3& p : mesh.positions()) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  return norm(hi - lo);
}

}  // namespace geoprox::test_meshes
