// triangulate_polygon: n - 2 triangles that cover the polygon once with its orientation (convex,
// non-convex, collinear corners, non-planar), the least-area choice for non-planar polygons, the
// method by corner count and shape, and the refusal of polygons without a plane.
#include "core/mesh/polygon_triangulation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/base/errors.h"
#include "core/base/tuning.h"

namespace geoprox {
namespace {

using Method = PolygonTriangulationMethod;

std::vector<Vec3> planar(const std::vector<std::pair<double, double>>& xy) {
  std::vector<Vec3> corners;
  for (const auto& [x, y] : xy) corners.push_back({x, y, 0});
  return corners;
}

/// The polygon's Newell normal (twice its area vector), computed here independently.
Vec3 newell_normal(const std::vector<Vec3>& corners) {
  Vec3 sum;
  for (std::size_t i = 0; i < corners.size(); ++i) {
    const Vec3 &p = corners[i], &q = corners[(i + 1) % corners.size()];
    sum =
        sum + Vec3{(p.y - q.y) * (p.z + q.z), (p.z - q.z) * (p.x + q.x), (p.x - q.x) * (p.y + q.y)};
  }
  return sum;
}

double triangle_area(const Vec3& a, const Vec3& b, const Vec3& c) {
  return 0.5 * norm(cross(b - a, c - a));
}

double total_area(const std::vector<Vec3>& corners, const std::vector<Triangle>& triangles) {
  double area = 0;
  for (const Triangle& t : triangles)
    area += triangle_area(corners[t[0]], corners[t[1]], corners[t[2]]);
  return area;
}

/// n - 2 triangles of ascending corner indices that form a disk with the polygon's boundary:
/// every edge (i, i+1) is used once in its direction, every other pair once each way or not.
void expect_disk(std::size_t n, const std::vector<Triangle>& triangles) {
  ASSERT_EQ(triangles.size(), n - 2);
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
  for (const Triangle& t : triangles) {
    EXPECT_TRUE(t[0] < t[1] && t[1] < t[2] && t[2] < n)
        << "triangle " << t[0] << " " << t[1] << " " << t[2];
    for (int k = 0; k < 3; ++k) ++uses[{t[k], t[(k + 1) % 3]}];
  }
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t j = static_cast<std::uint32_t>((i + 1) % n);
    EXPECT_EQ(uses[std::make_pair(i, j)], 1) << "edge " << i << "->" << j;
    EXPECT_EQ(uses[std::make_pair(j, i)], 0) << "edge " << i << "->" << j << " reversed";
  }
  for (const auto& [edge, count] : uses) {
    const auto [a, b] = edge;
    if ((a + 1) % n == b || (b + 1) % n == a) continue;
    EXPECT_EQ(count, 1) << "diagonal " << a << "->" << b;
    EXPECT_EQ(uses[std::make_pair(b, a)], 1) << "diagonal " << a << "->" << b << " one way only";
  }
}

/// The triangles, projected onto the plane normal to the polygon's Newell normal, all turn the
/// polygon's way and their areas add up to the polygon's: with expect_disk, they cover the
/// projected polygon exactly once, inside it.
void expect_cover(const std::vector<Vec3>& corners, const std::vector<Triangle>& triangles) {
  expect_disk(corners.size(), triangles);
  const Vec3 normal = newell_normal(corners);
  const Vec3 unit_normal = (1 / norm(normal)) * normal;
  const double polygon_area = 0.5 * norm(normal);
  double sum = 0;
  for (const Triangle& t : triangles) {
    const Vec3 &a = corners[t[0]], &b = corners[t[1]], &c = corners[t[2]];
    const double projected = 0.5 * dot(cross(b - a, c - a), unit_normal);
    EXPECT_GT(projected, 1e-12 * polygon_area)
        << "triangle " << t[0] << " " << t[1] << " " << t[2] << " turns the wrong way or is flat";
    sum += projected;
  }
  EXPECT_NEAR(sum, polygon_area, 1e-12 * polygon_area);
}

TEST(PolygonTriangulation, TriangleIsReturnedAsItIs) {
  const PolygonTriangulation result = triangulate_polygon(planar({{0, 0}, {1, 0}, {0, 1}}));
  EXPECT_EQ(result.method, Method::AlreadyTriangle);
  EXPECT_EQ(result.triangles, (std::vector<Triangle>{{0, 1, 2}}));
}

TEST(PolygonTriangulation, ConvexQuadSplitsAlongTheDiagonalOfLargerSmallestAngle) {
  // A flat rhombus: the short diagonal 1-3 gives angles of 28 degrees and more, the long one
  // 0-2 angles of 14 degrees.
  const std::vector<Vec3> rhombus = planar({{0, 0}, {2, -0.5}, {4, 0}, {2, 0.5}});
  const PolygonTriangulation result = triangulate_polygon(rhombus);
  EXPECT_EQ(result.method, Method::InsideDiagonals);
  EXPECT_EQ(result.triangles, (std::vector<Triangle>{{0, 1, 3}, {1, 2, 3}}));
  expect_cover(rhombus, result.triangles);
  // The same rhombus starting at another corner: the same diagonal.
  const std::vector<Vec3> turned = planar({{2, -0.5}, {4, 0}, {2, 0.5}, {0, 0}});
  EXPECT_EQ(triangulate_polygon(turned).triangles, (std::vector<Triangle>{{0, 1, 2}, {0, 2, 3}}));
}

TEST(PolygonTriangulation, RegularPolygonsAreCovered) {
  for (std::size_t n = 4; n <= 12; ++n) {
    SCOPED_TRACE(n);
    std::vector<Vec3> corners;
    for (std::size_t i = 0; i < n; ++i) {
      const double angle = 2 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(n);
      corners.push_back({std::cos(angle), std::sin(angle), 0.5});
    }
    const PolygonTriangulation result = triangulate_polygon(corners);
    EXPECT_EQ(result.method, Method::InsideDiagonals);
    expect_cover(corners, result.triangles);
  }
}

TEST(PolygonTriangulation, NonConvexPolygonsAreCoveredFromInside) {
  // An L whose corner 0 does not see corner 3 (a fan from corner 0 would leave the L), a comb
  // with teeth upwards, and a star: each only triangulates through diagonals that avoid its
  // notches.
  const std::vector<std::pair<std::string, std::vector<Vec3>>> polygons = {
      {"L", planar({{2, 1}, {1, 1}, {1, 2}, {0, 2}, {0, 0}, {2, 0}})},
      {"comb", planar({{0, 0},
                       {7, 0},
                       {7, 3},
                       {6, 3},
                       {6, 1},
                       {5, 1},
                       {5, 3},
                       {4, 3},
                       {4, 1},
                       {3, 1},
                       {3, 3},
                       {2, 3},
                       {2, 1},
                       {1, 1},
                       {1, 3},
                       {0, 3}})},
      {"star",
       [] {
         std::vector<Vec3> star;
         for (int i = 0; i < 14; ++i) {
           const double angle = 2 * std::numbers::pi * i / 14;
           const double radius = i % 2 == 0 ? 1.0 : 0.3;
           star.push_back({radius * std::cos(angle), radius * std::sin(angle), 0});
         }
         return star;
       }()},
      {"spiral",
       planar({{0, 0}, {4, 0}, {4, 4}, {1, 4}, {1, 2}, {2, 2}, {2, 3}, {3, 3}, {3, 1}, {0, 1}})}};
  for (const auto& [name, corners] : polygons) {
    SCOPED_TRACE(name);
    const PolygonTriangulation result = triangulate_polygon(corners);
    EXPECT_EQ(result.method, Method::InsideDiagonals);
    expect_cover(corners, result.triangles);
  }
}

TEST(PolygonTriangulation, ClockwisePolygonKeepsItsOrientation) {
  // Turning clockwise seen from +z: its Newell normal is -z, and so is every triangle's.
  const std::vector<Vec3> corners = planar({{0, 0}, {0, 2}, {1, 1}, {2, 2}, {2, 0}});
  const PolygonTriangulation result = triangulate_polygon(corners);
  expect_cover(corners, result.triangles);
  for (const Triangle& t : result.triangles) {
    EXPECT_LT(cross(corners[t[1]] - corners[t[0]], corners[t[2]] - corners[t[0]]).z, 0);
  }
}

TEST(PolygonTriangulation, CollinearCornersGiveNoFlatTriangles) {
  // A square with a corner in the middle of each side, and a triangle with three extra corners
  // on its base: every triangle has area (expect_cover refuses flat ones).
  const std::vector<Vec3> square =
      planar({{0, 0}, {1, 0}, {2, 0}, {2, 1}, {2, 2}, {1, 2}, {0, 2}, {0, 1}});
  const std::vector<Vec3> base = planar({{0, 0}, {1, 0}, {2, 0}, {3, 0}, {4, 0}, {2, 1}});
  for (const std::vector<Vec3>& corners : {square, base}) {
    const PolygonTriangulation result = triangulate_polygon(corners);
    EXPECT_EQ(result.method, Method::InsideDiagonals);
    expect_cover(corners, result.triangles);
  }
  // The base can only be fanned from its apex.
  EXPECT_EQ(triangulate_polygon(base).triangles,
            (std::vector<Triangle>{{0, 1, 5}, {1, 2, 5}, {2, 3, 5}, {3, 4, 5}}));
  // Turned in space, where its corners are collinear only to rounding: still no sliver.
  for (const std::vector<Vec3>& corners : {square, base}) {
    std::vector<Vec3> turned;
    for (const Vec3& p : corners) {
      turned.push_back({0.8 * p.x - 0.6 * p.y, 0.36 * p.x + 0.48 * p.y, 0.48 * p.x + 0.64 * p.y});
    }
    const PolygonTriangulation result = triangulate_polygon(turned);
    EXPECT_EQ(result.method, Method::InsideDiagonals);
    expect_cover(turned, result.triangles);
    for (const Triangle& t : result.triangles) {
      EXPECT_GT(triangle_area(turned[t[0]], turned[t[1]], turned[t[2]]), 0.1);
    }
  }
}

/// Calls `visit` with every triangulation of a polygon: `pending` holds the diagonals (i, j) whose
/// corners i .. j are still to be triangulated, `so_far` the triangles chosen.
void all_triangulations(std::vector<std::pair<std::size_t, std::size_t>> pending,
                        std::vector<Triangle>& so_far,
                        const std::function<void(const std::vector<Triangle>&)>& visit) {
  if (pending.empty()) {
    visit(so_far);
    return;
  }
  const auto [i, j] = pending.back();
  pending.pop_back();
  for (std::size_t k = i + 1; k < j; ++k) {
    so_far.push_back({static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(k),
                      static_cast<std::uint32_t>(j)});
    std::vector<std::pair<std::size_t, std::size_t>> next = pending;
    if (k > i + 1) next.push_back({i, k});
    if (j > k + 1) next.push_back({k, j});
    all_triangulations(std::move(next), so_far, visit);
    so_far.pop_back();
  }
}

TEST(PolygonTriangulation, NonPlanarPolygonsTakeTheLeastAreaTriangulation) {
  // Quads and hexagons around a circle with corners lifted at random: the result has the least
  // area of all triangulations (enumerated here: 2 for a quad, 14 for a hexagon).
  std::mt19937 random(43);
  std::uniform_real_distribution<double> height(-0.8, 0.8);
  for (int trial = 0; trial < 40; ++trial) {
    const std::size_t n = trial % 2 == 0 ? 4 : 6;
    std::vector<Vec3> corners;
    for (std::size_t i = 0; i < n; ++i) {
      const double angle = 2 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(n);
      corners.push_back({std::cos(angle), std::sin(angle), height(random)});
    }
    SCOPED_TRACE(trial);
    const PolygonTriangulation result = triangulate_polygon(corners);
    EXPECT_EQ(result.method, Method::InsideDiagonals);
    expect_cover(corners, result.triangles);
    double least = INFINITY;
    std::size_t count = 0;
    std::vector<Triangle> so_far;
    all_triangulations({{0, n - 1}}, so_far, [&](const std::vector<Triangle>& triangles) {
      least = std::min(least, total_area(corners, triangles));
      ++count;
    });
    EXPECT_EQ(count, n == 4 ? 2u : 14u);
    EXPECT_LE(total_area(corners, result.triangles), least + 1e-9);
  }
}

TEST(PolygonTriangulation, SaddleQuadFoldsAlongTheDiagonalOfLessArea) {
  // Corner 2 lifted by 1: along 1-3 the quad is a flat half (area 0.5) and a tilted one
  // (0.5 sqrt 3), 1.366 in all; along 0-2 two tilted halves of sqrt 2 together.
  const std::vector<Vec3> lifted = {{0, 0, 0}, {1, 0, 0}, {1, 1, 1}, {0, 1, 0}};
  const PolygonTriangulation result = triangulate_polygon(lifted);
  EXPECT_EQ(result.triangles, (std::vector<Triangle>{{0, 1, 3}, {1, 2, 3}}));
  // A saddle, both ways: every triangle turns the way of the Newell normal.
  const std::vector<Vec3> saddle = {{0, 0, 0}, {2, 0, 1}, {2, 1, 0}, {0, 1, 0.5}};
  const PolygonTriangulation folded = triangulate_polygon(saddle);
  expect_cover(saddle, folded.triangles);
  const Vec3 normal = newell_normal(saddle);
  for (const Triangle& t : folded.triangles) {
    EXPECT_GT(dot(cross(saddle[t[1]] - saddle[t[0]], saddle[t[2]] - saddle[t[0]]), normal), 0);
  }
}

TEST(PolygonTriangulation, SelfOverlappingPolygonStillGivesADisk) {
  // A bowtie: seen along any normal its projection crosses itself, and its Newell normal
  // vanishes. Liepa's programme over all diagonals still gives n - 2 triangles.
  const std::vector<Vec3> bowtie = planar({{0, 0}, {1, 1}, {1, 0}, {0, 1}});
  const PolygonTriangulation result = triangulate_polygon(bowtie);
  EXPECT_EQ(result.method, Method::MinimumArea);
  expect_disk(bowtie.size(), result.triangles);
  // A pentagon folded over itself (corner 4 pulled across edge 0-1).
  const std::vector<Vec3> folded = planar({{0, 0}, {4, 0}, {4, 3}, {2, 1}, {3, -1}});
  const PolygonTriangulation overlap = triangulate_polygon(folded);
  EXPECT_EQ(overlap.method, Method::MinimumArea);
  expect_disk(folded.size(), overlap.triangles);
}

/// A comb of `teeth` teeth of width 1 pointing up, 1 apart: 4 * teeth corners, two of them
/// non-convex at every gap.
std::vector<Vec3> comb(int teeth) {
  std::vector<std::pair<double, double>> xy = {{0, 0}, {2.0 * teeth - 1, 0}};
  for (int t = teeth - 1; t >= 0; --t) {
    const double right = 2.0 * t + 1, left = 2.0 * t;
    xy.push_back({right, 3});
    xy.push_back({left, 3});
    if (t > 0) {
      xy.push_back({left, 1});
      xy.push_back({left - 1, 1});
    }
  }
  return planar(xy);
}

TEST(PolygonTriangulation, LargePolygonsAreEarClipped) {
  const std::size_t most = tuning::kPolygonDynamicProgrammingCorners;
  std::vector<Vec3> circle;
  for (std::size_t i = 0; i < most; ++i) {
    const double angle = 2 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(most);
    circle.push_back({std::cos(angle), std::sin(angle), 0});
  }
  EXPECT_EQ(triangulate_polygon(circle).method, Method::InsideDiagonals);
  circle.push_back({1, -1e-3, 0});
  const PolygonTriangulation clipped = triangulate_polygon(circle);
  EXPECT_EQ(clipped.method, Method::EarClipping);
  expect_cover(circle, clipped.triangles);

  for (const int teeth : {20, 200}) {
    for (const double turned : {0.0, 0.3, std::numbers::pi / 2}) {
      SCOPED_TRACE(std::to_string(teeth) + " teeth turned by " + std::to_string(turned));
      std::vector<Vec3> corners = comb(teeth);
      for (Vec3& p : corners) {
        p = {p.x * std::cos(turned) - p.y * std::sin(turned),
             p.x * std::sin(turned) + p.y * std::cos(turned), 0};
      }
      ASSERT_GT(corners.size(), most);
      const PolygonTriangulation result = triangulate_polygon(corners);
      EXPECT_EQ(result.method, Method::EarClipping);
      expect_cover(corners, result.triangles);
    }
  }
  // A star whose notches crowd at its centre: every ear's box holds all of them.
  std::vector<Vec3> spiky;
  for (int i = 0; i < 1000; ++i) {
    const double angle = 2 * std::numbers::pi * i / 1000;
    const double radius = i % 2 == 0 ? 1.0 : 1e-3;
    spiky.push_back({radius * std::cos(angle), radius * std::sin(angle), 0});
  }
  const PolygonTriangulation spiky_result = triangulate_polygon(spiky);
  EXPECT_EQ(spiky_result.method, Method::EarClipping);
  expect_cover(spiky, spiky_result.triangles);
}

TEST(PolygonTriangulation, LargeSelfOverlappingPolygonsStillGiveADisk) {
  // 100 corners winding twice round a circle (no ear is free of other corners), and a figure
  // eight of two opposite loops (no Newell plane): ear clipping cuts off the best corner it
  // has and still gives n - 2 triangles.
  std::vector<Vec3> twice, eight;
  for (int i = 0; i < 100; ++i) {
    const double angle = 4 * std::numbers::pi * i / 100;
    twice.push_back({std::cos(angle), std::sin(angle), 0.01 * i});
    const double t = 2 * std::numbers::pi * i / 100;
    eight.push_back({std::sin(t), std::sin(t) * std::cos(t), 0});
  }
  for (const std::vector<Vec3>& corners : {twice, eight}) {
    const PolygonTriangulation result = triangulate_polygon(corners);
    EXPECT_EQ(result.method, Method::EarClipping);
    expect_disk(corners.size(), result.triangles);
  }
}

TEST(PolygonTriangulation, RandomStarShapedPolygonsAreCovered) {
  // Random angles and radii around a centre, some lifted a little off their plane: simple
  // non-convex polygons of 4 to 150 corners, through both dynamic programming and ear clipping.
  std::mt19937 random(2003);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int trial = 0; trial < 60; ++trial) {
    const std::size_t n = 4 + static_cast<std::size_t>(unit(random) * 147);
    std::vector<double> angles(n);
    for (double& a : angles) a = 2 * std::numbers::pi * unit(random);
    std::sort(angles.begin(), angles.end());
    const double lift = trial % 3 == 0 ? 0.05 : 0.0;
    std::vector<Vec3> corners;
    for (std::size_t i = 0; i < n; ++i) {
      const double radius = 0.2 + unit(random);
      corners.push_back({radius * std::cos(angles[i]), radius * std::sin(angles[i]),
                         lift * (unit(random) - 0.5)});
    }
    SCOPED_TRACE(std::to_string(trial) + ": " + std::to_string(n) + " corners");
    const PolygonTriangulation result = triangulate_polygon(corners);
    EXPECT_EQ(result.method, n <= tuning::kPolygonDynamicProgrammingCorners
                                 ? Method::InsideDiagonals
                                 : Method::EarClipping);
    expect_cover(corners, result.triangles);
  }
}

TEST(PolygonTriangulation, PolygonsWithoutAPlaneAreRefused) {
  auto expect_refused = [](const std::vector<Vec3>& corners, const std::string& fragment) {
    try {
      triangulate_polygon(corners);
      ADD_FAILURE() << "triangulated; expected a refusal with '" << fragment << "'";
    } catch (const MeshError& e) {
      EXPECT_EQ(e.code(), ErrorCode::DegenerateFaceIndices) << e.what();
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  expect_refused({{0, 0, 0}, {1, 1, 1}, {3, 3, 3}, {2, 2, 2}}, "4 corners all lie on one line");
  expect_refused({{1, 2, 3}, {1, 2, 3}, {1, 2, 3}, {1, 2, 3}, {1, 2, 3}}, "at one point");
  expect_refused({{0, 0, 0}, {1, 0, 0}}, "at least 3 corners");
  // Far from the origin, out of order along the line.
  expect_refused({{1e6, 1e6, 5},
                  {1e6 + 0.25, 1e6 + 0.5, 5},
                  {1e6 + 0.75, 1e6 + 1.5, 5},
                  {1e6 + 0.5, 1e6 + 1, 5}},
                 "on one line");
}

}  // namespace
}  // namespace geoprox
