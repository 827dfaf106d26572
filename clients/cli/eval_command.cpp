// `geoprox eval MESH GRAPH`: the accuracy of graph queries against the exact solver (and fast
// marching), and their timings. Random points uniform by area, reproducible by seed; the exact
// references run on all cores, the timed graph queries on one thread.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "clients/cli/cli.h"
#include "clients/cli/stats.h"
#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/geodesic/fast_marching.h"
#include "core/graph/graph_file.h"
#include "core/graph/loaded_graph.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/query/geodesic_query.h"

namespace geoprox::cli {
namespace {

using Clock = std::chrono::steady_clock;

/// `text` as the inside of a JSON string.
std::string json_escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out;
}

struct EvalArgs {
  std::string metric;  ///< --metric: the side file the graph was built with
  bool repair = false;  ///< --repair: the graph was built for the repaired mesh
  std::string mesh, graph;
  std::size_t pairs = 1000;
  std::size_t fields = 2;  ///< fields of each kind of source (FieldKind)
  std::size_t paths = 200;
  std::uint64_t seed = 1;
  bool json = false;
  bool fmm = true;
  std::size_t worst = 0;  ///< --worst: pairs listed with the largest errors
  double refine_within = GeodesicQueryOptions{}.refine_within;  ///< --refine-within
  double exact_within = GeodesicQueryOptions{}.exact_within;    ///< --exact-within
};

/// splitmix64: the same points for a seed on every platform.
struct Rng {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
};

/// Points uniform by area: a face by its area (binary search in the cumulative table), then
/// uniform barycentrics (the square-root rule).
class AreaSampler {
 public:
  explicit AreaSampler(const IntrinsicGeometry& g) {
    double sum = 0;
    for (std::uint32_t f = 0; f < g.mesh().num_faces(); ++f) {
      sum += g.face_area(f);
      cumulative_.push_back(sum);
    }
  }
  SurfacePoint draw(Rng& rng) const {
    const double x = rng.uniform() * cumulative_.back();
    const auto f = static_cast<std::uint32_t>(
        std::min<std::size_t>(std::upper_bound(cumulative_.begin(), cumulative_.end(), x) -
                                  cumulative_.begin(),
                              cumulative_.size() - 1));
    const double r1 = std::sqrt(rng.uniform()), r2 = rng.uniform();
    const double b0 = 1 - r1, b1 = r1 * (1 - r2);
    return SurfacePoint::face(f, b0, b1, std::max(0.0, 1 - b0 - b1));
  }

