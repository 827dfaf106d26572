// Polygon triangulation: projection onto the Newell plane, then dynamic programming over the
// diagonals inside the projection, over all diagonals, or ear clipping (see the header).
#include "core/mesh/polygon_triangulation.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <optional>
#include <queue>
#include <string>
#include <utility>
#include <vector>

#include "core/base/errors.h"
#include "core/base/tuning.h"

namespace geoprox {
namespace {

struct Point2 {
  double x = 0, y = 0;
};

/// Twice the signed area of triangle abc: positive when it turns counter-clockwise.
double orient(const Point2& a, const Point2& b, const Point2& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

/// Whether r, collinear with segment pq, lies on it (ends included).
bool within_box(const Point2& p, const Point2& q, const Point2& r) {
  return std::min(p.x, q.x) <= r.x && r.x <= std::max(p.x, q.x) && std::min(p.y, q.y) <= r.y &&
         r.y <= std::max(p.y, q.y);
}

/// Whether the closed segments ab and cd meet (crossing, touching or overlapping).
bool segments_meet(const Point2& a, const Point2& b, const Point2& c, const Point2& d) {
  const double d1 = orient(c, d, a), d2 = orient(c, d, b);
  const double d3 = orient(a, b, c), d4 = orient(a, b, d);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) {
    return true;
  }
  return (d1 == 0 && within_box(c, d, a)) || (d2 == 0 && within_box(c, d, b)) ||
         (d3 == 0 && within_box(a, b, c)) || (d4 == 0 && within_box(a, b, d));
}

double squared_distance(const Point2& a, const Point2& b) {
  return (b.x - a.x) * (b.x - a.x) + (b.y - a.y) * (b.y - a.y);
}

/// Tells whether points lie in a closed triangle (counter-clockwise) or on a side to rounding:
/// within tuning::kPolygonDegenerateRatio of the triangle's size (its box's diagonal) of a
/// side's line, outside. A corner on a side (collinear with it in a turned plane) then counts
/// as on it, whichever way rounding puts it.
class TriangleWithSides {
 public:
  TriangleWithSides(const Point2& a, const Point2& b, const Point2& c) : corners_{a, b, c} {
    const double box_diagonal_squared =
        squared_distance({std::min({a.x, b.x, c.x}), std::min({a.y, b.y, c.y})},
                         {std::max({a.x, b.x, c.x}), std::max({a.y, b.y, c.y})});
    constexpr double kRatio = tuning::kPolygonDegenerateRatio;
    for (int k = 0; k < 3; ++k) {
      // orient(side, p) is the side's length times p's distance from its line.
      slack_squared_[k] = kRatio * kRatio * box_diagonal_squared *
                          squared_distance(corners_[k], corners_[(k + 1) % 3]);
    }
  }

  bool holds(const Point2& p) const {
    for (int k = 0; k < 3; ++k) {
      const double o = orient(corners_[k], corners_[(k + 1) % 3], p);
      if (o < 0 && o * o > slack_squared_[k]) return false;
    }
    return true;
  }

