// A mesh, its proximity-graph file (checked against the mesh) and a query object over both, as
// the command-line tool, the benchmarks and the daemon (server::LoadedMesh) open them. Plumbing
// over core/mesh/mesh_io.h, core/mesh/riemannian_metric.h, core/graph/graph_file.h and
// core/query/geodesic_query.h.
//
// Thread safety: nothing changes after construction; the query is as thread-safe as
// GeodesicQuery (one QueryScratch per thread).
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "core/graph/graph_file.h"
#include "core/graph/refined_surface.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/mesh_io.h"
#include "core/query/geodesic_query.h"

namespace geoprox {

/// A mesh and its intrinsic geometry, which points into the mesh: never moved once built, so
/// held by shared_ptr (a reloaded graph keeps the mesh it was verified against).
struct MeshData {
  /// The mesh with its own edge lengths.
  explicit MeshData(TriangleMesh m)
      : mesh(std::move(m)), geometry(mesh), polygons(mesh.num_faces()) {}
  /// A loaded file's mesh with its own edge lengths, its polygons and repair report.
  explicit MeshData(LoadedMeshFile file);
  /// Loads the mesh (load_mesh_file: polygons triangulated, repaired if `load_options` say so)
  /// and its geometry: the metric of side file `metric_path`, or the mesh's own lengths when it
  /// is empty. Throws what load_mesh_file and load_geometry throw.
  static std::shared_ptr<MeshData> load(const std::string& mesh_path,
                                        const std::string& metric_path = {},
                                        const MeshLoadOptions& load_options = {});
  MeshData(const MeshData&) = delete;
  MeshData& operator=(const MeshData&) = delete;

  TriangleMesh mesh;
  IntrinsicGeometry geometry;
  /// Per face: the file's polygon (empty: the faces are the file's); see LoadedMeshFile.
  std::vector<std::uint32_t> face_polygon;
  std::size_t polygons = 0;  ///< face records in the file (mesh.num_faces() when built in code)
  std::optional<MeshRepairReport> repair;  ///< when loaded with repair
};

struct LoadedGraph {
  /// Loads the mesh and its geometry (MeshData::load, repaired if `load_options` say so) and
  /// maps the graph file; throws what those throw, and the graph file's error when it was built
  /// for another mesh or metric (a graph built for the repaired mesh matches only the repaired
  /// mesh).
  LoadedGraph(const std::string& mesh_path, const std::string& graph_path,
              const std::string& metric_path = {}, const GeodesicQueryOptions& options = {},
              const MeshLoadOptions& load_options = {});
  /// Over a mesh already loaded and a graph file the caller has checked against it
  /// (MappedGraphFile::verify_mesh).
  LoadedGraph(std::shared_ptr<const MeshData> mesh_data, MappedGraphFile graph_file,
              const GeodesicQueryOptions& options = {});
  // The query points at the mesh, the geometry and the mapping: never copied or moved.
  LoadedGraph(const LoadedGraph&) = delete;
  LoadedGraph& operator=(const LoadedGraph&) = delete;

  std::shared_ptr<const MeshData> data;
  const TriangleMesh& mesh;            ///< data->mesh
  const IntrinsicGeometry& geometry;  ///< data->geometry
  MappedGraphFile file;
  /// The refinement the graph was built on (a version-3 file), or null; the query answers on
  /// `mesh` through it.
  std::unique_ptr<const RefinedSurface> refined;
  std::unique_ptr<GeodesicQuery> query;

 private:
  void make_query(const GeodesicQueryOptions& options);
};

}  // namespace geoprox
