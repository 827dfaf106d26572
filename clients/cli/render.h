// Software rasterizer of `geoprox render`: a z-buffer (E. Catmull, "A subdivision algorithm for
// computer display of curved surfaces", 1974) with Gouraud shading (H. Gouraud, "Continuous
// shading of curved surfaces", 1971) under a headlight, an orthographic camera fitted to the
// mesh, a per-vertex scalar coloured by viridis with iso-lines, and a polyline drawn on top.
//
// It needs no display and no library: plain arrays in, RGB pixels out (PNG encoding is in
// result_files.h). Independent of geoprox::core, so it draws any triangle soup.
//
// Iso-lines are drawn per pixel from the interpolated value. Their width is exact in screen
// space without derivatives of neighbouring pixels: the value is affine over a projected
// triangle, so its screen gradient is one constant per triangle, and |value - level| / |gradient|
// is the pixel's distance to the level line. Edges are smoothed by supersampling (rendering at
// `supersampling` times the size and averaging blocks).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace geoprox::cli {

struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
};

/// Viridis (S. van der Walt, N. Smith, E. Firing: matplotlib's perceptually uniform colour map,
/// CC0), from dark purple (68,1,84) at t = 0 through teal to yellow (253,231,37) at t = 1:
/// 33 evenly spaced stops of matplotlib's 256-entry table, interpolated linearly (within 2/255 of
/// the table). `t` is clamped to [0, 1]; NaN gives t = 0.
Rgb viridis(double t);

/// Colour of a vertex with no value (unreachable, or beyond a cutoff): mid grey, which viridis
/// never takes.
inline constexpr Rgb kNoValueColour{128, 128, 128};

/// The colour map of geoprox's result files and pictures: viridis(value / max_value), and
/// kNoValueColour for a non-finite value. max_value <= 0 (a field that is 0 wherever it is
/// finite) maps every finite value to viridis(0).
Rgb value_colour(double value, double max_value);

/// The largest finite value, 0 if there is none.
double max_finite(const std::vector<double>& values);

using Point3 = std::array<double, 3>;

/// What to draw. Indices refer to `positions`; `values` has one entry per position (or none:
/// the surface is then drawn in kNoValueColour).
struct RenderScene {
  std::vector<Point3> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  /// Per-vertex scalar; a non-finite value means "no value": a triangle with such a corner is
  /// drawn in kNoValueColour, without iso-lines.
  std::vector<double> values;
  /// Drawn as a thick line over the surface (depth-tested: hidden behind the mesh). Empty: none.
  std::vector<Point3> polyline;
  /// Drawn as dots (e.g. the sources and the target), depth-tested like the polyline.
  std::vector<Point3> markers;
  /// A decal (paper Fig. 14): per-vertex texture coordinates (u, v), e.g. an exponential map,
  /// in mesh units; a triangle whose corners all have finite coordinates gets a checkerboard of
  /// squares of side `decal_square` over its colour. Empty: no decal.
  std::vector<std::array<double, 2>> decal;
  double decal_square = 0;
};

struct RenderOptions {
  int width = 640;   ///< picture width in pixels
  int height = 480;  ///< picture height in pixels
  /// Viewing direction in degrees: azimuth about the up axis (0 looks from the +front axis:
  /// +z for up y, +x for up z, +y for up x; 90 from the +side axis: +x, +y, +z), elevation
  /// above the horizontal plane (90 looks straight down).
  double azimuth = 30;
  double elevation = 20;
  /// Up axis of the mesh: 0 x, 1 y (most OBJ files), 2 z.
  int up_axis = 1;
  /// Iso-lines at k * max_value / (isolines + 1), k = 1..isolines (evenly spaced strictly
  /// between 0 and the largest value); 0 draws none.
  int isolines = 10;
  /// The value drawn at the top of the colour map; 0 means the largest finite value.
  double max_value = 0;
  /// Samples per pixel along each axis (1 = no smoothing); lowered for large pictures so that
  /// the samples stay below 2^25 (about 230 MB of buffers).
  int supersampling = 3;
  double margin = 0.04;         ///< fraction of the width and height left free on each side
  double isoline_width = 1.3;   ///< pixels
  double polyline_width = 3.5;  ///< pixels, without its dark outline
  double marker_radius = 5;     ///< pixels
  double ambient = 0.3;         ///< light that does not depend on the normal, 0..1
  Rgb background{255, 255, 255};
  Rgb isoline_colour{25, 25, 25};
  Rgb polyline_colour{235, 40, 40};
  Rgb outline_colour{20, 20, 20};  ///< outline of the polyline and the markers
  Rgb marker_colour{255, 255, 255};
};

/// 8-bit RGB pixels, rows from the top, 3 bytes per pixel.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;
};

/// Draws scenes with one set of options, keeping its buffers between calls (for several
/// pictures of the same size). Throws InvalidInput ("BadRenderOptions") for a size outside
/// 1..8192, supersampling outside 1..8 or an up axis outside 0..2, and ("BadScene") for values
/// that do not match the positions, a corner index out of range or non-finite coordinates.
class Rasterizer {
 public:
  explicit Rasterizer(const RenderOptions& options = {});
  Image draw(const RenderScene& scene);

 private:
  struct Projected {
    double x = 0, y = 0, depth = 0;  ///< supersampled pixels; depth grows towards the viewer
  };
  void shade_triangles(const RenderScene& scene, const std::vector<Projected>& screen,
                       const std::vector<double>& light, double max_value);
  void draw_segment(const Projected& a, const Projected& b, double half_width, double bias,
                    const Rgb& colour);
  Image downsample() const;

  RenderOptions options_;
  int width_ = 0, height_ = 0;  ///< supersampled size
  std::vector<float> depth_;    ///< per sample; -inf where no triangle was drawn
  std::vector<Rgb> colour_;     ///< per sample
};

/// One-shot: Rasterizer(options).draw(scene).
Image render(const RenderScene& scene, const RenderOptions& options = {});

}  // namespace geoprox::cli
