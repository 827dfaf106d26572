#include "core/apps/geodesic_spline.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <exception>
#include <string>

#include "core/apps/exponential_map.h"  // canonical_surface_point

namespace geoprox {

namespace {

/// Barycentrics of `p` in face f, if f contains it.
bool barycentrics_in_face(const TriangleMesh& mesh, const SurfacePoint& p, std::uint32_t f,
                          std::array<double, 3>& out) {
  const Triangle& corners = mesh.face(f);
  auto corner_of = [&](std::uint32_t v) {
    for (int k = 0; k < 3; ++k) {
      if (corners[k] == v) return k;
    }
    return -1;
  };
  out = {0, 0, 0};
  switch (p.kind) {
    case SurfacePoint::Kind::Vertex: {
      const int k = corner_of(p.id);
      if (k < 0) return false;
      out[k] = 1;
      return true;
    }
    case SurfacePoint::Kind::Edge: {
      const int a = corner_of(mesh.edge_origin(p.id)), b = corner_of(mesh.edge_target(p.id));
      if (a < 0 || b < 0) return false;
      out[a] = 1 - p.t;
      out[b] = p.t;
      return true;
    }
    case SurfacePoint::Kind::Face:
      if (p.id != f) return false;
      out = p.bary;
      return true;
  }
  return false;
}

/// Faces that contain `p` (for a vertex, its fan; for an edge, its one or two faces).
template <class F>
void for_each_face_of(const TriangleMesh& mesh, const SurfacePoint& p, F&& f) {
  switch (p.kind) {
    case SurfacePoint::Kind::Vertex:
      for (std::uint32_t h : mesh.outgoing_halfedges(p.id)) f(TriangleMesh::face_of(h));
      return;
    case SurfacePoint::Kind::Edge: {
      const std::uint32_t h = mesh.edge_halfedge(p.id);
      f(TriangleMesh::face_of(h));
      if (mesh.twin(h) >= 0) f(TriangleMesh::face_of(static_cast<std::uint32_t>(mesh.twin(h))));
      return;
    }
    case SurfacePoint::Kind::Face:
      f(p.id);
      return;
  }
}

struct Segment {
  std::uint32_t face = 0;
  std::array<double, 3> a{}, b{};
  double length = 0;
};

Segment segment_between(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                        const SurfacePoint& a, const SurfacePoint& b) {
  Segment s;
  bool found = false;
  for_each_face_of(mesh, a, [&](std::uint32_t f) {
    if (found) return;
    if (barycentrics_in_face(mesh, a, f, s.a) && barycentrics_in_face(mesh, b, f, s.b)) {
      s.face = f;
      found = true;
    }
  });
  if (!found) {
    throw InvalidInput(ErrorCode::BadPath, "consecutive path points " + a.to_string() + " and " +
                                               b.to_string() + " share no face");
  }
  const Vec2 pa = geometry.face_point(s.face, s.a.data()),
             pb = geometry.face_point(s.face, s.b.data());
  s.length = std::hypot(pb.x - pa.x, pb.y - pa.y);
  return s;
}

}  // namespace

SurfacePoint point_along_path(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                              std::span<const PathPoint> path, double u) {
  if (path.empty()) throw InvalidInput(ErrorCode::BadPath, "an empty path has no points along it");
  if (!(u > 0) || path.size() == 1) return path.front().point;
  if (u >= 1) return path.back().point;
  std::vector<Segment> segments;
  segments.reserve(path.size() - 1);
  double total = 0;
  for (std::size_t k = 0; k + 1 < path.size(); ++k) {
    segments.push_back(segment_between(mesh, geometry, path[k].point, path[k + 1].point));
    total += segments.back().length;
  }
  if (!(total > 0)) return path.front().point;
  const double wanted = u * total;
  double travelled = 0;
  for (const Segment& s : segments) {
    if (travelled + s.length >= wanted && s.length > 0) {
      const double w = std::clamp((wanted - travelled) / s.length, 0.0, 1.0);
      SurfacePoint p = SurfacePoint::face(s.face, (1 - w) * s.a[0] + w * s.b[0],
                                          (1 - w) * s.a[1] + w * s.b[1],
                                          (1 - w) * s.a[2] + w * s.b[2]);
      return canonical_surface_point(mesh, p);
    }
    travelled += s.length;
  }
  return path.back().point;  // rounding left `wanted` a hair beyond the sum
}

struct GeodesicSpline::Worker {
  Worker(const TriangleMesh& mesh, const IntrinsicGeometry& geometry, const GeodesicQuery* query)
      : scratch(query ? std::make_unique<QueryScratch>(query->make_scratch()) : nullptr),
        solver(mesh, geometry) {}
  std::unique_ptr<QueryScratch> scratch;  // graph mode only
  ExactGeodesicSolver solver;
  std::uint32_t geodesics = 0;
};

GeodesicSpline::GeodesicSpline(const GeodesicQuery& query)
    : mesh_(&query.mesh()), geometry_(&query.geometry()), query_(&query) {
  workers_.push_back(std::make_unique<Worker>(*mesh_, *geometry_, query_));
}

GeodesicSpline::GeodesicSpline(const TriangleMesh& mesh, const IntrinsicGeometry& geometry)
    : mesh_(&mesh), geometry_(&geometry) {
  workers_.push_back(std::make_unique<Worker>(*mesh_, *geometry_, query_));
}

GeodesicSpline::~GeodesicSpline() = default;

std::vector<PathPoint> GeodesicSpline::geodesic(const SurfacePoint& a, const SurfacePoint& b,
                                                const Options& options, Worker& worker) const {
  ++worker.geodesics;
  if (options.geodesics == SplineGeodesics::Graph &&
      norm(b.position(*mesh_) - a.position(*mesh_)) > query_->link_radius()) {
    return query_->exact_path(a, b, *worker.scratch).points;
  }
  ExactGeodesicOptions solve;
  solve.stop_after_targets = 1;
  solve.interrupt = options.interrupt;
  if (geometry_->lengths_are_chords()) solve.goal = b.position(*mesh_);
  const GeodesicSource source{a, 0};
  worker.solver.solve(std::span<const GeodesicSource>(&source, 1),
                      std::span<const SurfacePoint>(&b, 1), solve);
  if (worker.solver.settled_targets().empty()) {
    throw Unreachable(ErrorCode::Unreachable, b.to_string() + " is not reachable from " +
                                                  a.to_string() + " (another component)");
  }
  return worker.solver.path_to(b).points;
}

SurfacePoint GeodesicSpline::lerp(const SurfacePoint& a, const SurfacePoint& b, double u,
                                  const Options& options, Worker& worker) const {
  if (u <= 0) return a;
  if (u >= 1) return b;
  const std::vector<PathPoint> path = geodesic(a, b, options, worker);
  return point_along_path(*mesh_, *geometry_, path, u);
}

SurfacePoint GeodesicSpline::curve_point(const GeodesicSplineResult& out, std::size_t pieces,
                                         std::uint32_t k, const Options& options,
                                         Worker& worker) const {
  auto along = [&](std::size_t leg, double u) {
    return point_along_path(*mesh_, *geometry_, out.control_polygon[leg], u);
  };
  const double s = static_cast<double>(pieces) * k / (options.samples - 1);
  const std::size_t piece = std::min(static_cast<std::size_t>(s), pieces - 1);
  const double t = std::clamp(s - static_cast<double>(piece), 0.0, 1.0);
  if (options.type == SplineType::Bezier) {
    const std::size_t i = 3 * piece;
    const SurfacePoint q0 = along(i, t), q1 = along(i + 1, t), q2 = along(i + 2, t);
    return lerp(lerp(q0, q1, t, options, worker), lerp(q1, q2, t, options, worker), t, options,
                worker);
  }
  const std::size_t i = piece;
  const SurfacePoint q1 = along(i, (t + 2) / 3), q2 = along(i + 1, (t + 1) / 3),
                     q3 = along(i + 2, t / 3);
  return lerp(lerp(q1, q2, (t + 1) / 2, options, worker), lerp(q2, q3, t / 2, options, worker), t,
              options, worker);
}

GeodesicSplineResult GeodesicSpline::compute(std::span<const SurfacePoint> control,
                                             const Options& options) {
  const std::size_t n = control.size();
  if (options.type == SplineType::Bezier && (n < 4 || (n - 1) % 3 != 0)) {
    throw InvalidInput(ErrorCode::BadControlPoints,
                       "a cubic Bezier spline needs 3k + 1 control points "
                       "(4, 7, 10, ...), not " +
                           std::to_string(n));
  }
  if (options.type == SplineType::BSpline && n < 4) {
    throw InvalidInput(
        ErrorCode::BadControlPoints,
        "a cubic B-spline needs at least 4 control points, not " + std::to_string(n));
  }
  if (options.samples < 2) {
    throw InvalidInput(
        ErrorCode::BadSamples,
        "a spline needs at least 2 samples (its two ends), not " + std::to_string(options.samples));
  }
  if (options.geodesics == SplineGeodesics::Graph && query_ == nullptr) {
    throw InvalidInput(ErrorCode::NoGraph, "graph geodesics need a proximity graph");
  }
  std::vector<SurfacePoint> points;
  points.reserve(n);
  for (const SurfacePoint& p : control) points.push_back(canonical_surface_point(*mesh_, p));
  const int threads = std::max(
      1, std::min(options.threads > 0 ? options.threads : omp_get_max_threads(),
                  static_cast<int>(options.samples)));
  while (workers_.size() < static_cast<std::size_t>(threads)) {
    workers_.push_back(std::make_unique<Worker>(*mesh_, *geometry_, query_));
  }
  for (const auto& worker : workers_) {
    worker->geodesics = 0;
    if (worker->scratch) worker->scratch->set_interrupt(options.interrupt);
  }
  struct ClearInterrupts {  // on every way out: the scratch outlives `options`
    std::vector<std::unique_ptr<Worker>>& workers;
    ~ClearInterrupts() {
      for (const auto& worker : workers) {
        if (worker->scratch) worker->scratch->set_interrupt(nullptr);
      }
    }
  } clear_interrupts{workers_};

  GeodesicSplineResult out;
  for (std::size_t i = 0; i + 1 < n; ++i) {
    out.control_polygon.push_back(geodesic(points[i], points[i + 1], options, *workers_[0]));
  }
  const std::size_t pieces = options.type == SplineType::Bezier ? (n - 1) / 3 : n - 3;
  out.curve.resize(options.samples);
  // The first exception of any thread is rethrown once all have stopped (none may leave an
  // OpenMP region); the others skip their remaining points.
  std::exception_ptr failure;
  std::atomic<bool> failed = false;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1) if (threads > 1)
  for (std::int64_t k = 0; k < static_cast<std::int64_t>(options.samples); ++k) {
    if (failed.load(std::memory_order_relaxed)) continue;
    try {
      if (options.interrupt) options.interrupt->check();
      Worker& worker = *workers_[static_cast<std::size_t>(omp_get_thread_num())];
      const SurfacePoint c =
          curve_point(out, pieces, static_cast<std::uint32_t>(k), options, worker);
      out.curve[static_cast<std::size_t>(k)] = {c, c.position(*mesh_)};
    } catch (...) {
#pragma omp critical(geoprox_spline_failure)
      if (!failure) failure = std::current_exception();
      failed.store(true, std::memory_order_relaxed);
    }
  }
  if (failure) std::rethrow_exception(failure);
  for (const auto& worker : workers_) out.geodesics += worker->geodesics;
  return out;
}

GeodesicSplineResult geodesic_spline(const GeodesicQuery& query,
                                     std::span<const SurfacePoint> control,
                                     const GeodesicSplineOptions& options) {
  GeodesicSpline spline(query);
  return spline.compute(control, options);
}

}  // namespace geoprox
