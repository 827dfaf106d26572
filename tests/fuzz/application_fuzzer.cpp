// libFuzzer target: geodesic splines and the exponential map (core/apps/geodesic_spline.h,
// core/apps/exponential_map.h) with hostile parameters on flat grids, where geodesics run through
// vertices whose angle sum is 2 pi and along chains of collinear edges.
//
// Input, read as a little stream (a short input reads zeros past its end):
//   byte 0: grid (mod 3), byte 1: flags (bit 0 exact, bit 1 B-spline, bit 2 raw doubles for
//   the points' parameters, bit 3 the expmap's radius raw), byte 2: curve samples (mod 64),
//   byte 3: control points (mod 12), then per point a kind byte (mod 3: vertex, edge, face),
//   a 16-bit id (taken modulo the count, or past it when the kind byte's bit 7 is set), and its
//   parameters (16-bit fractions, or raw doubles that may be NaN, negative or off the simplex);
//   then the expmap's radius.
// Findings: any crash, sanitizer report or hang (each call runs under a 20 s deadline: past it
// is a finding), any exception but the documented InvalidInput, and a curve that does not have
// the requested points, leaves the grid, or (Bezier) does not start at its first control point.
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "core/base/errors.h"
#include "core/apps/exponential_map.h"
#include "core/query/geodesic_query.h"
#include "core/apps/geodesic_spline.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/graph/proximity_graph.h"

namespace {

using namespace geoprox;

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "application_fuzzer: %s: %s\n", what, detail.c_str());
  std::abort();
}