 private:
  std::vector<double> cumulative_;
};

/// The kinds of field sources eval draws, each from a point uniform by area: that point's face
/// point, its face's nearest corner, the nearest point of its face's sides, and three points.
enum class FieldKind : std::size_t { Vertex, Edge, Face, ThreeSources };
constexpr std::size_t kFieldKinds = 4;
constexpr const char* kFieldKindNames[kFieldKinds] = {"vertex", "edge", "face", "multi"};

std::vector<SurfacePoint> field_sources_of_kind(FieldKind kind, const TriangleMesh& mesh,
                                                const AreaSampler& sampler, Rng& rng) {
  const SurfacePoint p = sampler.draw(rng);
  const Triangle& corners = mesh.face(p.id);
  const auto& b = p.bary;
  switch (kind) {
    case FieldKind::Vertex:
      return {SurfacePoint::vertex(corners[static_cast<std::size_t>(
          std::max_element(b.begin(), b.end()) - b.begin())])};
    case FieldKind::Edge: {
      // The side opposite the smallest barycentric, at the other two's proportion.
      const auto k = static_cast<std::size_t>(std::min_element(b.begin(), b.end()) - b.begin());
      const std::uint32_t from = corners[(k + 1) % 3], to = corners[(k + 2) % 3];
      const double t = b[(k + 2) % 3] / (b[(k + 1) % 3] + b[(k + 2) % 3]);
      for (std::uint32_t h : mesh.outgoing_halfedges(from)) {
        if (mesh.target(h) != to) continue;
        const std::uint32_t e = mesh.edge_of(h);
        return {SurfacePoint::edge(e, mesh.edge_halfedge(e) == h ? t : 1 - t)};
      }
      return {p};  // unreachable for a face's own side
    }
    case FieldKind::Face:
      return {p};
    case FieldKind::ThreeSources:
      return {p, sampler.draw(rng), sampler.draw(rng)};
  }
  return {p};
}

struct ErrorStats {
  std::size_t count = 0;
  double mean = 0, p50 = 0, p99 = 0, max = 0;
  std::size_t below_exact = 0;  ///< answers below the exact distance by more than 1e-9 relative
  std::size_t worst = SIZE_MAX;  ///< index of the answer with the largest error (SIZE_MAX: none)
};

ErrorStats error_stats(const std::vector<double>& approx, const std::vector<double>& exact) {
  std::vector<double> rel;
  ErrorStats s;
  for (std::size_t k = 0; k < approx.size(); ++k) {
    if (!(exact[k] > 0) || !std::isfinite(exact[k]) || !std::isfinite(approx[k])) continue;
    const double e = (approx[k] - exact[k]) / exact[k];
    if (e < -1e-9) ++s.below_exact;
    if (rel.empty() || std::abs(e) > s.max) {
      s.max = std::abs(e);
      s.worst = k;
    }
    rel.push_back(std::abs(e));
  }
  s.count = rel.size();
  s.mean = mean(rel);
  s.p50 = quantile(rel, 0.5);
  s.p99 = quantile(rel, 0.99);
  return s;
}

/// Fast marching's value at a surface point: the barycentric blend of its face's corners.
double fmm_at(const FastMarchingSolver& fmm, const TriangleMesh& mesh, const SurfacePoint& p) {
  const auto [face, bary] = p.in_face(mesh);
  double d = 0;
  for (int i = 0; i < 3; ++i) d += bary[i] * fmm.distance(mesh.face(face)[i]);
  return d;
}

// ---- the run, in steps: points, exact references, timed graph queries, figures, report ----

/// The random points: pairs share sources (up to 100 targets each) so that one full exact
/// solve serves many pairs; field k has kind k % kFieldKinds.
struct EvalPoints {
  std::size_t per_source = 0;
  std::vector<SurfacePoint> sources;
  std::vector<std::vector<SurfacePoint>> targets;
  std::vector<std::vector<SurfacePoint>> field_sources;
};

EvalPoints draw_points(const EvalArgs& args, const TriangleMesh& mesh,
                       const AreaSampler& sampler, Rng& rng) {
  EvalPoints points;
  points.per_source = std::min<std::size_t>(100, args.pairs);
  const std::size_t num_sources = (args.pairs + points.per_source - 1) / points.per_source;
  points.sources.resize(num_sources);
  points.targets.resize(num_sources);
  for (std::size_t k = 0; k < num_sources; ++k) {
    points.sources[k] = sampler.draw(rng);
    const std::size_t n = std::min(points.per_source, args.pairs - k * points.per_source);
    for (std::size_t j = 0; j < n; ++j) points.targets[k].push_back(sampler.draw(rng));
  }
  const std::size_t num_fields = args.fields * kFieldKinds;
  points.field_sources.resize(num_fields);
  for (std::size_t k = 0; k < num_fields; ++k) {
    const auto kind = static_cast<FieldKind>(k % kFieldKinds);
    points.field_sources[k] = field_sources_of_kind(kind, mesh, sampler, rng);
  }
  return points;
}

/// Exact and fast-marching distances: per source, at its targets; per field, at every vertex.
struct References {
  std::vector<std::vector<double>> exact, fmm;
  std::vector<std::vector<double>> field_exact, field_fmm;
};

/// Runs the exact solver (and fast marching) in parallel over sources and fields, untimed.
References solve_references(const EvalArgs& args, const LoadedGraph& g,
                            const EvalPoints& points) {
  const std::size_t num_sources = points.sources.size();
  const std::size_t num_fields = points.field_sources.size();
  References refs;
  refs.exact.resize(num_sources);
  refs.fmm.resize(num_sources);
  refs.field_exact.resize(num_fields);
  refs.field_fmm.resize(num_fields);
  std::fprintf(stderr, "geoprox: eval: exact references for %zu sources and %zu fields...\n",
               num_sources, num_fields);
  const auto total = static_cast<std::int64_t>(num_sources + num_fields);
#pragma omp parallel
  {
    ExactGeodesicSolver solver(g.mesh, g.geometry);
    FastMarchingSolver marching(g.mesh, g.geometry);
#pragma omp for schedule(dynamic, 1)
    for (std::int64_t k = 0; k < total; ++k) {
      const auto u = static_cast<std::size_t>(k);
      if (u >= num_sources) {
        const std::size_t f = u - num_sources;
        std::vector<GeodesicSource> from;
        for (const SurfacePoint& p : points.field_sources[f]) from.push_back({p, 0});
        solver.solve(from);
        if (args.fmm) marching.solve(from);
        refs.field_exact[f] = solver.vertex_distances();
        if (args.fmm) refs.field_fmm[f] = marching.vertex_distances();
        continue;
      }
      solver.solve(points.sources[u]);
      if (args.fmm) marching.solve(points.sources[u]);
      for (const SurfacePoint& t : points.targets[u]) {
        double d = kInfinity;
        try {
          d = solver.distance(t);
        } catch (const Unreachable&) {
        }
        refs.exact[u].push_back(d);
        refs.fmm[u].push_back(args.fmm ? fmm_at(marching, g.mesh, t) : kInfinity);
      }
    }
  }
  return refs;
}

/// What the timed graph queries answered, flattened in pair (and field vertex) order.
struct Measurements {
  std::vector<double> approx, reference, fmm_values, p2p_ms;
  std::size_t exact_answers = 0, unreachable = 0;
  double samples_settled = 0;
  std::vector<double> path_ms;
  std::size_t path_exact_segments = 0;
  double worst_path_length_error = 0;
  std::vector<double> field_approx, field_reference, field_fmm_values, field_ms;
  std::array<std::vector<double>, kFieldKinds> kind_approx, kind_reference;
};

void time_pairs(const GeodesicQuery& query, QueryScratch& scratch, const EvalPoints& points,
                const References& refs, Measurements& m) {
  for (std::size_t k = 0; k < points.sources.size(); ++k) {
    for (std::size_t j = 0; j < points.targets[k].size(); ++j) {
      const auto start = Clock::now();
      double d = kInfinity;
      try {
        const DistanceResult r = query.distance(points.sources[k], points.targets[k][j], scratch);
        d = r.distance;
        m.exact_answers += r.exact ? 1 : 0;
        m.samples_settled += r.samples_settled;
      } catch (const Unreachable&) {
        ++m.unreachable;
      }
      m.p2p_ms.push_back(ms_since(start));
      m.approx.push_back(d);
      m.reference.push_back(refs.exact[k][j]);
      m.fmm_values.push_back(refs.fmm[k][j]);
    }
  }
}

/// Paths of the first `max_paths` pairs: timings, and how far their polyline length is from
/// the distance they report.
void time_paths(const GeodesicQuery& query, QueryScratch& scratch, const EvalPoints& points,
                std::size_t max_paths, Measurements& m) {
  std::size_t paths_done = 0;
  for (std::size_t k = 0; k < points.sources.size() && paths_done < max_paths; ++k) {
    for (std::size_t j = 0; j < points.targets[k].size() && paths_done < max_paths; ++j) {
      const auto start = Clock::now();
      try {
        const PathResult p = query.path(points.sources[k], points.targets[k][j], scratch);
        m.path_ms.push_back(ms_since(start));
        double length = 0;
        for (std::size_t i = 1; i < p.points.size(); ++i) {
          length += norm(p.points[i].position - p.points[i - 1].position);
        }
        if (p.distance > 0) {
          m.worst_path_length_error =
              std::max(m.worst_path_length_error, std::abs(length - p.distance) / p.distance);
        }
        m.path_exact_segments += p.exact_segments;
      } catch (const Unreachable&) {
      }
      ++paths_done;
    }
  }
}

void time_fields(const EvalArgs& args, const GeodesicQuery& query, QueryScratch& scratch,
                 const EvalPoints& points, const References& refs, Measurements& m) {
  for (std::size_t k = 0; k < points.field_sources.size(); ++k) {
    const auto start = Clock::now();
    const DistanceField f = query.field(points.field_sources[k], scratch);
    m.field_ms.push_back(ms_since(start));
    for (std::size_t v = 0; v < f.distances.size(); ++v) {
      m.field_approx.push_back(f.distances[v]);
      m.field_reference.push_back(refs.field_exact[k][v]);
      m.field_fmm_values.push_back(args.fmm ? refs.field_fmm[k][v] : kInfinity);
      m.kind_approx[k % kFieldKinds].push_back(f.distances[v]);
      m.kind_reference[k % kFieldKinds].push_back(refs.field_exact[k][v]);
    }
  }
}

/// The figures of the report.
struct EvalFigures {
  ErrorStats pair_err, pair_fmm, field_err, field_fmm_err;
  std::array<ErrorStats, kFieldKinds> kind_err;
  std::string worst_pair = "none";  ///< "SOURCE TARGET" of the largest pair error
  std::size_t worst = 0;            ///< its index (0 when there is none)
  std::string worst_field = "none";  ///< "v:ID from SOURCES" of the largest field error
  double worst_field_exact = 0, worst_field_graph = 0;
  double bound = 0;  ///< the graph's error bound (infinite when there is none)
  std::size_t beyond_bound = 0;
  std::vector<std::size_t> worst_pairs;  ///< --worst: pair indices, largest error first
};

/// "SOURCE TARGET" of pair `k`.
std::string pair_text(const EvalPoints& points, std::size_t k) {
  return points.sources[k / points.per_source].to_string() + " " +
         points.targets[k / points.per_source][k % points.per_source].to_string();
}

/// The indices of the `count` pairs with the largest relative errors, largest first.
std::vector<std::size_t> worst_pairs(const Measurements& m, std::size_t count) {
  std::vector<std::pair<double, std::size_t>> errors;
  for (std::size_t k = 0; k < m.approx.size(); ++k) {
    if (m.reference[k] > 0 && std::isfinite(m.reference[k]) && std::isfinite(m.approx[k])) {
      errors.emplace_back(std::abs(m.approx[k] - m.reference[k]) / m.reference[k], k);
    }
  }
  count = std::min(count, errors.size());
  std::partial_sort(errors.begin(), errors.begin() + static_cast<std::ptrdiff_t>(count),
                    errors.end(), std::greater<>());
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < count; ++k) out.push_back(errors[k].second);
  return out;
}

