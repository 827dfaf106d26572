#include "core/graph/loaded_graph.h"

#include "core/mesh/mesh_io.h"
#include "core/mesh/riemannian_metric.h"

namespace geoprox {

LoadedGraph::LoadedGraph(const std::string& mesh_path, const std::string& graph_path,
                         const std::string& metric_path, const GeodesicQueryOptions& options)
    : mesh(load_mesh(mesh_path)),
      geometry(load_geometry(mesh, metric_path)),
      file(MappedGraphFile::open(graph_path)) {
  file.verify_mesh(mesh, geometry);
  query = std::make_unique<GeodesicQuery>(mesh, geometry, file.view(), options);
}

}  // namespace geoprox