/// A flat grid of nx x ny cells of size h, every cell split along one diagonal or alternating,
/// without the cells `hole` picks, and what the queries need on it.
struct Grid {
  Grid(int nx, int ny, double h, bool alternate, int hole_i, int hole_j) {
    std::vector<Vec3> positions;
    for (int j = 0; j <= ny; ++j) {
      for (int i = 0; i <= nx; ++i) positions.push_back({i * h, j * h, 0});
    }
    std::vector<Triangle> faces;
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        if (i == hole_i && j == hole_j) continue;
        const auto at = [&](int a, int b) { return static_cast<std::uint32_t>(b * (nx + 1) + a); };
        if (alternate && (i + j) % 2 == 1) {
          faces.push_back({at(i, j), at(i + 1, j), at(i, j + 1)});
          faces.push_back({at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
        } else {
          faces.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
          faces.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
      }
    }
    size = std::hypot(nx * h, ny * h);
    mesh = std::make_unique<TriangleMesh>(positions, faces);
    geometry = std::make_unique<IntrinsicGeometry>(*mesh);
    ProximityGraphOptions options;
    options.threads = 1;
    graph = std::make_unique<ProximityGraph>(build_proximity_graph(*mesh, *geometry, options));
    query = std::make_unique<GeodesicQuery>(*mesh, *geometry, graph->view());
  }
  double size = 0;
  std::unique_ptr<TriangleMesh> mesh;
  std::unique_ptr<IntrinsicGeometry> geometry;
  std::unique_ptr<ProximityGraph> graph;
  std::unique_ptr<GeodesicQuery> query;
};

const Grid& grid(int which) {
  static const Grid grids[] = {Grid(8, 8, 0.1, true, -1, -1), Grid(6, 5, 1.3, false, -1, -1),
                               Grid(7, 7, 0.05, true, 3, 4)};
  return grids[which];
}

class Reader {
 public:
  Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint8_t byte() { return at_ < size_ ? data_[at_++] : 0; }
  std::uint16_t u16() { return static_cast<std::uint16_t>(byte() | (byte() << 8)); }
  double fraction() { return u16() / 65535.0; }
  double raw() {
    std::uint64_t bits = 0;
    for (int k = 0; k < 8; ++k) bits |= static_cast<std::uint64_t>(byte()) << (8 * k);
    double out;
    std::memcpy(&out, &bits, sizeof out);
    return out;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_, at_ = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Reader in(data, size);
  const Grid& g = grid(in.byte() % 3);
  const TriangleMesh& mesh = *g.mesh;
  const std::uint8_t flags = in.byte();
  GeodesicSplineOptions options;
  options.geodesics = flags & 1 ? SplineGeodesics::Exact : SplineGeodesics::Graph;
  options.type = flags & 2 ? SplineType::BSpline : SplineType::Bezier;
  options.samples = in.byte() % 64;
  const int count = in.byte() % 12;
  std::vector<SurfacePoint> control;
  for (int k = 0; k < count; ++k) {
    const std::uint8_t kind = in.byte();
    const bool past = kind & 0x80;
    auto id = [&](std::size_t n) {
      const std::uint32_t raw_id = in.u16();
      return past ? static_cast<std::uint32_t>(n) + raw_id : raw_id % static_cast<std::uint32_t>(n);
    };
    const bool raw = flags & 4;
    switch (kind % 3) {
      case 0:
        control.push_back(SurfacePoint::vertex(id(mesh.num_vertices())));
        break;
      case 1: {
        const std::uint32_t e = id(mesh.num_edges());
        control.push_back(SurfacePoint::edge(e, raw ? in.raw() : in.fraction()));
        break;
      }
      default: {
        const std::uint32_t f = id(mesh.num_faces());
        double b0 = raw ? in.raw() : in.fraction(), b1 = raw ? in.raw() : in.fraction();
        if (!raw && b0 + b1 > 1) {
          b0 = 1 - b0;
          b1 = 1 - b1;
        }
        control.push_back(SurfacePoint::face(f, b0, b1, raw ? in.raw() : 1 - b0 - b1));
      }
    }
  }
  const double radius = flags & 8 ? in.raw() : in.fraction() * g.size;

  QueryInterrupt deadline;
  deadline.deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  options.interrupt = &deadline;
  try {
    GeodesicSpline spline(*g.query);
    const GeodesicSplineResult r = spline.compute(control, options);
    if (r.curve.size() != options.samples) finding("curve size", std::to_string(r.curve.size()));
    for (const PathPoint& p : r.curve) {
      const Vec3& x = p.position;
      if (!(x.x >= -1e-9 && x.y >= -1e-9 && x.x <= g.size && x.y <= g.size && x.z == 0)) {
        finding("curve point off the grid", p.point.to_string());
      }
    }
    // The first control point as the solvers take it: barycentrics accepted off the simplex
    // (their sum within kBarycentricSumTolerance of 1) name the point of their normalized form.
    SurfacePoint first = control.front();
    if (first.kind == SurfacePoint::Kind::Face) {
      const double sum = first.bary[0] + first.bary[1] + first.bary[2];
      for (double& b : first.bary) b /= sum;
    }
    if (options.type == SplineType::Bezier &&
        norm(r.curve.front().position - first.position(mesh)) > 1e-9 * g.size) {
      finding("Bezier does not start at its first control point", control.front().to_string());
    }
  } catch (const InvalidInput&) {
  } catch (const Interrupted& e) {
    finding("spline ran past 20 s", e.what());
  } catch (const std::exception& e) {
    finding("spline threw", e.what());
  }
  if (control.empty()) return 0;
  try {
    ExponentialMap map(*g.query);
    ExponentialMapOptions map_options;
    map_options.radius = radius;
    map_options.mode = flags & 1 ? ExponentialMapMode::Exact : ExponentialMapMode::Graph;
    map_options.interrupt = &deadline;
    const ExponentialMapResult r = map.compute(control.front(), map_options);
    for (const ExponentialMapVertex& v : r.vertices) {
      if (!(v.distance <= radius) || !std::isfinite(v.u) || !std::isfinite(v.v)) {
        finding("expmap vertex", std::to_string(v.vertex));
      }
    }
  } catch (const InvalidInput&) {
  } catch (const Interrupted& e) {
    finding("expmap ran past 20 s", e.what());
  } catch (const std::exception& e) {
    finding("expmap threw", e.what());
  }
  return 0;
}
