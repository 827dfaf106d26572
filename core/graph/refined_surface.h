// A proximity graph over a refinement of the mesh that queries are given in (no paper: the
// samples of "Lightweight preprocessing and fast query of geodesic distance via proximity graph"
// are vertices, so a face several link radii long holds none, and answers across it can be far
// off; docs/queries.md, "Long faces").
//
// When the first build of a graph leaves points of the surface with no sample within the link
// radius, build_proximity_graph refines the mesh by longest-edge bisection
// (core/mesh/mesh_refinement.h) and builds on the refinement instead. The user's mesh stays the
// query interface: GeodesicQuery takes and returns its points (mapped through RefinementMap),
// fields are reported per vertex of it, and the graph file stores the refined mesh with the map
// (core/graph/graph_file.h, version 3), so that nothing else needs to be kept.
//
// Thread safety: nothing changes after construction.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/graph/proximity_graph.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/mesh_refinement.h"
#include "core/mesh/refinement_map.h"

namespace geoprox {

class MappedGraphFile;

/// The refined mesh a graph was built on, its lengths, and the map to the input mesh. Neither
/// copied nor moved (the geometry and the map point into it): held by shared_ptr.
class RefinedSurface {
 public:
  /// A refinement of `input` just made (the arrays are moved in).
  RefinedSurface(const TriangleMesh& input, RefinedMesh refinement, double max_edge_length);
  /// The refinement a version-3 graph file stores for `input` (which the caller verified with
  /// MappedGraphFile::verify_mesh); the map's arrays stay in the mapping, so `file` must
  /// outlive this.
  RefinedSurface(const TriangleMesh& input, const MappedGraphFile& file);
  RefinedSurface(const RefinedSurface&) = delete;
  RefinedSurface& operator=(const RefinedSurface&) = delete;

  const TriangleMesh& input() const { return map_.input(); }
  const TriangleMesh& mesh() const { return mesh_; }
  const IntrinsicGeometry& geometry() const { return geometry_; }
  const RefinementMap& map() const { return map_; }
  std::span<const std::uint32_t> source_face() const { return source_face_; }
  std::span<const RefinementMap::CornerBarys> source_bary() const { return source_bary_; }
  /// No edge of the refined mesh is longer than this (mesh units).
  double max_edge_length() const { return max_edge_length_; }

 private:
  std::vector<std::uint32_t> owned_source_face_;
  std::vector<RefinementMap::CornerBarys> owned_source_bary_;
  std::span<const std::uint32_t> source_face_;
  std::span<const RefinementMap::CornerBarys> source_bary_;
  double max_edge_length_;
  TriangleMesh mesh_;
  IntrinsicGeometry geometry_;
  RefinementMap map_;
};

/// The refinement build_proximity_graph makes for `mesh`: every edge at most half the link
/// radius of the graph `options` ask for on the result. More faces ask for more samples
/// (Table 1), so shorter edges: the input is refined again with the result's figure until the
/// result asks for no shorter ones (at most tuning::kGraphRefinementRounds times).
/// `max_edge_length` > 0 fixes the limit instead. Throws InvalidInput as refine_long_edges.
struct GraphRefinement {
  RefinedMesh refined;
  double max_edge_length = 0;  ///< the limit used (mesh units)
  double link_radius = 0;      ///< of a graph of `options` on the result
};
GraphRefinement refine_for_graph(const TriangleMesh& mesh, const ProximityGraphOptions& options,
                                 double max_edge_length = 0);

}  // namespace geoprox