 private:
  Point2 corners_[3];
  double slack_squared_[3];
};

/// The smallest angle of triangle abc in radians (0 for a degenerate one).
double smallest_angle(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, bc = c - b, ca = a - c;
  const double twice_area = norm(cross(ab, ca));
  const double at_a = std::atan2(twice_area, -dot(ab, ca));
  const double at_b = std::atan2(twice_area, -dot(bc, ab));
  const double at_c = std::atan2(twice_area, -dot(ca, bc));
  return std::min({at_a, at_b, at_c});
}

/// What a triangulation is judged by: less total area, then a larger smallest angle.
struct Weight {
  double area = 0;
  double smallest_angle = std::numbers::pi;
};

Weight triangle_weight(const Vec3& a, const Vec3& b, const Vec3& c) {
  return {0.5 * norm(cross(b - a, c - a)), smallest_angle(a, b, c)};
}

Weight combine(const Weight& x, const Weight& y) {
  return {x.area + y.area, std::min(x.smallest_angle, y.smallest_angle)};
}

/// The polygon's size and the plane it is projected onto.
struct PolygonShape {
  double extent = 0;  ///< largest distance from corner 0
  Vec3 origin;        ///< the centroid of the corners
  Vec3 normal;        ///< unit; the Newell normal when `has_plane`
  bool has_plane = false;
};

Vec3 unit(const Vec3& v) { return (1 / norm(v)) * v; }

/// Measures the polygon; refuses corners on one line or at one point (the header's contract).
PolygonShape measure(std::span<const Vec3> corners) {
  const std::size_t n = corners.size();
  const Vec3& first = corners[0];
  std::size_t far = 0;
  double extent = 0;
  for (std::size_t i = 1; i < n; ++i) {
    const double d = norm(corners[i] - first);
    if (d > extent) {
      extent = d;
      far = i;
    }
  }
  const std::string count = std::to_string(n);
  if (!(extent > 0)) {
    throw MeshError(ErrorCode::DegenerateFaceIndices,
                    "the polygon's " + count +
                        " corners are all at one point: it has no area to be triangulated");
  }
  const Vec3 axis = unit(corners[far] - first);
  std::size_t off_line = 0;
  double off_line_distance = 0;
  for (std::size_t i = 1; i < n; ++i) {
    const double d = norm(cross(axis, corners[i] - first));
    if (d > off_line_distance) {
      off_line_distance = d;
      off_line = i;
    }
  }
  if (!(off_line_distance > tuning::kPolygonDegenerateRatio * extent)) {
    throw MeshError(ErrorCode::DegenerateFaceIndices,
                    "the polygon's " + count +
                        " corners all lie on one line: it has no plane to be triangulated in");
  }
  PolygonShape shape;
  shape.extent = extent;
  for (const Vec3& p : corners) shape.origin = shape.origin + p;
  shape.origin = (1.0 / static_cast<double>(n)) * shape.origin;
  Vec3 newell;
  for (std::size_t i = 0; i < n; ++i) {
    newell = newell + cross(corners[i] - shape.origin, corners[(i + 1) % n] - shape.origin);
  }
  shape.has_plane = norm(newell) > tuning::kPolygonDegenerateRatio * extent * extent;
  // Without a Newell plane (the polygon's area vector vanishes: it overlaps itself), the plane of
  // three corners far apart still spreads the corners out for ear clipping.
  shape.normal =
      shape.has_plane ? unit(newell) : unit(cross(corners[far] - first, corners[off_line] - first));
  return shape;
}

/// The corners in a frame (u, v) of the plane normal to shape.normal, with u x v = normal: a
/// polygon that turns counter-clockwise about its Newell normal turns counter-clockwise here.
std::vector<Point2> project(std::span<const Vec3> corners, const PolygonShape& shape) {
  const Vec3& n = shape.normal;
  // The coordinate axis least aligned with the normal gives a well-conditioned u.
  const double ax = std::abs(n.x), ay = std::abs(n.y), az = std::abs(n.z);
  Vec3 axis{0, 0, 1};
  if (ax <= ay && ax <= az) {
    axis = {1, 0, 0};
  } else if (ay <= az) {
    axis = {0, 1, 0};
  }
  const Vec3 u = unit(cross(axis, n));
  const Vec3 v = cross(n, u);
  std::vector<Point2> points;
  points.reserve(corners.size());
  for (const Vec3& p : corners) {
    const Vec3 d = p - shape.origin;
    points.push_back({dot(d, u), dot(d, v)});
  }
  return points;
}

double signed_area(const std::vector<Point2>& points) {
  double twice = 0;
  const std::size_t n = points.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Point2 &p = points[i], &q = points[(i + 1) % n];
    twice += p.x * q.y - q.x * p.y;
  }
  return 0.5 * twice;
}

/// Whether the projected polygon is simple and counter-clockwise: no two edges meet except
/// adjacent ones at their common corner, which they do not fold back over.
bool is_simple_counter_clockwise(const std::vector<Point2>& points) {
  const std::size_t n = points.size();
  if (!(signed_area(points) > 0)) return false;
  for (std::size_t i = 0; i < n; ++i) {
    const Point2 &previous = points[(i + n - 1) % n], &corner = points[i],
                 &next = points[(i + 1) % n];
    if (corner.x == next.x && corner.y == next.y) return false;
    if (orient(previous, corner, next) == 0 &&
        (previous.x - corner.x) * (next.x - corner.x) +
                (previous.y - corner.y) * (next.y - corner.y) >
            0) {
      return false;  // the edges at `corner` fold back over each other
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    // Edge i against the edges after it that share no corner with it.
    for (std::size_t j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;
      if (segments_meet(points[i], points[i + 1], points[j], points[(j + 1) % n])) return false;
    }
  }
  return true;
}

/// The diagonal test of O'Rourke, "Computational Geometry in C" (1998), section 1.6, for a simple
/// counter-clockwise polygon: whether the open segment from corner a to corner b lies inside.
class DiagonalTest {
 public:
  explicit DiagonalTest(const std::vector<Point2>& points) : points_(points) {}

  bool inside(std::size_t a, std::size_t b) const {
    if (!in_cone(a, b) || !in_cone(b, a)) return false;
    const std::size_t n = points_.size();
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t l = (k + 1) % n;
      if (k == a || k == b || l == a || l == b) continue;
      if (segments_meet(points_[a], points_[b], points_[k], points_[l])) return false;
    }
    return true;
  }

 private:
  /// Whether b lies strictly inside the polygon's angle at corner a.
  bool in_cone(std::size_t a, std::size_t b) const {
    const std::size_t n = points_.size();
    const Point2& before = points_[(a + n - 1) % n];
    const Point2& after = points_[(a + 1) % n];
    const Point2 &at = points_[a], &to = points_[b];
    if (orient(at, after, before) >= 0) {  // convex or straight
      return orient(at, to, before) > 0 && orient(to, at, after) > 0;
    }
    return !(orient(at, to, after) >= 0 && orient(to, at, before) >= 0);
  }

  const std::vector<Point2>& points_;
};

/// The minimum-weight triangulation of the polygon by dynamic programming over the diagonals
/// (i, j) that `allowed` admits, with corner order 0 .. n-1: cell (i, j) holds the best
/// triangulation of corners i .. j, closed by the diagonal (or, for (0, n-1), the edge) from i
/// to j. Returns false if the diagonals admitted do not triangulate the polygon.
template <typename Allowed>
bool triangulate_by_diagonals(std::span<const Vec3> corners, const std::vector<Point2>& points,
                              bool require_counter_clockwise, double area_tie,
                              const Allowed& allowed, std::vector<Triangle>& triangles) {
  static_assert(tuning::kPolygonDynamicProgrammingCorners < 0xFF, "splits are stored as bytes");
  const std::size_t n = corners.size();
  constexpr std::uint8_t kNone = 0xFF;  // no triangulation of corners i .. j found
  std::vector<Weight> best(n * n);
  std::vector<std::uint8_t> split(n * n, kNone);
  auto feasible = [&](std::size_t i, std::size_t j) {
    return j == i + 1 || split[i * n + j] != kNone;
  };
  auto better = [area_tie](const Weight& a, const Weight& b) {
    if (std::abs(a.area - b.area) > area_tie) return a.area < b.area;
    return a.smallest_angle > b.smallest_angle;
  };
  for (std::size_t length = 2; length < n; ++length) {
    for (std::size_t i = 0; i + length < n; ++i) {
      const std::size_t j = i + length;
      if (!(i == 0 && j == n - 1) && !allowed(i, j)) continue;
      for (std::size_t k = i + 1; k < j; ++k) {
        if (!feasible(i, k) || !feasible(k, j)) continue;
        if (require_counter_clockwise && !(orient(points[i], points[k], points[j]) > 0)) continue;
        Weight weight = triangle_weight(corners[i], corners[k], corners[j]);
        if (k > i + 1) weight = combine(weight, best[i * n + k]);
        if (j > k + 1) weight = combine(weight, best[k * n + j]);
        // The first split found stands unless a better one comes: a triangulation is found
        // whatever the weights (even NaN ones).
        if (split[i * n + j] == kNone || better(weight, best[i * n + j])) {
          best[i * n + j] = weight;
          split[i * n + j] = static_cast<std::uint8_t>(k);
        }
      }
    }
  }
  if (split[n - 1] == kNone) return false;
  std::vector<std::pair<std::size_t, std::size_t>> pending = {{0, n - 1}};
  while (!pending.empty()) {
    const auto [i, j] = pending.back();
    pending.pop_back();
    const std::size_t k = split[i * n + j];
    triangles.push_back({static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(k),
                         static_cast<std::uint32_t>(j)});
    if (k > i + 1) pending.push_back({i, k});
    if (j > k + 1) pending.push_back({k, j});
  }
  return true;
}

/// The corners that are not convex, in a uniform grid of buckets over the projected polygon, so
/// that an ear test looks only at those in the buckets its triangle's bounding box meets.
/// Corners leave it (lazily, when a test meets them) once removed or convex; one that turns
/// non-convex later (only in a polygon that is not simple) goes to a list every test reads.
class NonConvexCorners {
 public:
  NonConvexCorners(const std::vector<Point2>& points, const std::vector<std::uint32_t>& corners) {
    low_ = high_ = points.front();
    for (const Point2& p : points) {
      low_ = {std::min(low_.x, p.x), std::min(low_.y, p.y)};
      high_ = {std::max(high_.x, p.x), std::max(high_.y, p.y)};
    }
    // About one corner per bucket.
    side_ = std::max<std::size_t>(1, static_cast<std::size_t>(std::sqrt(corners.size())));
    scale_x_ = high_.x > low_.x ? static_cast<double>(side_) / (high_.x - low_.x) : 0;
    scale_y_ = high_.y > low_.y ? static_cast<double>(side_) / (high_.y - low_.y) : 0;
    first_.assign(side_ * side_ + 1, 0);
    for (const std::uint32_t c : corners) ++first_[bucket(points[c]) + 1];
    for (std::size_t b = 0; b < side_ * side_; ++b) first_[b + 1] += first_[b];
    size_.assign(side_ * side_, 0);
    items_.resize(corners.size());
    for (const std::uint32_t c : corners) {
      const std::size_t b = bucket(points[c]);
      items_[first_[b] + size_[b]++] = c;
    }
  }

