#include "core/geodesic/exact_geodesic.h"

#include <limits>
#include <string>

#include "core/base/errors.h"
#include "core/geodesic/window_propagation.h"

namespace geoprox {

ExactGeodesicSolver::ExactGeodesicSolver(const TriangleMesh& mesh,
                                         const IntrinsicGeometry& geometry)
    : engine_(std::make_unique<detail::WindowPropagation>(mesh, geometry)) {}
ExactGeodesicSolver::~ExactGeodesicSolver() = default;
ExactGeodesicSolver::ExactGeodesicSolver(ExactGeodesicSolver&&) noexcept = default;
ExactGeodesicSolver& ExactGeodesicSolver::operator=(ExactGeodesicSolver&&) noexcept = default;

void ExactGeodesicSolver::solve(std::span<const GeodesicSource> sources,
                                std::span<const SurfacePoint> targets, const Options& options) {
  engine_->solve(sources, targets, options);
}
void ExactGeodesicSolver::solve(std::span<const GeodesicSource> sources,
                                const GeodesicTargets& targets, const Options& options) {
  engine_->solve(sources, targets, options);
}
void ExactGeodesicSolver::solve(const SurfacePoint& source, const Options& options) {
  engine_->solve(source, options);
}

double ExactGeodesicSolver::distance(std::uint32_t vertex) const {
  return engine_->distance(vertex);
}
double ExactGeodesicSolver::distance(const SurfacePoint& point) const {
  return engine_->distance(point);
}
std::vector<double> ExactGeodesicSolver::vertex_distances() const {
  return engine_->vertex_distances();
}
std::int32_t ExactGeodesicSolver::nearest_source(std::uint32_t vertex) const {
  return engine_->nearest_source(vertex);
}
GeodesicPath ExactGeodesicSolver::path_to(const SurfacePoint& point) const {
  return engine_->path_to(point);
}
const std::vector<std::uint32_t>& ExactGeodesicSolver::touched_vertices() const {
  return engine_->touched_vertices();
}
std::size_t ExactGeodesicSolver::windows_stored() const { return engine_->windows_stored(); }
std::uint32_t ExactGeodesicSolver::window_halfedge(std::size_t window) const {
  return engine_->window_halfedge(window);
}
double ExactGeodesicSolver::radius_reached() const { return engine_->radius_reached(); }
const std::vector<std::uint32_t>& ExactGeodesicSolver::settled_targets() const {
  return engine_->settled_targets();
}
const std::vector<double>& ExactGeodesicSolver::settled_target_distances() const {
  return engine_->settled_target_distances();
}
const ExactGeodesicStats& ExactGeodesicSolver::stats() const { return engine_->stats(); }
const TriangleMesh& ExactGeodesicSolver::mesh() const { return engine_->mesh(); }
const IntrinsicGeometry& ExactGeodesicSolver::geometry() const { return engine_->geometry(); }

// Targets: validated once, indexed by vertex and by face so that a solve finds the targets of
// what it reaches without searching.
void GeodesicTargets::assign(const IntrinsicGeometry& geometry,
                             std::span<const SurfacePoint> points) {
  const TriangleMesh& mesh = geometry.mesh();
  for (const SurfacePoint& p : points) p.validate(mesh);
  if (points.size() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max())) {
    throw InvalidInput(ErrorCode::TooManyTargets,
                       std::to_string(points.size()) + " targets (at most 2^31 - 1)");
  }
  // Before any change: a list head must never name an entry that a failed push left out.
  entries_.reserve(points.size());
  if (geometry_ != &geometry) {
    vertex_first_.assign(mesh.num_vertices(), -1);
    face_first_.assign(mesh.num_faces(), -1);
  } else {
    for (const Entry& e : entries_)
      (e.vertex >= 0 ? vertex_first_[e.vertex] : face_first_[e.face]) = -1;
  }
  geometry_ = &geometry;
  entries_.clear();
  face_targets_ = 0;
  for (const SurfacePoint& p : points) {
    const auto index = static_cast<std::int32_t>(entries_.size());
    Entry e{};
    if (p.kind == SurfacePoint::Kind::Vertex) {
      e.vertex = static_cast<std::int32_t>(p.id);
      e.next = vertex_first_[p.id];
      vertex_first_[p.id] = index;
    } else {
      const auto [face, bary] = p.in_face(mesh);
      e.vertex = -1;
      e.face = face;
      e.point = geometry.face_point(face, bary.data());
      e.next = face_first_[face];
      face_first_[face] = index;
      ++face_targets_;
    }
    entries_.push_back(e);
  }
}

// ---------------------------------------------------------------------------------------------

std::vector<double> exact_geodesic_distances(const TriangleMesh& mesh,
                                             const IntrinsicGeometry& geometry,
                                             std::span<const GeodesicSource> sources,
                                             const ExactGeodesicSolver::Options& options) {
  ExactGeodesicSolver solver(mesh, geometry);
  solver.solve(sources, {}, options);
  return solver.vertex_distances();
}

GeodesicPath exact_geodesic_path(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                                 const SurfacePoint& source, const SurfacePoint& target) {
  ExactGeodesicSolver solver(mesh, geometry);
  const GeodesicSource one{source, 0.0};
  const SurfacePoint targets[] = {target};
  ExactGeodesicSolver::Options options;
  options.stop_after_targets = 1;
  solver.solve(std::span<const GeodesicSource>(&one, 1), targets, options);
  return solver.path_to(target);
}

}  // namespace geoprox
