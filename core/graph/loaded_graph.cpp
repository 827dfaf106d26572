#include "core/graph/loaded_graph.h"

#include "core/mesh/mesh_io.h"
#include "core/mesh/riemannian_metric.h"

namespace geoprox {

MeshData::MeshData(LoadedMeshFile file)
    : mesh(std::move(file.mesh)),
      geometry(mesh),
      face_polygon(std::move(file.face_polygon)),
      polygons(file.polygons),
      repair(file.repair) {}

std::shared_ptr<MeshData> MeshData::load(const std::string& mesh_path,
                                         const std::string& metric_path,
                                         const MeshLoadOptions& load_options) {
  auto data = std::make_shared<MeshData>(load_mesh_file(mesh_path, load_options));
  if (!metric_path.empty()) data->geometry = load_geometry(data->mesh, metric_path);
  return data;
}

namespace {

MappedGraphFile open_verified(const std::string& graph_path, const MeshData& data) {
  MappedGraphFile file = MappedGraphFile::open(graph_path);
  file.verify_mesh(data.mesh, data.geometry);
  return file;
}

}  // namespace

LoadedGraph::LoadedGraph(const std::string& mesh_path, const std::string& graph_path,
                         const std::string& metric_path, const GeodesicQueryOptions& options,
                         const MeshLoadOptions& load_options)
    : data(MeshData::load(mesh_path, metric_path, load_options)),
      mesh(data->mesh),
      geometry(data->geometry),
      file(open_verified(graph_path, *data)) {
  make_query(options);
}

LoadedGraph::LoadedGraph(std::shared_ptr<const MeshData> mesh_data, MappedGraphFile graph_file,
                         const GeodesicQueryOptions& options)
    : data(std::move(mesh_data)),
      mesh(data->mesh),
      geometry(data->geometry),
      file(std::move(graph_file)) {
  make_query(options);
}

void LoadedGraph::make_query(const GeodesicQueryOptions& options) {
  if (file.refined_from()) {
    refined = std::make_unique<const RefinedSurface>(mesh, file);
    query = std::make_unique<GeodesicQuery>(mesh, geometry, file.view(), *refined, options);
  } else {
    query = std::make_unique<GeodesicQuery>(mesh, geometry, file.view(), options);
  }
}

}  // namespace geoprox