  void add_late(std::uint32_t corner) { late_.push_back(corner); }

  /// Whether `visit` returns false for every listed corner in the buckets that the box
  /// [low, high] meets and every late one (it stops at the first true); `keep` says whether a
  /// corner still belongs to the list, else it leaves it.
  template <typename Keep, typename Visit>
  bool none_in_box(const Point2& low, const Point2& high, const Keep& keep, const Visit& visit) {
    const std::size_t x0 = column(low.x), x1 = column(high.x);
    const std::size_t y0 = row(low.y), y1 = row(high.y);
    for (std::size_t y = y0; y <= y1; ++y) {
      for (std::size_t x = x0; x <= x1; ++x) {
        const std::size_t b = y * side_ + x;
        std::uint32_t* items = items_.data() + first_[b];
        for (std::uint32_t k = 0; k < size_[b];) {
          if (!keep(items[k])) {
            items[k] = items[--size_[b]];
            continue;
          }
          if (visit(items[k++])) return false;
        }
      }
    }
    for (std::size_t k = 0; k < late_.size();) {
      if (!keep(late_[k])) {
        late_[k] = late_.back();
        late_.pop_back();
        continue;
      }
      if (visit(late_[k++])) return false;
    }
    return true;
  }

 private:
  std::size_t column(double x) const {
    const double c = std::floor((x - low_.x) * scale_x_);
    return c > 0 ? std::min(static_cast<std::size_t>(c), side_ - 1) : 0;
  }
  std::size_t row(double y) const {
    const double r = std::floor((y - low_.y) * scale_y_);
    return r > 0 ? std::min(static_cast<std::size_t>(r), side_ - 1) : 0;
  }
  std::size_t bucket(const Point2& p) const { return row(p.y) * side_ + column(p.x); }

