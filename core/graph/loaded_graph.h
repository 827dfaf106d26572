// A mesh, its proximity-graph file (checked against the mesh) and a query object over both, as
// the command-line tool and the benchmarks open them (no paper: plumbing over
// core/mesh/mesh_io.h, core/mesh/riemannian_metric.h, core/graph/graph_file.h and core/query/geodesic_query.h).
#pragma once

#include <memory>
#include <string>

#include "core/query/geodesic_query.h"
#include "core/graph/graph_file.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"

namespace geoprox {

struct LoadedGraph {
  TriangleMesh mesh;
  IntrinsicGeometry geometry;
  MappedGraphFile file;
  std::unique_ptr<GeodesicQuery> query;

  /// Loads the mesh, its geometry (the metric of side file `metric_path`, or the mesh's own
  /// lengths when empty) and maps the graph file; throws what those throw, and the graph file's
  /// error when it was built for another mesh or metric.
  LoadedGraph(const std::string& mesh_path, const std::string& graph_path,
              const std::string& metric_path = {}, const GeodesicQueryOptions& options = {});
  // The query points at the mesh, the geometry and the mapping: never copied or moved.
  LoadedGraph(const LoadedGraph&) = delete;
  LoadedGraph& operator=(const LoadedGraph&) = delete;
};

}  // namespace geoprox
