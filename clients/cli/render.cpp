// Software rasterizer of `geoprox render` (see render.h for the method and its papers).
#include "clients/cli/render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/base/errors.h"

namespace geoprox::cli {
namespace {

// matplotlib's viridis at t = k / 32, k = 0..32, rounded to 8 bits.
constexpr std::array<Rgb, 33> kViridisStops{{
    {68, 1, 84},    {71, 13, 96},   {72, 24, 106},  {72, 35, 116},  {71, 45, 123},  {69, 54, 129},
    {66, 64, 134},  {63, 73, 137},  {59, 82, 139},  {55, 90, 141},  {51, 99, 141},  {47, 106, 142},
    {44, 114, 142}, {41, 122, 142}, {38, 129, 142}, {35, 137, 142}, {33, 144, 140}, {31, 152, 139},
    {31, 159, 136}, {33, 166, 133}, {40, 174, 128}, {49, 181, 123}, {62, 188, 116}, {76, 194, 108},
    {93, 201, 99},  {110, 206, 88}, {130, 211, 76}, {150, 216, 63}, {171, 220, 50}, {192, 223, 36},
    {213, 226, 26}, {234, 229, 26}, {253, 231, 37},
}};

constexpr long kMaxSamples = 1L << 25;

using Vec = std::array<double, 3>;

Vec sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec normalized(const Vec& a) {
  const double n = std::sqrt(dot(a, a));
  return n > 0 ? Vec{a[0] / n, a[1] / n, a[2] / n} : a;
}

std::uint8_t to_byte(double value) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(value, 0.0, 255.0)));
}

Rgb mix(const Rgb& a, const Rgb& b, double t) {
  return {to_byte(a.r + (b.r - a.r) * t), to_byte(a.g + (b.g - a.g) * t),
          to_byte(a.b + (b.b - a.b) * t)};
}

Rgb scaled(const Rgb& c, double s) {
  return {to_byte(c.r * s), to_byte(c.g * s), to_byte(c.b * s)};
}

/// Signed doubled area of (a, b, p): positive when p is left of a->b in a y-up frame.
template <typename P>
double edge(const P& a, const P& b, double px, double py) {
  return (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x);
}

}  // namespace

Rgb viridis(double t) {
  if (!(t > 0)) return kViridisStops.front();  // also NaN
  if (t >= 1) return kViridisStops.back();
  const double x = t * (kViridisStops.size() - 1);
  const auto i = static_cast<std::size_t>(x);
  return mix(kViridisStops[i], kViridisStops[i + 1], x - static_cast<double>(i));
}

Rgb value_colour(double value, double max_value) {
  if (!std::isfinite(value)) return kNoValueColour;
  return viridis(max_value > 0 ? value / max_value : 0);
}

double max_finite(const std::vector<double>& values) {
  double m = 0;
  for (double v : values) {
    if (std::isfinite(v)) m = std::max(m, v);
  }
  return m;
}

Rasterizer::Rasterizer(const RenderOptions& options) : options_(options) {
  if (options.width < 1 || options.width > 8192 || options.height < 1 || options.height > 8192) {
    throw InvalidInput(ErrorCode::BadRenderOptions,
                       "picture size " + std::to_string(options.width) + "x" +
                           std::to_string(options.height) + " is outside 1..8192 pixels per side");
  }
  if (options.supersampling < 1 || options.supersampling > 8) {
    throw InvalidInput(
        ErrorCode::BadRenderOptions,
        "supersampling " + std::to_string(options.supersampling) + " is outside 1..8");
  }
  if (options.up_axis < 0 || options.up_axis > 2) {
    throw InvalidInput(ErrorCode::BadRenderOptions, "up axis " + std::to_string(options.up_axis) +
                                                        " is not 0 (x), 1 (y) or 2 (z)");
  }
  const long pixels = static_cast<long>(options.width) * options.height;
  while (options_.supersampling > 1 &&
         pixels * options_.supersampling * options_.supersampling > kMaxSamples) {
    --options_.supersampling;
  }
  width_ = options.width * options_.supersampling;
  height_ = options.height * options_.supersampling;
}

