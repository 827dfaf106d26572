#include "core/graph/refined_surface.h"

#include "core/base/tuning.h"
#include "core/graph/graph_file.h"

namespace geoprox {

RefinedSurface::RefinedSurface(const TriangleMesh& input, RefinedMesh refinement,
                               double max_edge_length)
    : owned_source_face_(std::move(refinement.source_face)),
      owned_source_bary_(std::move(refinement.source_bary)),
      source_face_(owned_source_face_),
      source_bary_(owned_source_bary_),
      max_edge_length_(max_edge_length),
      mesh_(std::move(refinement.positions), std::move(refinement.faces)),
      geometry_(mesh_),
      map_(input, mesh_, source_face_, source_bary_) {}

RefinedSurface::RefinedSurface(const TriangleMesh& input, const MappedGraphFile& file)
    : source_face_(file.source_face()),
      source_bary_(file.source_bary()),
      max_edge_length_(file.refined_from() ? file.refined_from()->max_edge_length : 0),
      mesh_(file.make_mesh()),
      geometry_(file.make_geometry(mesh_)),
      map_(input, mesh_, source_face_, source_bary_) {}

GraphRefinement refine_for_graph(const TriangleMesh& mesh, const ProximityGraphOptions& options,
                                 double max_edge_length) {
  auto link_radius_of = [&](const TriangleMesh& m) {
    return resolve_graph_size(m, IntrinsicGeometry(m), options).link_radius;
  };
  GraphRefinement out;
  if (max_edge_length > 0) {
    out.max_edge_length = max_edge_length;
    out.refined = refine_long_edges(mesh, {.max_edge_length = max_edge_length});
    out.link_radius = link_radius_of(TriangleMesh(out.refined.positions, out.refined.faces));
    return out;
  }
  out.max_edge_length = tuning::kGraphRefinementEdgeOfLinkRadius * link_radius_of(mesh);
  out.refined = refine_long_edges(mesh, {.max_edge_length = out.max_edge_length});
  for (int round = 1;; ++round) {
    out.link_radius = link_radius_of(TriangleMesh(out.refined.positions, out.refined.faces));
    const double wanted = tuning::kGraphRefinementEdgeOfLinkRadius * out.link_radius;
    if (wanted >= out.max_edge_length || round == tuning::kGraphRefinementRounds) return out;
    out.max_edge_length = wanted;
    out.refined = refine_long_edges(mesh, {.max_edge_length = wanted});
  }
}

}  // namespace geoprox