EvalFigures figures_of(const Measurements& m, const EvalPoints& points, const TriangleMesh& mesh,
                       const ProximityGraphView& view, std::size_t list_worst) {
  EvalFigures out;
  out.worst_pairs = worst_pairs(m, list_worst);
  for (std::size_t k = 0; k < kFieldKinds; ++k) {
    out.kind_err[k] = error_stats(m.kind_approx[k], m.kind_reference[k]);
  }
  // The vertex behind the worst field error, and its field's sources.
  out.field_err = error_stats(m.field_approx, m.field_reference);
  if (out.field_err.worst != SIZE_MAX) {
    const std::size_t nv = mesh.num_vertices();
    out.worst_field = "v:" + std::to_string(out.field_err.worst % nv) + " from";
    for (const SurfacePoint& p : points.field_sources[out.field_err.worst / nv]) {
      out.worst_field += ' ';
      out.worst_field += p.to_string();
    }
    out.worst_field_exact = m.field_reference[out.field_err.worst];
    out.worst_field_graph = m.field_approx[out.field_err.worst];
  }
  out.pair_err = error_stats(m.approx, m.reference);
  out.pair_fmm = error_stats(m.fmm_values, m.reference);
  // The pair behind the worst error, so that it can be looked at (`geoprox distance`, `path`).
  out.worst = out.pair_err.worst == SIZE_MAX ? 0 : out.pair_err.worst;
  if (out.pair_err.worst != SIZE_MAX) {
    out.worst_pair = pair_text(points, out.worst);
  }
  out.field_fmm_err = error_stats(m.field_fmm_values, m.field_reference);
  // Theorem 4.2 bounds every pair's relative error when it is finite.
  out.bound = view.error_bound();
  if (std::isfinite(out.bound)) {
    for (std::size_t k = 0; k < m.approx.size(); ++k) {
      out.beyond_bound +=
          std::isfinite(m.reference[k]) && m.approx[k] > m.reference[k] * (1 + out.bound);
    }
  }
  return out;
}

