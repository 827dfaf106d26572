#include "core/query/geodesic_query.h"

#include <utility>

#include "core/graph/refined_surface.h"
#include "core/query/query_engine.h"

namespace geoprox {

QueryScratch::QueryScratch(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
void QueryScratch::set_interrupt(const QueryInterrupt* interrupt) { impl_->interrupt = interrupt; }
void QueryScratch::set_run_both(RunBoth run_both) { impl_->run_both = std::move(run_both); }
QueryScratch::QueryScratch(QueryScratch&&) noexcept = default;
QueryScratch& QueryScratch::operator=(QueryScratch&&) noexcept = default;
QueryScratch::~QueryScratch() = default;

GeodesicQuery::GeodesicQuery(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                             const ProximityGraphView& graph, const Options& options)
    : GeodesicQuery(mesh, geometry, graph, options, detail::QueryTuning{}) {}
GeodesicQuery::GeodesicQuery(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                             const ProximityGraphView& graph, const Options& options,
                             const detail::QueryTuning& tuning)
    : engine_(std::make_unique<detail::QueryEngine>(mesh, geometry, graph, options, tuning)),
      mesh_(&mesh),
      geometry_(&geometry) {}
GeodesicQuery::GeodesicQuery(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                             const ProximityGraphView& graph, const RefinedSurface& refined,
                             const Options& options)
    : engine_(std::make_unique<detail::QueryEngine>(refined.mesh(), refined.geometry(), graph,
                                                    options, detail::QueryTuning{})),
      mesh_(&mesh),
      geometry_(&geometry),
      refined_(&refined) {
  if (&refined.input() != &mesh) {
    throw InvalidInput(ErrorCode::GraphMismatch,
                       "the graph was built on a refinement of another mesh object");
  }
}
GeodesicQuery::~GeodesicQuery() = default;
GeodesicQuery::GeodesicQuery(GeodesicQuery&&) noexcept = default;
GeodesicQuery& GeodesicQuery::operator=(GeodesicQuery&&) noexcept = default;

SurfacePoint GeodesicQuery::to_engine(const SurfacePoint& point) const {
  if (refined_ == nullptr) return point;
  point.validate(*mesh_);
  return refined_->map().to_refined(point);
}

std::vector<SurfacePoint> GeodesicQuery::to_engine(std::span<const SurfacePoint> points) const {
  std::vector<SurfacePoint> out;
  out.reserve(points.size());
  for (const SurfacePoint& p : points) out.push_back(to_engine(p));
  return out;
}

void GeodesicQuery::path_to_mesh(PathResult& path, const SurfacePoint& s,
                                 const SurfacePoint& t) const {
  if (refined_ == nullptr || path.points.empty()) return;
  for (PathPoint& p : path.points) p.point = refined_->map().to_input(p.point);
  // The ends as given (mapping there and back may round their barycentrics).
  path.points.front().point = s;
  path.points.back().point = t;
}

QueryScratch GeodesicQuery::make_scratch() const { return engine_->make_scratch(); }
DistanceResult GeodesicQuery::exact_distance(const SurfacePoint& s, const SurfacePoint& t,
                                             QueryScratch& scratch) const {
  return engine_->exact_distance(to_engine(s), to_engine(t), scratch);
}
PathResult GeodesicQuery::exact_path(const SurfacePoint& s, const SurfacePoint& t,
                                     QueryScratch& scratch) const {
  PathResult path = engine_->exact_path(to_engine(s), to_engine(t), scratch);
  path_to_mesh(path, s, t);
  return path;
}
DistanceResult GeodesicQuery::distance(const SurfacePoint& s, const SurfacePoint& t,
                                       QueryScratch& scratch) const {
  return engine_->distance(to_engine(s), to_engine(t), scratch);
}
PathResult GeodesicQuery::path(const SurfacePoint& s, const SurfacePoint& t,
                               QueryScratch& scratch) const {
  PathResult path = engine_->path(to_engine(s), to_engine(t), scratch);
  path_to_mesh(path, s, t);
  return path;
}
DistanceField GeodesicQuery::field(std::span<const SurfacePoint> sources, QueryScratch& scratch,
                                   const DistanceFieldOptions& options) const {
  if (refined_ == nullptr) return engine_->field(sources, scratch, options);
  DistanceField field = engine_->field(to_engine(sources), scratch, options);
  // The mesh's vertices are the refined mesh's first ones, with the same ids.
  field.distances.resize(mesh_->num_vertices());
  field.nearest_source.resize(mesh_->num_vertices());
  return field;
}
std::vector<double> GeodesicQuery::matrix(std::span<const SurfacePoint> sources,
                                          std::span<const SurfacePoint> targets,
                                          QueryScratch& scratch) const {
  if (refined_ == nullptr) return engine_->matrix(sources, targets, scratch);
  return engine_->matrix(to_engine(sources), to_engine(targets), scratch);
}
SurfacePoint GeodesicQuery::sample_point(std::uint32_t sample) const {
  const SurfacePoint p = engine_->sample_point(sample);
  return refined_ == nullptr ? p : refined_->map().to_input(p);
}
SnapResult GeodesicQuery::snap(const Vec3& position) const {
  SnapResult r = engine_->snap(position);
  if (refined_ != nullptr) r.point = refined_->map().to_input(r.point);
  return r;
}
const TriangleMesh& GeodesicQuery::mesh() const { return *mesh_; }
const IntrinsicGeometry& GeodesicQuery::geometry() const { return *geometry_; }
const ProximityGraphView& GeodesicQuery::graph() const { return engine_->graph(); }
double GeodesicQuery::link_radius() const { return engine_->link_radius(); }
const GeodesicQueryOptions& GeodesicQuery::options() const { return engine_->options(); }

}  // namespace geoprox
