#include "core/geodesic/covering_radius.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <queue>
#include <string>
#include <vector>

#include "core/base/errors.h"

namespace geoprox {

namespace {

using Bary = std::array<double, 3>;

// A triangle inside face `face`: its corners' barycentrics in the face, their distances to the
// samples, its longest side, and the most any point of it can be from the samples.
struct Cell {
  std::uint32_t face = 0;
  std::array<Bary, 3> corner;
  std::array<double, 3> value;
  double longest = 0;
  double upper = 0;

  double max_value() const { return std::max({value[0], value[1], value[2]}); }
};

struct LowerUpper {
  bool operator()(const Cell& a, const Cell& b) const { return a.upper < b.upper; }
};

Bary midpoint(const Bary& a, const Bary& b) {
  return {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2};
}

// Makes and splits cells, evaluating the exact distance of the last solve at new corners.
class CellSplitter {
 public:
  CellSplitter(const ExactGeodesicSolver& solver, std::size_t& evaluations)
      : solver_(solver), geometry_(solver.geometry()), evaluations_(evaluations),
        smallest_side_(1e-9 * geometry_.mean_edge_length()) {}

  Cell whole_face(std::uint32_t f) const {
    Cell cell{f, {Bary{1, 0, 0}, Bary{0, 1, 0}, Bary{0, 0, 1}}, {}};
    for (int k = 0; k < 3; ++k) cell.value[k] = solver_.distance(solver_.mesh().face(f)[k]);
    measure(cell);
    return cell;
  }

  /// Shorter cells are not split: rounding, not the bound, would decide when to stop.
  bool too_small(const Cell& cell) const { return cell.longest <= smallest_side_; }

  /// The four triangles that cut `cell` at the midpoints of its sides; on_new_point(point,
  /// distance) sees each midpoint as it is evaluated.
  template <class OnNewPoint>
  std::array<Cell, 4> split(const Cell& cell, OnNewPoint&& on_new_point) {
    std::array<Bary, 3> mid;
    std::array<double, 3> mid_value;
    for (int k = 0; k < 3; ++k) {
      mid[k] = midpoint(cell.corner[k], cell.corner[(k + 1) % 3]);
      const SurfacePoint point = SurfacePoint::face(cell.face, mid[k][0], mid[k][1], mid[k][2]);
      mid_value[k] = solver_.distance(point);
      ++evaluations_;
      on_new_point(point, mid_value[k]);
    }
    // Corner k with the midpoints after and before it; then the middle triangle.
    std::array<Cell, 4> parts;
    for (int k = 0; k < 3; ++k) {
      const int before = (k + 2) % 3;
      parts[k] = {cell.face, {cell.corner[k], mid[k], mid[before]},
                  {cell.value[k], mid_value[k], mid_value[before]}};
    }
    parts[3] = {cell.face, mid, mid_value};
    for (Cell& part : parts) measure(part);
    return parts;
  }

 private:
  // Every point x of a triangle with corners P_k lies within L / sqrt(3) of one of them (L its
  // longest side): for barycentrics l, sum_k l_k |x - P_k|^2 = sum_{i<j} l_i l_j |P_i - P_j|^2
  // <= L^2 / 3. A geodesic distance grows by at most the straight length inside a face.
  void measure(Cell& cell) const {
    Vec2 p[3];
    for (int k = 0; k < 3; ++k) p[k] = geometry_.face_point(cell.face, cell.corner[k].data());
    cell.longest = 0;
    for (int k = 0; k < 3; ++k) {
      const Vec2& a = p[k];
      const Vec2& b = p[(k + 1) % 3];
      cell.longest = std::max(cell.longest, std::hypot(a.x - b.x, a.y - b.y));
    }
    cell.upper = cell.max_value() + cell.longest / std::sqrt(3.0);
  }