/// printf into a growing string.
class Report {
 public:
  template <class... Values>
  void add(const char* format, Values... values) {
    std::snprintf(buf_, sizeof buf_, format, values...);
    text_ += buf_;
  }
  std::string& text() { return text_; }

 private:
  std::string text_;
  char buf_[512];
};

void add_text_report(Report& r, const EvalArgs& args, const LoadedGraph& g,
                     const EvalPoints& points, const Measurements& m, const EvalFigures& f) {
  const ProximityGraphView view = g.file.view();
  const double link_radius = g.query->link_radius();
  r.add("mesh            %s (%zu faces, %zu vertices)\n", args.mesh.c_str(), g.mesh.num_faces(),
        g.mesh.num_vertices());
  r.add("graph           %u samples, m_P %u, link radius %.6g, near pairs solved exactly within "
        "%g and refined within %g link radii\n",
        view.num_samples, view.neighbors, link_radius, args.exact_within, args.refine_within);
  r.add("pairs           %zu (%zu answered exactly, %zu unreachable), seed %llu\n",
        m.approx.size(), m.exact_answers, m.unreachable,
        static_cast<unsigned long long>(args.seed));
  r.add("distance error  mean %.4f%%  p50 %.4f%%  p99 %.4f%%  max %.4f%%  (below exact: %zu)\n",
        100 * f.pair_err.mean, 100 * f.pair_err.p50, 100 * f.pair_err.p99, 100 * f.pair_err.max,
        f.pair_err.below_exact);
  if (std::isfinite(f.bound)) {
    r.add("error bound     %.4g (Theorem 4.2: 2r / (rho - 2r)); pairs beyond it: %zu\n", f.bound,
          f.beyond_bound);
  } else {
    r.add("error bound     none (Theorem 4.2 needs rho > 2r; r %.6g, rho %.6g)\n",
          view.covering_radius, view.link_radius);
  }
  if (f.pair_err.worst != SIZE_MAX) {
    r.add("worst pair      %s  (exact %.9g, graph %.9g, %.2f link radii apart)\n",
          f.worst_pair.c_str(), m.reference[f.worst], m.approx[f.worst],
          m.reference[f.worst] / link_radius);
  }
  for (const std::size_t k : f.worst_pairs) {
    r.add("  error %7.4f%%  exact %.9g  graph %.9g  %.2f link radii  %s\n",
          100 * (m.approx[k] - m.reference[k]) / m.reference[k], m.reference[k], m.approx[k],
          m.reference[k] / link_radius, pair_text(points, k).c_str());
  }
  if (args.fmm) {
    r.add("fast marching   mean %.4f%%  p50 %.4f%%  p99 %.4f%%  max %.4f%%\n",
          100 * f.pair_fmm.mean, 100 * f.pair_fmm.p50, 100 * f.pair_fmm.p99,
          100 * f.pair_fmm.max);
  }
  r.add("field error     %zu fields, mean %.4f%%  p99 %.4f%%  max %.4f%%  (below exact: %zu)\n",
        m.field_ms.size(), 100 * f.field_err.mean, 100 * f.field_err.p99,
        100 * f.field_err.max, f.field_err.below_exact);
  for (std::size_t k = 0; k < kFieldKinds; ++k) {
    r.add("  %-6s sources mean %.4f%%  p99 %.4f%%  max %.4f%%  (below exact: %zu)\n",
          kFieldKindNames[k], 100 * f.kind_err[k].mean, 100 * f.kind_err[k].p99,
          100 * f.kind_err[k].max, f.kind_err[k].below_exact);
  }
  if (f.field_err.worst != SIZE_MAX) {
    r.add("worst field     %s  (exact %.9g, graph %.9g, %.2f link radii)\n",
          f.worst_field.c_str(), f.worst_field_exact, f.worst_field_graph,
          f.worst_field_exact / link_radius);
  }
  if (args.fmm) {
    r.add("field fmm       mean %.4f%%  p99 %.4f%%  max %.4f%%\n", 100 * f.field_fmm_err.mean,
          100 * f.field_fmm_err.p99, 100 * f.field_fmm_err.max);
  }
  r.add("p2p time        median %.3f ms  p99 %.3f ms  (graph search: %.0f samples settled on "
        "average)\n",
        quantile(m.p2p_ms, 0.5), quantile(m.p2p_ms, 0.99),
        m.samples_settled / static_cast<double>(std::max<std::size_t>(1, m.approx.size())));
  r.add("path time       median %.3f ms  p99 %.3f ms  (%zu paths, %zu exact segments, length "
        "error max %.2e)\n",
        quantile(m.path_ms, 0.5), quantile(m.path_ms, 0.99), m.path_ms.size(),
        m.path_exact_segments, m.worst_path_length_error);
  r.add("field time      median %.3f ms\n", quantile(m.field_ms, 0.5));
}