  Point2 low_, high_;
  std::size_t side_ = 1;
  double scale_x_ = 0, scale_y_ = 0;
  std::vector<std::size_t> first_;   ///< per bucket: its first slot in items_ (CSR)
  std::vector<std::uint32_t> size_;  ///< per bucket: how many of its slots are still listed
  std::vector<std::uint32_t> items_;
  std::vector<std::uint32_t> late_;
};

/// Ear clipping in the projection, the best-shaped ear first (by its smallest angle in 3D). An
/// ear test reads the non-convex corners near the ear (NonConvexCorners). A corner is tested
/// again when its neighbours change, and when the corner that kept it from being an ear goes:
/// about O(n log n) when the polygon's notches are spread out, O(n^2) tests of O(n) for a
/// polygon whose notches all block each other.
class EarClipping {
 public:
  EarClipping(std::span<const Vec3> corners, std::vector<Point2> points)
      : corners_(corners), points_(std::move(points)) {
    const std::size_t n = corners_.size();
    // Ears are found turning counter-clockwise; a polygon without a Newell plane may come out
    // the other way round.
    if (signed_area(points_) < 0) {
      for (Point2& p : points_) p.y = -p.y;
    }
    previous_.resize(n);
    next_.resize(n);
    version_.assign(n, 0);
    waiting_on_.assign(n, kNoCorner);
    waiters_.resize(n);
    removed_.assign(n, false);
    listed_non_convex_.assign(n, false);
    for (std::size_t i = 0; i < n; ++i) {
      previous_[i] = static_cast<std::uint32_t>((i + n - 1) % n);
      next_[i] = static_cast<std::uint32_t>((i + 1) % n);
    }
    convex_.resize(n);
    for (std::uint32_t i = 0; i < n; ++i) convex_[i] = turns_left(i);
    std::vector<std::uint32_t> non_convex;
    for (std::uint32_t i = 0; i < n; ++i) {
      if (!is_convex(i)) {
        non_convex.push_back(i);
        listed_non_convex_[i] = true;
      }
    }
    non_convex_.emplace(points_, non_convex);
    for (std::uint32_t i = 0; i < n; ++i) consider(i);
  }