  const ExactGeodesicSolver& solver_;
  const IntrinsicGeometry& geometry_;
  std::size_t& evaluations_;
  double smallest_side_;
};

// Whether face `cell` holds a point farther than `threshold` from the samples; a face whose
// farthest point is within `tolerance` (relative) of it may go either way. `pending` is scratch,
// kept from face to face.
bool holds_point_beyond(const Cell& face, double threshold, double tolerance,
                        CellSplitter& splitter, std::vector<Cell>& pending) {
  pending.assign(1, face);
  bool found = false;
  auto check = [&](const SurfacePoint&, double d) { found = found || d > threshold; };
  while (!pending.empty() && !found) {
    const Cell cell = pending.back();
    pending.pop_back();
    if (cell.upper <= threshold) continue;
    if (cell.max_value() > threshold) return true;
    if (cell.longest / std::sqrt(3.0) <= tolerance * threshold || splitter.too_small(cell)) {
      continue;
    }
    for (const Cell& part : splitter.split(cell, check)) pending.push_back(part);
  }
  return found;
}

}  // namespace

CoveringRadius covering_radius(ExactGeodesicSolver& solver, std::span<const SurfacePoint> samples,
                               const CoveringRadiusOptions& options) {
  if (samples.empty()) {
    throw InvalidInput(ErrorCode::BadGraphSize, "no samples to measure a covering radius of");
  }
  if (!(options.relative_tolerance > 0 && options.relative_tolerance < 1)) {
    throw InvalidInput(ErrorCode::BadOption, "covering radius tolerance must be in (0, 1), not " +
                                                 std::to_string(options.relative_tolerance));
  }
  if (std::isnan(options.beyond) || options.beyond < 0) {
    throw InvalidInput(ErrorCode::BadOption, "covering radius threshold must be >= 0, not " +
                                                 std::to_string(options.beyond));
  }
  const TriangleMesh& mesh = solver.mesh();
  std::vector<GeodesicSource> sources(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) sources[i] = {samples[i], 0.0};
  ExactGeodesicOptions full;
  solver.solve(sources, {}, full);

  CoveringRadius result;
  // The vertices first: their distances are known, and they start the search high.
  for (std::uint32_t v = 0; v < mesh.num_vertices(); ++v) {
    if (mesh.is_isolated_vertex(v)) continue;
    const double d = solver.distance(v);
    if (!(d <= result.vertex_radius)) {
      result.vertex_radius = d;
      result.farthest = SurfacePoint::vertex(v);
    }
  }
  result.attained = result.vertex_radius;
  if (result.vertex_radius == kInfinity) {
    result.radius = kInfinity;
    return result;
  }

  CellSplitter splitter(solver, result.evaluations);
  const double slack = 1 + options.relative_tolerance;
  double bound_left = 0;  // the largest bound of a cell left unsplit
  // Best first: the cell that could hold the farthest point is split next, so the best found
  // rises fast and most faces are never split.
  std::priority_queue<Cell, std::vector<Cell>, LowerUpper> open;
  auto offer = [&](const Cell& cell) {
    if (cell.upper <= result.attained * slack || splitter.too_small(cell)) {
      bound_left = std::max(bound_left, cell.upper);
    } else {
      open.push(cell);
    }
  };
  auto record = [&](const SurfacePoint& point, double d) {
    if (d > result.attained) {
      result.attained = d;
      result.farthest = point;
    }
  };
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) offer(splitter.whole_face(f));
  while (!open.empty() && open.top().upper > result.attained * slack) {
    const Cell cell = open.top();
    open.pop();
    for (const Cell& part : splitter.split(cell, record)) offer(part);
  }
  if (!open.empty()) bound_left = std::max(bound_left, open.top().upper);
  result.radius = std::max(result.attained, bound_left);

  if (options.beyond < result.radius) {
    std::vector<Cell> pending;
    for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
      if (holds_point_beyond(splitter.whole_face(f), options.beyond, options.relative_tolerance,
                             splitter, pending)) {
        ++result.faces_beyond;
        result.area_beyond += solver.geometry().face_area(f);
      }
    }
  }
  return result;
}

CoveringRadius covering_radius(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                               std::span<const SurfacePoint> samples,
                               const CoveringRadiusOptions& options) {
  ExactGeodesicSolver solver(mesh, geometry);
  return covering_radius(solver, samples, options);
}

}  // namespace geoprox
