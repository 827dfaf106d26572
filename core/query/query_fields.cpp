// Distance fields (paper section 3.2) and distance matrices.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "core/base/errors.h"
#include "core/query/query_engine.h"
#include <omp.h>

namespace geoprox::detail {

// ---------------------------------------------------------------------------------------------
// Distance field (§3.2): one multi-source search over the graph from the sources' links, then
// each vertex takes the best of its covering samples; vertices inside a source's own exact
// region keep their exact distance.


// The exact values a field takes from `solver`: every vertex it settled within `exact_within`
// (and max_distance).
void QueryEngine::add_field_region(const ExactGeodesicSolver& solver, double exact_within,
                                   double max_distance, Links& out) const {
  for (std::uint32_t v : solver.touched_vertices()) {
    const double d = solver.distance(v);
    if (d <= max_distance && d <= exact_within) out.region.emplace_back(v, d);
  }
}

// One exact solve from all sources at once out to `radius`: every vertex inside is exact (its
// nearest source's), and every sample inside links its nearest source to the graph at its exact
// distance, so that the graph starts from the whole disks and vertices just beyond them are not
// answered through a path of few hops, where the paper's answers err most. The usual links of
// a point are all inside (a cover row or a link solve's covers reach rho), except for a point
// with no sample within rho, which is linked as point-to-point queries link it.
void QueryEngine::link_field_disks(std::span<const SurfacePoint> sources, double radius,
                                   double max_distance, QueryScratch::Impl& w) const {
  w.field_sources.clear();
  for (const SurfacePoint& p : sources) w.field_sources.push_back({p, 0.0});
  ExactGeodesicOptions bounded;
  bounded.max_distance = radius;
  bounded.interrupt = w.interrupt;
  w.solver_s.solve(w.field_sources, {}, bounded);
  w.field_linked.assign(sources.size(), 0);
  for (std::size_t k = 0; k < sources.size(); ++k) {
    Links& l = w.many[k];
    l.samples.clear();
    l.via.clear();
    l.region.clear();
    l.longest = 0;
  }
  for (std::uint32_t v : w.solver_s.touched_vertices()) {
    const double d = w.solver_s.distance(v);
    if (!(d <= radius)) continue;
    const auto k = static_cast<std::size_t>(w.solver_s.nearest_source(v));
    Links& l = w.many[k];
    if (d <= max_distance) l.region.emplace_back(v, d);
    if (sample_of_vertex_[v] < 0) continue;
    l.samples.emplace_back(static_cast<std::uint32_t>(sample_of_vertex_[v]), d);
    l.via.emplace_back(kDirect, 0.0);
    l.longest = std::max(l.longest, d);
    if (d <= link_radius_) w.field_linked[k] = 1;
  }
  for (std::size_t k = 0; k < sources.size(); ++k) {
    if (w.field_linked[k]) continue;
    Links& extra = w.links_s;
    solve_within_link_radius(sources[k], w.solver_s, w.interrupt);
    const double exact_within = link_solved(sources[k], w.solver_s, w, extra);
    Links& l = w.many[k];
    l.samples.insert(l.samples.end(), extra.samples.begin(), extra.samples.end());
    l.via.insert(l.via.end(), extra.via.begin(), extra.via.end());
    // With no sample within rho, the solver holds the solve out to the nearest one: exact.
    if (exact_within == kInfinity) add_field_region(w.solver_s, exact_within, max_distance, l);
  }
}

DistanceField QueryEngine::field(std::span<const SurfacePoint> sources, QueryScratch& scratch,
                                 const DistanceFieldOptions& options) const {
  if (sources.empty()) throw InvalidInput(ErrorCode::NoSources, "a distance field needs a source");
  if (graph_.cover_sample.empty()) {
    throw InvalidInput(ErrorCode::NoCoverTable,
                       "this graph has no per-vertex cover table (imported from the paper's text "
                       "format?): distance fields need a graph built by geoprox");
  }
  if (std::isnan(options.max_distance) || options.max_distance < 0) {
    throw InvalidInput(ErrorCode::BadRadius, "max_distance must be a non-negative number");
  }
  for (const SurfacePoint& p : sources) p.validate(*mesh_);
  QueryScratch::Impl& w = *scratch.impl_;
  if (w.many.size() < sources.size()) w.many.resize(sources.size());
  std::vector<const Links*> links(sources.size());
  const double exact_radius = field_exact_radius();
  if (exact_radius > link_radius_) {
    link_field_disks(sources, exact_radius, options.max_distance, w);
  } else {
    for (std::size_t k = 0; k < sources.size(); ++k) {
      // The paper's field: links as for point-to-point queries, from the solve out to rho that
      // the exact region needs anyway.
      Links& l = w.many[k];
      solve_within_link_radius(sources[k], w.solver_s, w.interrupt);
      add_field_region(w.solver_s, link_solved(sources[k], w.solver_s, w, l),
                       options.max_distance, l);
    }
  }
  for (std::size_t k = 0; k < sources.size(); ++k) links[k] = &w.many[k];
  graph_distances_from(w, links, options.max_distance);

  const auto nv = static_cast<std::int64_t>(mesh_->num_vertices());
  DistanceField out;
  out.distances.assign(static_cast<std::size_t>(nv), kInfinity);
  out.nearest_source.assign(static_cast<std::size_t>(nv), -1);
  // Every sample's label in one dense array (the cover rows read it once per entry, the stamps
  // only once per sample).
  w.dense_label.resize(graph_.num_samples);
  for (std::uint32_t i = 0; i < graph_.num_samples; ++i) w.dense_label[i] = w.get(0, i);
  const double* label = w.dense_label.data();
  const std::uint32_t* cover_sample = graph_.cover_sample.data();
  const float* cover_distance = graph_.cover_distance.data();
  const QueryScratch::Impl& labels = w;
  const int threads = options.threads > 0 ? options.threads : omp_get_max_threads();
#pragma omp parallel for num_threads(threads) schedule(static, 4096) if (threads > 1)
  for (std::int64_t v = 0; v < nv; ++v) {
    double best = kInfinity;
    std::uint32_t best_entry = 0;
    const std::uint32_t end = graph_.cover_offsets[static_cast<std::size_t>(v) + 1];
    for (std::uint32_t c = graph_.cover_offsets[static_cast<std::size_t>(v)]; c < end; ++c) {
      const double d = label[cover_sample[c]] + static_cast<double>(cover_distance[c]);
      best_entry = d < best ? c : best_entry;
      best = d < best ? d : best;
    }
    if (best <= options.max_distance && best < kInfinity) {
      out.distances[static_cast<std::size_t>(v)] = best;
      out.nearest_source[static_cast<std::size_t>(v)] =
          static_cast<std::int32_t>(labels.origin[cover_sample[best_entry]]);
    }
  }
  for (std::size_t k = 0; k < sources.size(); ++k) {
    for (const auto& [v, d] : w.many[k].region) {
      if (d < out.distances[v]) {
        out.distances[v] = d;
        out.nearest_source[v] = static_cast<std::int32_t>(k);
      }
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Matrix: every point is linked once; one graph search per source serves all targets.

std::vector<double> QueryEngine::matrix(std::span<const SurfacePoint> sources,
                                        std::span<const SurfacePoint> targets,
                                        QueryScratch& scratch) const {
  for (const SurfacePoint& p : sources) p.validate(*mesh_);
  for (const SurfacePoint& p : targets) p.validate(*mesh_);
  QueryScratch::Impl& w = *scratch.impl_;
  const std::size_t S = sources.size(), T = targets.size();
  std::vector<double> out(S * T, kInfinity);
  if (S == 0 || T == 0) return out;
  if (w.many.size() < S + T) w.many.resize(S + T);
  // Pairs that distance() answers from the exact solves of link_pair (then not refined).
  std::vector<char> exact(S * T, 0);
  auto take_exact = [&](std::size_t k, double d) {
    if (d < kInfinity) exact[k] = 1;
    out[k] = std::min(out[k], d);
  };
  // Links as for point-to-point queries. Sources are always solved out to the link radius, so
  // that every pair closer than it gets its exact distance, as distance() does.
  for (std::size_t j = 0; j < T; ++j) {
    if (!link_by_covers(targets[j], w.many[S + j])) {
      const double exact_within = link_by_solve(targets[j], w.solver_t, w, w.many[S + j]);
      for (std::size_t i = 0; i < S; ++i) {  // as in distance(): exact when reached
        take_exact(i * T + j, exact_up_to(w.solver_t.distance(sources[i]), exact_within));
      }
    }
  }
  if (w.wide.size() < T) w.wide.resize(T);
  w.has_wide.assign(T, 0);
  std::vector<std::size_t> near;  // targets of source i that distance() refines
  std::size_t solver_t_holds = SIZE_MAX;  // the target whose near disk solver_t holds
  for (std::size_t i = 0; i < S; ++i) {
    Links& l = w.many[i];
    solve_within_link_radius(sources[i], w.solver_s, w.interrupt);
    const double exact_within = link_solved(sources[i], w.solver_s, w, l);
    for (std::size_t j = 0; j < T; ++j) {
      take_exact(i * T + j, exact_up_to(w.solver_s.distance(targets[j]), exact_within));
    }
    const Links* one[] = {&l};
    // The search only needs to run until every target's links are settled; the largest
    // current estimate bounds how far that can be.
    double farthest = 0;
    bool unbounded = false;
    for (std::size_t j = 0; j < T; ++j) {
      if (out[i * T + j] == kInfinity) unbounded = true;
      farthest = std::max(farthest, out[i * T + j]);
    }
    graph_distances_from(w, one, unbounded ? kInfinity : farthest);
    near.clear();
    for (std::size_t j = 0; j < T; ++j) {
      double best = out[i * T + j];
      for (const auto& [sample, d] : w.many[S + j].samples)
        best = std::min(best, w.get(0, sample) + d);
      if (!exact[i * T + j]) {
        // As answer() does. The solve reuses solver_t, which then holds no target's near disk
        // (also should it not reach the target and the pair be refined after all).
        if (solves_exactly(best)) solver_t_holds = SIZE_MAX;
        if (const double d = solve_exactly(sources[i], targets[j], best, w.solver_t, w.interrupt);
            d < kInfinity) {
          best = d;
        } else if (refines(sources[i], targets[j], best)) {
          near.push_back(j);
        }
      }
      out[i * T + j] = best;
    }
    if (near.empty()) continue;
    // Near pairs, as answer_near() does them. Undirected disks (near_disks_directed()) are
    // shared: the source's by its near targets, a target's wide links by every source.
    const bool directed = near_disks_directed();
    if (!directed) {
      solve_near(sources[i], w.solver_s, w.interrupt);
      wide_links(w.solver_s, w, l, w.wide_s);
    }
    w.source_position = sources[i].position(*mesh_);
    for (std::size_t j : near) {
      const double graph_distance = out[i * T + j];
      if (directed) {
        solve_near(sources[i], w.solver_s, w.interrupt, &targets[j], graph_distance);
        wide_links(w.solver_s, w, l, w.wide_s);
        solve_near(targets[j], w.solver_t, w.interrupt, &sources[i], graph_distance);
        wide_links(w.solver_t, w, w.many[S + j], w.wide[j]);
        solver_t_holds = SIZE_MAX;
      } else {
        if (solver_t_holds != j) {  // the join reads the target's solve too
          solve_near(targets[j], w.solver_t, w.interrupt);
          solver_t_holds = j;
        }
        if (!w.has_wide[j]) {
          wide_links(w.solver_t, w, w.many[S + j], w.wide[j]);
          w.has_wide[j] = 1;
        }
      }
      w.target_position = targets[j].position(*mesh_);
      out[i * T + j] = join_or_search(w, w.solver_s, w.wide_s, w.solver_t, w.wide[j]).distance;
    }
  }
  return out;
}

}  // namespace geoprox::detail