/// The same figures as one JSON line (--json).
void add_json_report(Report& r, const EvalArgs& args, const LoadedGraph& g,
                     const Measurements& m, const EvalFigures& f) {
  const ProximityGraphView view = g.file.view();
  r.add("{\"mesh\":\"%s\",\"faces\":%zu,\"vertices\":%zu,\"samples\":%u,\"neighbors\":%u,",
        json_escape(args.mesh).c_str(), g.mesh.num_faces(), g.mesh.num_vertices(),
        view.num_samples, view.neighbors);
  r.add("\"link_radius\":%.17g,\"exact_within\":%.17g,\"refine_within\":%.17g,\"pairs\":%zu,"
        "\"exact_answers\":%zu,\"unreachable\":%zu,",
        g.query->link_radius(), args.exact_within, args.refine_within, m.approx.size(),
        m.exact_answers, m.unreachable);
  r.add("\"seed\":%llu,\"error\":{\"mean\":%.6g,\"p50\":%.6g,\"p99\":%.6g,\"max\":%.6g,"
        "\"below_exact\":%zu},",
        static_cast<unsigned long long>(args.seed), f.pair_err.mean, f.pair_err.p50,
        f.pair_err.p99, f.pair_err.max, f.pair_err.below_exact);
  r.add("\"worst_pair\":\"%s\",", json_escape(f.worst_pair).c_str());
  if (std::isfinite(f.bound)) {
    r.add("\"error_bound\":%.6g,\"beyond_bound\":%zu,", f.bound, f.beyond_bound);
  } else {
    r.add("%s", "\"error_bound\":null,\"beyond_bound\":0,");
  }
  r.add("\"fmm_error\":{\"mean\":%.6g,\"p50\":%.6g,\"p99\":%.6g,\"max\":%.6g},", f.pair_fmm.mean,
        f.pair_fmm.p50, f.pair_fmm.p99, f.pair_fmm.max);
  r.add("\"fields\":%zu,\"field_error\":{\"mean\":%.6g,\"p99\":%.6g,\"max\":%.6g,"
        "\"below_exact\":%zu},",
        m.field_ms.size(), f.field_err.mean, f.field_err.p99, f.field_err.max,
        f.field_err.below_exact);
  r.add("%s", "\"field_error_by_source\":{");
  for (std::size_t k = 0; k < kFieldKinds; ++k) {
    r.add("\"%s\":{\"mean\":%.6g,\"p99\":%.6g,\"max\":%.6g,\"below_exact\":%zu}%s",
          kFieldKindNames[k], f.kind_err[k].mean, f.kind_err[k].p99, f.kind_err[k].max,
          f.kind_err[k].below_exact, k + 1 < kFieldKinds ? "," : "},");
  }
  r.add("\"field_fmm_error\":{\"mean\":%.6g,\"p99\":%.6g,\"max\":%.6g},", f.field_fmm_err.mean,
        f.field_fmm_err.p99, f.field_fmm_err.max);
  r.add("\"p2p_ms\":{\"p50\":%.6g,\"p99\":%.6g},\"path_ms\":{\"p50\":%.6g,\"p99\":%.6g},",
        quantile(m.p2p_ms, 0.5), quantile(m.p2p_ms, 0.99), quantile(m.path_ms, 0.5),
        quantile(m.path_ms, 0.99));
  r.add("\"path_exact_segments\":%zu,\"path_length_error_max\":%.6g,\"field_ms\":%.6g}\n",
        m.path_exact_segments, m.worst_path_length_error, quantile(m.field_ms, 0.5));
}