  void run(std::vector<Triangle>& triangles) {
    std::size_t remaining = corners_.size();
    std::uint32_t any = 0;  // a corner not yet removed
    while (remaining > 3) {
      std::uint32_t corner = 0;
      if (!pop_ear(corner)) corner = best_corner_without_ear(any);
      triangles.push_back({previous_[corner], corner, next_[corner]});
      remove(corner);
      any = next_[corner];
      --remaining;
    }
    triangles.push_back({previous_[any], any, next_[any]});
  }

 private:
  static constexpr std::uint32_t kNoCorner = 0xFFFFFFFF;

  struct Candidate {
    double smallest_angle;
    std::uint32_t corner;
    std::uint32_t version;
    /// The priority queue's order: the largest smallest angle first, then the lowest corner.
    bool operator<(const Candidate& other) const {
      if (smallest_angle != other.smallest_angle) return smallest_angle < other.smallest_angle;
      return corner > other.corner;
    }
  };

  double turn(std::uint32_t i) const {
    return orient(points_[previous_[i]], points_[i], points_[next_[i]]);
  }
  /// Whether corner i turns left by more than rounding: the sine of its turn is above
  /// tuning::kPolygonDegenerateRatio. A straight corner (collinear with its neighbours, to
  /// rounding) is no ear, which would be flat, but may block one.
  bool turns_left(std::uint32_t i) const {
    const Point2 &a = points_[previous_[i]], &b = points_[i], &c = points_[next_[i]];
    const double o = orient(a, b, c);
    constexpr double kRatio = tuning::kPolygonDegenerateRatio;
    return o > 0 && o * o > kRatio * kRatio * squared_distance(a, b) * squared_distance(b, c);
  }
  /// turns_left, kept up to date as corners are cut off (ear tests read it for every corner).
  bool is_convex(std::uint32_t i) const { return convex_[i]; }

  bool is_ear(std::uint32_t i) {
    if (!is_convex(i)) return false;
    const std::uint32_t a = previous_[i], c = next_[i];
    const Point2 &pa = points_[a], &pi = points_[i], &pc = points_[c];
    const Point2 low{std::min({pa.x, pi.x, pc.x}), std::min({pa.y, pi.y, pc.y})};
    const Point2 high{std::max({pa.x, pi.x, pc.x}), std::max({pa.y, pi.y, pc.y})};
    // Non-convex corners only: a simple polygon with a corner inside a convex corner's triangle
    // has a non-convex one there too.
    const TriangleWithSides triangle(pa, pi, pc);
    std::uint32_t blocker = kNoCorner;
    const bool ear = non_convex_->none_in_box(
        low, high,
        [&](std::uint32_t r) {
          const bool keep = !removed_[r] && !is_convex(r);
          if (!keep) listed_non_convex_[r] = false;
          return keep;
        },
        [&](std::uint32_t r) {
          if (r == a || r == i || r == c || !triangle.holds(points_[r])) return false;
          blocker = r;
          return true;
        });
    if (!ear) {
      // Tested again when the blocker goes (turns convex or is cut off).
      waiting_on_[i] = blocker;
      waiters_[blocker].push_back(i);
    }
    return ear;
  }

  /// Corner r no longer blocks ears: the corners whose last test it failed are tested again.
  void release(std::uint32_t r) {
    std::vector<std::uint32_t> waiting = std::move(waiters_[r]);
    waiters_[r].clear();
    for (const std::uint32_t i : waiting) {
      if (removed_[i] || waiting_on_[i] != r) continue;  // tested again since
      waiting_on_[i] = kNoCorner;
      consider(i);
    }
  }

  void consider(std::uint32_t i) {
    if (is_ear(i)) {
      ears_.push({smallest_angle(corners_[previous_[i]], corners_[i], corners_[next_[i]]), i,
                  version_[i]});
    }
  }