namespace {

/// Refuses decals, values or triangles that do not match the vertices.
void check_scene(const RenderScene& scene) {
  const std::size_t n = scene.positions.size();
  if (!scene.decal.empty() && scene.decal.size() != n) {
    throw InvalidInput(ErrorCode::BadScene, std::to_string(scene.decal.size()) +
                                                " decal coordinates for " + std::to_string(n) +
                                                " vertices");
  }
  if (!scene.values.empty() && scene.values.size() != n) {
    throw InvalidInput(ErrorCode::BadScene, std::to_string(scene.values.size()) + " values for " +
                                                std::to_string(n) + " vertices");
  }
  for (std::size_t f = 0; f < scene.triangles.size(); ++f) {
    for (std::uint32_t v : scene.triangles[f]) {
      if (v >= n) {
        throw InvalidInput(ErrorCode::BadScene, "triangle " + std::to_string(f) + " uses vertex " +
                                                    std::to_string(v) + " of " + std::to_string(n));
      }
    }
  }
}

/// Gouraud: the headlight's intensity at each vertex from its area-weighted normal, two-sided
/// so that open meshes seen from behind are lit too.
std::vector<double> vertex_light(const RenderScene& scene, const Vec& eye, double ambient_light) {
  const std::size_t n = scene.positions.size();
  std::vector<Vec> normals(n, Vec{0, 0, 0});
  for (const auto& t : scene.triangles) {
    const Vec face_normal = cross(sub(scene.positions[t[1]], scene.positions[t[0]]),
                                  sub(scene.positions[t[2]], scene.positions[t[0]]));
    for (std::uint32_t v : t) {
      for (int k = 0; k < 3; ++k) normals[v][k] += face_normal[k];
    }
  }
  const double ambient = std::clamp(ambient_light, 0.0, 1.0);
  std::vector<double> light(n, 1.0);
  for (std::size_t v = 0; v < n; ++v) {
    if (dot(normals[v], normals[v]) > 0) {
      light[v] = ambient + (1 - ambient) * std::abs(dot(normalized(normals[v]), eye));
    }
  }
  return light;
}

}  // namespace

Image Rasterizer::draw(const RenderScene& scene) {
  check_scene(scene);
  const std::size_t n = scene.positions.size();

  // Camera: `eye` points from the scene towards the viewer; `right` and `up` span the picture.
  const double pi = std::acos(-1.0);
  const double azimuth = options_.azimuth * pi / 180;
  const double elevation = std::clamp(options_.elevation, -90.0, 90.0) * pi / 180;
  Vec world_up{}, front{}, side{};
  world_up[static_cast<std::size_t>(options_.up_axis)] = 1;
  front[static_cast<std::size_t>((options_.up_axis + 1) % 3)] = 1;
  side[static_cast<std::size_t>((options_.up_axis + 2) % 3)] = 1;
  Vec horizontal{};
  for (int k = 0; k < 3; ++k) {
    horizontal[k] = std::cos(azimuth) * front[k] + std::sin(azimuth) * side[k];
  }
  Vec eye{};
  for (int k = 0; k < 3; ++k) {
    eye[k] = std::cos(elevation) * horizontal[k] + std::sin(elevation) * world_up[k];
  }
  const Vec right = normalized(cross(world_up, horizontal));  // never 0: horizontal _|_ up
  const Vec up = cross(eye, right);

  // Fit the projection of everything drawn into the picture, less the margins.
  double min_x = std::numeric_limits<double>::infinity(), max_x = -min_x;
  double min_y = min_x, max_y = -min_x, min_depth = min_x, max_depth = -min_x;
  auto extend = [&](const Point3& p) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      throw InvalidInput(ErrorCode::BadScene, "a position is not finite");
    }
    const double x = dot(p, right), y = dot(p, up), depth = dot(p, eye);
    min_x = std::min(min_x, x), max_x = std::max(max_x, x);
    min_y = std::min(min_y, y), max_y = std::max(max_y, y);
    min_depth = std::min(min_depth, depth), max_depth = std::max(max_depth, depth);
  };
  for (const Point3& p : scene.positions) extend(p);
  for (const Point3& p : scene.polyline) extend(p);
  for (const Point3& p : scene.markers) extend(p);
  const double usable = 1 - 2 * std::clamp(options_.margin, 0.0, 0.45);
  double scale = 1;
  if (max_x > min_x || max_y > min_y) {
    scale = std::numeric_limits<double>::infinity();
    if (max_x > min_x) scale = std::min(scale, width_ * usable / (max_x - min_x));
    if (max_y > min_y) scale = std::min(scale, height_ * usable / (max_y - min_y));
  }
  const double centre_x = std::isfinite(min_x) ? (min_x + max_x) / 2 : 0;
  const double centre_y = std::isfinite(min_y) ? (min_y + max_y) / 2 : 0;
  const double centre_depth = std::isfinite(min_depth) ? (min_depth + max_depth) / 2 : 0;
  // Depth is scaled like x and y, so that depth biases are in (supersampled) pixels, and
  // centred, so that the float z-buffer keeps its precision far from the origin.
  auto project = [&](const Point3& p) {
    return Projected{width_ / 2.0 + (dot(p, right) - centre_x) * scale,
                     height_ / 2.0 - (dot(p, up) - centre_y) * scale,
                     (dot(p, eye) - centre_depth) * scale};
  };
  std::vector<Projected> screen(n);
  for (std::size_t v = 0; v < n; ++v) screen[v] = project(scene.positions[v]);

  const std::vector<double> light = vertex_light(scene, eye, options_.ambient);

  const std::size_t samples = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  depth_.assign(samples, -std::numeric_limits<float>::infinity());
  colour_.assign(samples, options_.background);
  const double max_value = options_.max_value > 0 ? options_.max_value : max_finite(scene.values);
  shade_triangles(scene, screen, light, max_value);

  // The polyline and the markers: an outline, then the colour, both tested against the
  // surface's depth with a bias of a few line widths (the surface under a thick line may rise
  // towards the viewer on one side of it).
  const double s = options_.supersampling;
  const double half = options_.polyline_width * s / 2, outline = half + 1.2 * s;
  std::vector<Projected> line;
  for (const Point3& p : scene.polyline) line.push_back(project(p));
  for (int pass = 0; pass < 2; ++pass) {
    for (std::size_t i = 0; i + 1 < line.size(); ++i) {
      draw_segment(line[i], line[i + 1], pass == 0 ? outline : half, 3 * outline,
                   pass == 0 ? options_.outline_colour : options_.polyline_colour);
    }
  }
  const double radius = options_.marker_radius * s;
  for (const Point3& p : scene.markers) {
    const Projected q = project(p);
    draw_segment(q, q, radius + 1.2 * s, 3 * radius, options_.outline_colour);
    draw_segment(q, q, radius, 3 * radius, options_.marker_colour);
  }
  return downsample();
}

