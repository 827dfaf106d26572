#include "core/query/geodesic_query.h"

#include <utility>

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
    : engine_(std::make_unique<detail::QueryEngine>(mesh, geometry, graph, options, tuning)) {}
GeodesicQuery::~GeodesicQuery() = default;
GeodesicQuery::GeodesicQuery(GeodesicQuery&&) noexcept = default;
GeodesicQuery& GeodesicQuery::operator=(GeodesicQuery&&) noexcept = default;

QueryScratch GeodesicQuery::make_scratch() const { return engine_->make_scratch(); }
DistanceResult GeodesicQuery::exact_distance(const SurfacePoint& s, const SurfacePoint& t,
                                             QueryScratch& scratch) const {
  return engine_->exact_distance(s, t, scratch);
}
PathResult GeodesicQuery::exact_path(const SurfacePoint& s, const SurfacePoint& t,
                                     QueryScratch& scratch) const {
  return engine_->exact_path(s, t, scratch);
}
DistanceResult GeodesicQuery::distance(const SurfacePoint& s, const SurfacePoint& t,
                                       QueryScratch& scratch) const {
  return engine_->distance(s, t, scratch);
}
PathResult GeodesicQuery::path(const SurfacePoint& s, const SurfacePoint& t,
                               QueryScratch& scratch) const {
  return engine_->path(s, t, scratch);
}
DistanceField GeodesicQuery::field(std::span<const SurfacePoint> sources, QueryScratch& scratch,
                                   const DistanceFieldOptions& options) const {
  return engine_->field(sources, scratch, options);
}
std::vector<double> GeodesicQuery::matrix(std::span<const SurfacePoint> sources,
                                          std::span<const SurfacePoint> targets,
                                          QueryScratch& scratch) const {
  return engine_->matrix(sources, targets, scratch);
}
SurfacePoint GeodesicQuery::sample_point(std::uint32_t sample) const {
  return engine_->sample_point(sample);
}
SnapResult GeodesicQuery::snap(const Vec3& position) const { return engine_->snap(position); }
const TriangleMesh& GeodesicQuery::mesh() const { return engine_->mesh(); }
const IntrinsicGeometry& GeodesicQuery::geometry() const { return engine_->geometry(); }
const ProximityGraphView& GeodesicQuery::graph() const { return engine_->graph(); }
double GeodesicQuery::link_radius() const { return engine_->link_radius(); }

}  // namespace geoprox