  bool pop_ear(std::uint32_t& corner) {
    while (!ears_.empty()) {
      const Candidate top = ears_.top();
      ears_.pop();
      if (!removed_[top.corner] && top.version == version_[top.corner]) {
        corner = top.corner;
        return true;
      }
    }
    return false;
  }

  /// No ear is left (the projection is not simple, or rounding): the convex corner with the
  /// best-shaped triangle, else the corner that turns least the wrong way.
  std::uint32_t best_corner_without_ear(std::uint32_t start) const {
    std::uint32_t best = start;
    double best_angle = -1;
    double best_turn = turn(start);
    std::uint32_t i = start;
    do {
      const double t = turn(i);
      if (t > 0) {
        const double angle =
            smallest_angle(corners_[previous_[i]], corners_[i], corners_[next_[i]]);
        if (angle > best_angle) {
          best_angle = angle;
          best = i;
        }
      } else if (best_angle < 0 && t > best_turn) {
        best_turn = t;
        best = i;
      }
      i = next_[i];
    } while (i != start);
    return best;
  }

  void remove(std::uint32_t corner) {
    removed_[corner] = true;
    const std::uint32_t a = previous_[corner], c = next_[corner];
    next_[a] = c;
    previous_[c] = a;
    for (const std::uint32_t neighbour : {a, c}) {
      ++version_[neighbour];
      waiting_on_[neighbour] = kNoCorner;
      convex_[neighbour] = turns_left(neighbour);
      if (!is_convex(neighbour)) {
        if (!listed_non_convex_[neighbour]) {
          listed_non_convex_[neighbour] = true;
          non_convex_->add_late(neighbour);
        }
      }
    }
    consider(a);
    consider(c);
    release(corner);
    for (const std::uint32_t neighbour : {a, c}) {
      if (is_convex(neighbour)) release(neighbour);
    }
  }

  std::span<const Vec3> corners_;
  std::vector<Point2> points_;
  std::vector<std::uint32_t> previous_, next_, version_;
  // Per corner (char rather than bool: read for every corner an ear test meets).
  std::vector<char> removed_, listed_non_convex_;
  std::vector<char> convex_;  ///< turns_left
  std::optional<NonConvexCorners> non_convex_;
  /// Per corner: the corner that failed its last ear test, or kNoCorner; and per corner, the
  /// corners waiting on it (stale entries are skipped).
  std::vector<std::uint32_t> waiting_on_;
  std::vector<std::vector<std::uint32_t>> waiters_;
  std::priority_queue<Candidate> ears_;
};

}  // namespace

PolygonTriangulation triangulate_polygon(std::span<const Vec3> corners) {
  const std::size_t n = corners.size();
  if (n < 3) {
    throw MeshError(ErrorCode::DegenerateFaceIndices,
                    "a polygon needs at least 3 corners, this one has " + std::to_string(n));
  }
  PolygonTriangulation result;
  if (n == 3) {
    result.triangles.push_back({0, 1, 2});
    return result;
  }
  const PolygonShape shape = measure(corners);
  std::vector<Point2> points = project(corners, shape);
  result.triangles.reserve(n - 2);
  if (n <= tuning::kPolygonDynamicProgrammingCorners) {
    const double area_tie = tuning::kPolygonAreaTieTolerance * shape.extent * shape.extent;
    if (shape.has_plane && is_simple_counter_clockwise(points)) {
      const DiagonalTest diagonals(points);
      result.method = PolygonTriangulationMethod::InsideDiagonals;
      if (triangulate_by_diagonals(
              corners, points, true, area_tie,
              [&](std::size_t i, std::size_t j) { return diagonals.inside(i, j); },
              result.triangles)) {
        std::sort(result.triangles.begin(), result.triangles.end());
        return result;
      }
      result.triangles.clear();  // rounding: the inside diagonals did not close up
    }
    result.method = PolygonTriangulationMethod::MinimumArea;
    triangulate_by_diagonals(
        corners, points, false, area_tie, [](std::size_t, std::size_t) { return true; },
        result.triangles);
  } else {
    result.method = PolygonTriangulationMethod::EarClipping;
    EarClipping(corners, std::move(points)).run(result.triangles);
    for (Triangle& t : result.triangles) {
      std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    }
  }
  std::sort(result.triangles.begin(), result.triangles.end());
  return result;
}

}  // namespace geoprox