void Rasterizer::shade_triangles(const RenderScene& scene, const std::vector<Projected>& screen,
                                 const std::vector<double>& light, double max_value) {
  const bool has_values = !scene.values.empty();
  const bool has_decal = !scene.decal.empty() && scene.decal_square > 0;
  // The decal's two squares: light and dark enough to read over any part of the colour map.
  constexpr Rgb kDecalLight{245, 245, 245}, kDecalDark{35, 35, 35};
  const int lines = max_value > 0 ? std::max(0, options_.isolines) : 0;
  const double step = lines > 0 ? max_value / (lines + 1) : 0;
  const double line_half = options_.isoline_width * options_.supersampling / 2;

  for (const auto& t : scene.triangles) {
    const Projected &a = screen[t[0]], &b = screen[t[1]], &c = screen[t[2]];
    const double area = edge(a, b, c.x, c.y);
    if (std::abs(area) < 1e-12) continue;  // seen edge-on
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({a.x, b.x, c.x}))));
    const int x1 = std::min(width_ - 1, static_cast<int>(std::ceil(std::max({a.x, b.x, c.x}))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({a.y, b.y, c.y}))));
    const int y1 = std::min(height_ - 1, static_cast<int>(std::ceil(std::max({a.y, b.y, c.y}))));
    if (x0 > x1 || y0 > y1) continue;

    double v[3] = {0, 0, 0};
    bool valued = has_values;
    for (int k = 0; k < 3 && has_values; ++k) {
      v[k] = scene.values[t[k]];
      valued = valued && std::isfinite(v[k]);
    }
    // Screen gradient of the value (constant over the triangle), for the iso-line width.
    const double dw0x = (b.y - c.y) / area, dw0y = (c.x - b.x) / area;
    const double dw1x = (c.y - a.y) / area, dw1y = (a.x - c.x) / area;
    const double gradient = std::hypot((v[0] - v[2]) * dw0x + (v[1] - v[2]) * dw1x,
                                       (v[0] - v[2]) * dw0y + (v[1] - v[2]) * dw1y);
    const double l[3] = {light[t[0]], light[t[1]], light[t[2]]};
    std::array<double, 2> uv[3] = {};
    bool decal = has_decal;
    for (int k = 0; k < 3 && has_decal; ++k) {
      uv[k] = scene.decal[t[k]];
      decal = decal && std::isfinite(uv[k][0]) && std::isfinite(uv[k][1]);
    }

    for (int y = y0; y <= y1; ++y) {
      const double py = y + 0.5;
      for (int x = x0; x <= x1; ++x) {
        const double px = x + 0.5;
        const double w0 = edge(b, c, px, py) / area;
        const double w1 = edge(c, a, px, py) / area;
        const double w2 = 1 - w0 - w1;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const double depth = w0 * a.depth + w1 * b.depth + w2 * c.depth;
        const std::size_t at = static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) +
                               static_cast<std::size_t>(x);
        if (!(depth > depth_[at])) continue;
        depth_[at] = static_cast<float>(depth);

        Rgb colour = kNoValueColour;
        if (valued) {
          const double value = w0 * v[0] + w1 * v[1] + w2 * v[2];
          colour = value_colour(value, max_value);
          if (lines > 0 && gradient > 0) {
            const double level = std::round(value / step);
            if (level >= 1 && level <= lines) {
              const double pixels = std::abs(value - level * step) / gradient;
              const double cover = std::clamp(line_half + 0.5 - pixels, 0.0, 1.0);
              colour = mix(colour, options_.isoline_colour, cover);
            }
          }
        }
        if (decal) {
          const double u = w0 * uv[0][0] + w1 * uv[1][0] + w2 * uv[2][0];
          const double w = w0 * uv[0][1] + w1 * uv[1][1] + w2 * uv[2][1];
          const auto parity = (static_cast<long long>(std::floor(u / scene.decal_square)) +
                               static_cast<long long>(std::floor(w / scene.decal_square))) &
                              1;
          colour = mix(colour, parity ? kDecalLight : kDecalDark, 0.7);
        }
        colour_[at] = scaled(colour, w0 * l[0] + w1 * l[1] + w2 * l[2]);
      }
    }
  }
}