void run_eval(const EvalArgs& args) {
  if (args.pairs == 0) throw InvalidInput(ErrorCode::BadCount, "--pairs must be positive");
  GeodesicQueryOptions query_options;
  query_options.refine_within = args.refine_within;
  query_options.exact_within = args.exact_within;
  const LoadedGraph g(args.mesh, args.graph, args.metric, query_options, {.repair = args.repair});
  report_repair(args.mesh, g.data->repair);
  const AreaSampler sampler(g.geometry);
  Rng rng{args.seed};
  const EvalPoints points = draw_points(args, g.mesh, sampler, rng);
  const References refs = solve_references(args, g, points);

  // Timed graph queries, one thread.
  QueryScratch scratch = g.query->make_scratch();
  Measurements m;
  time_pairs(*g.query, scratch, points, refs, m);
  time_paths(*g.query, scratch, points, args.paths, m);
  time_fields(args, *g.query, scratch, points, refs, m);

  const EvalFigures figures = figures_of(m, points, g.mesh, g.file.view(), args.worst);
  Report report;
  add_text_report(report, args, g, points, m, figures);
  if (args.json) add_json_report(report, args, g, m, figures);
  write_output(report.text(), "");
}

}  // namespace

void add_eval_command(CLI::App& app, std::vector<Command>& commands) {
  auto eval_args = std::make_shared<EvalArgs>();
  CLI::App* eval = app.add_subcommand(
      "eval", "Accuracy of graph queries against the exact solver, and their timings");
  eval->add_option("MESH", eval_args->mesh, "Triangle mesh file the graph was built from")
      ->required();
  eval->add_option("GRAPH", eval_args->graph, "Graph file from 'geoprox build'")->required();
  add_metric_option(*eval, eval_args->metric);
  add_repair_flag(*eval, eval_args->repair);
  eval->add_option("--pairs", eval_args->pairs, "Random point pairs (uniform by area)")
      ->check(CLI::PositiveNumber);
  eval->add_option("--fields", eval_args->fields,
                   "Distance fields of each kind of source: a vertex, an edge point, a face point "
                   "and three face points (corner, side and face drawn uniformly by area)");
  eval->add_option("--paths", eval_args->paths, "Pairs also queried for their path");
  eval->add_option("--seed", eval_args->seed, "Seed of the random points (same seed, same points)");
  eval->add_flag("--json", eval_args->json, "End with one JSON line holding every figure");
  eval->add_option("--worst", eval_args->worst,
                   "Also list this many pairs with the largest errors: error, exact and graph "
                   "distances, link radii apart, the points");
  eval->add_flag("!--no-fmm", eval_args->fmm, "Skip the fast-marching comparison");
  eval->add_option("--exact-within", eval_args->exact_within,
                   "Solve pairs whose graph answer is under this many link radii exactly, "
                   "bounded by that answer (0: graph answers; docs/queries.md, near pairs)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  eval->add_option("--refine-within", eval_args->refine_within,
                   "Refine pairs whose graph answer is under this many link radii (0 with "
                   "--exact-within 0: the paper's answers; docs/queries.md, near pairs)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  eval->footer(
      "Pairs share sources (100 targets per source) so that one full exact solve serves 100\n"
      "pairs; the exact references run on all cores, the graph queries on one thread.\n"
      "Relative errors are |graph - exact| / exact; 'below exact' counts answers more than\n"
      "1e-9 below the exact distance (there should be none: graph answers are real paths).\n"
      "Fast marching at a face point blends its corners' values barycentrically.\n\n" +
      exit_code_footer());
  commands.push_back({eval, [eval_args] { run_eval(*eval_args); }});
}

}  // namespace geoprox::cli