void Rasterizer::draw_segment(const Projected& a, const Projected& b, double half_width,
                              double bias, const Rgb& colour) {
  const int x0 = std::max(0, static_cast<int>(std::floor(std::min(a.x, b.x) - half_width)));
  const int x1 = std::min(width_ - 1, static_cast<int>(std::ceil(std::max(a.x, b.x) + half_width)));
  const int y0 = std::max(0, static_cast<int>(std::floor(std::min(a.y, b.y) - half_width)));
  const int y1 =
      std::min(height_ - 1, static_cast<int>(std::ceil(std::max(a.y, b.y) + half_width)));
  const double dx = b.x - a.x, dy = b.y - a.y;
  const double length2 = dx * dx + dy * dy;
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      const double px = x + 0.5 - a.x, py = y + 0.5 - a.y;
      const double t = length2 > 0 ? std::clamp((px * dx + py * dy) / length2, 0.0, 1.0) : 0;
      const double ex = px - t * dx, ey = py - t * dy;
      if (ex * ex + ey * ey > half_width * half_width) continue;
      const std::size_t at = static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) +
                             static_cast<std::size_t>(x);
      const double depth = a.depth + t * (b.depth - a.depth);
      if (depth + bias >= depth_[at]) colour_[at] = colour;
    }
  }
}

Image Rasterizer::downsample() const {
  const int s = options_.supersampling;
  Image image;
  image.width = options_.width;
  image.height = options_.height;
  image.rgb.resize(static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height) *
                   3);
  std::size_t out = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      unsigned sum[3] = {0, 0, 0};
      for (int j = 0; j < s; ++j) {
        const std::size_t row =
            static_cast<std::size_t>(y * s + j) * static_cast<std::size_t>(width_);
        for (int i = 0; i < s; ++i) {
          const Rgb& c = colour_[row + static_cast<std::size_t>(x * s + i)];
          sum[0] += c.r, sum[1] += c.g, sum[2] += c.b;
        }
      }
      const unsigned count = static_cast<unsigned>(s * s);
      for (unsigned channel : sum)
        image.rgb[out++] = static_cast<std::uint8_t>((channel + count / 2) / count);
    }
  }
  return image;
}

Image render(const RenderScene& scene, const RenderOptions& options) {
  return Rasterizer(options).draw(scene);
}

}  // namespace geoprox::cli
