// `geoprox distance`, `geoprox field`, `geoprox path`, `geoprox render` and `geoprox eval`:
// queries on a built graph (issue 4; result files and pictures: issue 6), calling core directly.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "clients/cli/cli.h"
#include "clients/cli/render.h"
#include "clients/cli/result_files.h"
#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/geodesic/fast_marching.h"
#include "core/apps/exponential_map.h"
#include "core/query/geodesic_query.h"
#include "core/graph/graph_file.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/graph/loaded_graph.h"

namespace geoprox::cli {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// The p-quantile (0..1) of `values` by nearest rank; 0 for none.
double quantile(std::vector<double> values, double p) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(values.size())));
  return values[std::min(values.size() - 1, rank == 0 ? 0 : rank - 1)];
}

double mean(const std::vector<double>& values) {
  double sum = 0;
  for (double v : values) sum += v;
  return values.empty() ? 0 : sum / static_cast<double>(values.size());
}

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

/// Point syntax of `geoprox exact` plus `s:I` (sample I of the graph) and `p:X,Y,Z` (a 3D
/// position snapped to the surface).
SurfacePoint resolve_point(const std::string& option, const std::string& text,
                           const GeodesicQuery& query) {
  if (text.rfind("s:", 0) == 0) {
    char* end = nullptr;
    const unsigned long sample = std::strtoul(text.c_str() + 2, &end, 10);
    if (text.size() == 2 || *end != '\0' || sample > UINT32_MAX) {
      throw InvalidInput(ErrorCode::BadPointSyntax, option + ": '" + text + "' is not s:SAMPLE");
    }
    return query.sample_point(static_cast<std::uint32_t>(sample));
  }
  if (text.rfind("p:", 0) == 0) {
    Vec3 p;
    char tail = 0;
    if (std::sscanf(text.c_str() + 2, "%lf,%lf,%lf%c", &p.x, &p.y, &p.z, &tail) != 3) {
      throw InvalidInput(ErrorCode::BadPointSyntax, option + ": '" + text + "' is not p:X,Y,Z");
    }
    return query.snap(p).point;
  }
  const SurfacePoint point = parse_point(option, text);
  validate_point(option, text, point, query.mesh());
  return point;
}

void report_timings(const char* what, const std::vector<double>& ms) {
  std::fprintf(stderr, "geoprox: timing: %zu %s, median %.3f ms, p99 %.3f ms per query\n",
               ms.size(), what, quantile(ms, 0.5), quantile(ms, 0.99));
}

Vec3 position_of(const SurfacePoint& point, const TriangleMesh& mesh) {
  const auto [face, bary] = point.in_face(mesh);
  return mesh.face_point(face, bary);
}

// ---------------------------------------------------------------------------------------------
// geoprox distance MESH --graph FILE --pairs PAIRS

struct DistanceArgs {
  std::string metric;  ///< --metric: the side file the graph was built with
  std::string mesh, graph, pairs;
};

void run_distance(const DistanceArgs& args) {
  LoadedGraph g(args.mesh, args.graph, args.metric);
  std::ifstream file;
  std::istream* in = &std::cin;
  if (args.pairs != "-") {
    file.open(args.pairs);
    if (!file) throw FileError(ErrorCode::FileNotFound, "cannot open pairs file '" + args.pairs + "'");
    in = &file;
  }
  QueryScratch scratch = g.query->make_scratch();
  std::string line, text;
  std::vector<double> ms;
  std::size_t line_number = 0;
  while (std::getline(*in, line)) {
    ++line_number;
    std::istringstream fields(line);
    std::string a, b, extra;
    if (!(fields >> a)) continue;  // blank line
    if (!(fields >> b) || (fields >> extra)) {
      throw InvalidInput(ErrorCode::BadPairsLine, args.pairs + ":" + std::to_string(line_number) +
                                             ": expected 'SOURCE TARGET'");
    }
    const std::string where = args.pairs + ":" + std::to_string(line_number);
    const SurfacePoint s = resolve_point(where, a, *g.query);
    const SurfacePoint t = resolve_point(where, b, *g.query);
    const auto start = Clock::now();
    double d = kInfinity;
    try {
      d = g.query->distance(s, t, scratch).distance;
    } catch (const Unreachable&) {
      // printed as inf
    }
    ms.push_back(ms_since(start));
    append_number(text, d);
    text += '\n';
  }
  write_output(text, "");
  report_timings("distance queries", ms);
}

// ---------------------------------------------------------------------------------------------
// geoprox field MESH --graph FILE --source P [--max-distance D] [--out FIELD.ply]

struct FieldArgs {
  std::string metric;  ///< --metric: the side file the graph was built with
  std::string mesh, graph;
  std::vector<std::string> sources;
  double max_distance = kInfinity;
  int threads = 1;
  std::string out;
};

std::vector<SurfacePoint> resolve_sources(const LoadedGraph& g,
                                          const std::vector<std::string>& texts) {
  std::vector<SurfacePoint> sources;
  for (const std::string& text : texts) {
    sources.push_back(resolve_point("--source", text, *g.query));
  }
  return sources;
}

DistanceField compute_field(const LoadedGraph& g, const std::vector<SurfacePoint>& sources,
                            double max_distance, int threads, double& elapsed_ms) {
  QueryScratch scratch = g.query->make_scratch();
  DistanceFieldOptions options;
  options.max_distance = max_distance;
  options.threads = threads;
  const auto start = Clock::now();
  DistanceField field = g.query->field(sources, scratch, options);
  elapsed_ms = ms_since(start);
  return field;
}

void run_field(const FieldArgs& args) {
  LoadedGraph g(args.mesh, args.graph, args.metric);
  double elapsed = 0;
  const DistanceField field = compute_field(g, resolve_sources(g, args.sources),
                                            args.max_distance, args.threads, elapsed);
  if (!args.out.empty()) {
    write_field_ply(args.out, g.mesh, field.distances,
                    {"geoprox field of " + args.mesh + " from " + join_words(args.sources) +
                     " (graph " + args.graph + ")"});
    print_diagnostic("field", "wrote " + args.out + " (" +
                                  field_file_summary(g.mesh, field.distances) + ")");
    report_timings("fields", {elapsed});
    return;
  }
  std::string text;
  text.reserve(field.distances.size() * 24);
  for (double d : field.distances) {
    append_number(text, d);
    text += '\n';
  }
  write_output(text, "");
  report_timings("fields", {elapsed});
}

// ---------------------------------------------------------------------------------------------
// geoprox path MESH --graph FILE --source P --target Q [--out PATH.obj]

struct PathArgs {
  std::string metric;  ///< --metric: the side file the graph was built with
  std::string mesh, graph, source, target, out;
};

void run_path(const PathArgs& args) {
  LoadedGraph g(args.mesh, args.graph, args.metric);
  const SurfacePoint s = resolve_point("--source", args.source, *g.query);
  const SurfacePoint t = resolve_point("--target", args.target, *g.query);
  QueryScratch scratch = g.query->make_scratch();
  const auto start = Clock::now();
  const PathResult path = g.query->path(s, t, scratch);  // Unreachable: exit 2
  const double elapsed = ms_since(start);
  std::vector<Vec3> points;
  for (const PathPoint& p : path.points) points.push_back(p.position);
  std::string distance;
  append_number(distance, path.distance);
  const std::string summary = "distance " + distance + ", " + std::to_string(points.size()) +
                              " points, exact " + (path.exact ? "yes" : "no");
  if (!args.out.empty()) {
    write_path_obj(args.out, points,
                   {"geoprox path on " + args.mesh + " from " + args.source + " to " +
                        args.target + " (graph " + args.graph + ")",
                    summary + " (mesh units)"});
    print_diagnostic("path", "wrote " + args.out + " (" + summary + ")");
  } else {
    std::string text;
    for (const Vec3& p : points) {
      append_xyz(text, p);
      text += '\n';
    }
    write_output(text, "");
    print_diagnostic("path", summary);
  }
  report_timings("paths", {elapsed});
}

// ---------------------------------------------------------------------------------------------
// geoprox render MESH --graph FILE --source P [--target Q] -o PICTURE.png

struct RenderArgs {
  std::string metric;  ///< --metric: the side file the graph was built with
  std::string mesh, graph;
  std::vector<std::string> sources;
  std::string target;
  std::string out;
  std::string view = "30,20";
  std::string up = "y";
  double max_distance = kInfinity;
  int threads = 1;
  double decal_radius = 0;  ///< > 0: checkerboard through the exponential map of the source
  int decal_squares = 8;    ///< squares across the decal's diameter
  RenderOptions options;
};

/// CLI11 check for --view: "AZIMUTH,ELEVATION" in degrees, elevation within [-90, 90].
std::string check_view(const std::string& text) {
  double azimuth = 0, elevation = 0;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf%c", &azimuth, &elevation, &tail) != 2 ||
      !std::isfinite(azimuth) || !(elevation >= -90 && elevation <= 90)) {
    return "must be AZIMUTH,ELEVATION in degrees (elevation -90..90), not '" + text + "'";
  }
  return {};
}

void run_render(const RenderArgs& args) {
  LoadedGraph g(args.mesh, args.graph, args.metric);
  const std::vector<SurfacePoint> sources = resolve_sources(g, args.sources);
  std::optional<SurfacePoint> target;
  if (!args.target.empty()) target = resolve_point("--target", args.target, *g.query);
  double elapsed = 0;
  const DistanceField field = compute_field(g, sources, args.max_distance, args.threads, elapsed);
  RenderOptions options = args.options;
  std::sscanf(args.view.c_str(), "%lf,%lf", &options.azimuth, &options.elevation);  // checked
  options.up_axis = args.up == "x" ? 0 : args.up == "z" ? 2 : 1;

  RenderScene scene;
  for (const Vec3& p : g.mesh.positions()) scene.positions.push_back({p.x, p.y, p.z});
  for (const Triangle& f : g.mesh.faces()) scene.triangles.push_back(f);
  scene.values = field.distances;
  for (const SurfacePoint& source : sources) {
    const Vec3 p = position_of(source, g.mesh);
    scene.markers.push_back({p.x, p.y, p.z});
  }
  std::string decal_note;
  if (args.decal_radius > 0) {
    // A decal (paper §6.1, Fig. 14): the graph exponential map of the first source gives every
    // vertex within the radius its (u, v); the checkerboard is drawn through them.
    ExponentialMapOptions map_options;
    map_options.radius = args.decal_radius;
    const ExponentialMapResult map = exponential_map(*g.query, sources.front(), map_options);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    scene.decal.assign(g.mesh.num_vertices(), {nan, nan});
    for (const ExponentialMapVertex& m : map.vertices) scene.decal[m.vertex] = {m.u, m.v};
    scene.decal_square = 2 * args.decal_radius / args.decal_squares;
    decal_note = ", decal of " + std::to_string(map.vertices.size()) + " vertices";
  }
  std::string path_note;
  if (target) {
    QueryScratch scratch = g.query->make_scratch();
    // Unreachable (exit 2) when the target is in another component.
    const PathResult path = g.query->path(sources.front(), *target, scratch);
    for (const PathPoint& p : path.points) {
      scene.polyline.push_back({p.position.x, p.position.y, p.position.z});
    }
    const Vec3 p = position_of(*target, g.mesh);
    scene.markers.push_back({p.x, p.y, p.z});
    std::string distance;
    append_number(distance, path.distance);
    path_note = ", path of length " + distance;
  }
  write_png(args.out, render(scene, options));
  const double max_value = max_finite(field.distances);
  char text[200];
  std::snprintf(text, sizeof text, "%dx%d, distances 0..%.6g, ", options.width, options.height,
                max_value);
  std::string lines = "no iso-lines";
  if (options.isolines > 0) {
    char every[80];
    std::snprintf(every, sizeof every, "%d iso-lines every %.6g", options.isolines,
                  max_value / (options.isolines + 1));
    lines = every;
  }
  print_diagnostic("render",
                   "wrote " + args.out + " (" + text + lines + path_note + decal_note + ")");
}

// ---------------------------------------------------------------------------------------------
// geoprox eval MESH GRAPH: accuracy against the exact solver, and query timings.

struct EvalArgs {
  std::string metric;  ///< --metric: the side file the graph was built with
  std::string mesh, graph;
  std::size_t pairs = 1000;
  std::size_t fields = 2;  ///< fields of each kind of source (FieldKind)
  std::size_t paths = 200;
  std::uint64_t seed = 1;
  bool json = false;
  bool fmm = true;
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

void run_eval(const EvalArgs& args) {
  if (args.pairs == 0) throw InvalidInput(ErrorCode::BadCount, "--pairs must be positive");
  GeodesicQueryOptions query_options;
  query_options.refine_within = args.refine_within;
  query_options.exact_within = args.exact_within;
  LoadedGraph g(args.mesh, args.graph, args.metric, query_options);
  const TriangleMesh& mesh = g.mesh;
  const GeodesicQuery& query = *g.query;
  const AreaSampler sampler(g.geometry);
  Rng rng{args.seed};

  // Pairs share sources (100 targets each) so that one full exact solve serves 100 pairs.
  const std::size_t per_source = std::min<std::size_t>(100, args.pairs);
  const std::size_t num_sources = (args.pairs + per_source - 1) / per_source;
  std::vector<SurfacePoint> sources(num_sources);
  std::vector<std::vector<SurfacePoint>> targets(num_sources);
  for (std::size_t k = 0; k < num_sources; ++k) {
    sources[k] = sampler.draw(rng);
    const std::size_t n = std::min(per_source, args.pairs - k * per_source);
    for (std::size_t j = 0; j < n; ++j) targets[k].push_back(sampler.draw(rng));
  }
  // Field k has kind k % kFieldKinds.
  const std::size_t num_fields = args.fields * kFieldKinds;
  std::vector<std::vector<SurfacePoint>> field_sources(num_fields);
  for (std::size_t k = 0; k < num_fields; ++k) {
    const auto kind = static_cast<FieldKind>(k % kFieldKinds);
    field_sources[k] = field_sources_of_kind(kind, mesh, sampler, rng);
  }

  // Exact references and fast marching, in parallel over sources (untimed).
  std::vector<std::vector<double>> exact(num_sources), fmm(num_sources);
  std::vector<std::vector<double>> field_exact(num_fields), field_fmm(num_fields);
  std::fprintf(stderr, "geoprox: eval: exact references for %zu sources and %zu fields...\n",
               num_sources, num_fields);
  const auto total = static_cast<std::int64_t>(num_sources + num_fields);
#pragma omp parallel
  {
    ExactGeodesicSolver solver(mesh, g.geometry);
    FastMarchingSolver marching(mesh, g.geometry);
#pragma omp for schedule(dynamic, 1)
    for (std::int64_t k = 0; k < total; ++k) {
      const auto u = static_cast<std::size_t>(k);
      const bool is_field = u >= num_sources;
      if (is_field) {
        std::vector<GeodesicSource> from;
        for (const SurfacePoint& p : field_sources[u - num_sources]) from.push_back({p, 0});
        solver.solve(from);
        if (args.fmm) marching.solve(from);
        field_exact[u - num_sources] = solver.vertex_distances();
        if (args.fmm) field_fmm[u - num_sources] = marching.vertex_distances();
        continue;
      }
      solver.solve(sources[u]);
      if (args.fmm) marching.solve(sources[u]);
      for (const SurfacePoint& t : targets[u]) {
        double d = kInfinity;
        try {
          d = solver.distance(t);
        } catch (const Unreachable&) {
        }
        exact[u].push_back(d);
        fmm[u].push_back(args.fmm ? fmm_at(marching, mesh, t) : kInfinity);
      }
    }
  }

  // Timed graph queries, one thread.
  QueryScratch scratch = query.make_scratch();
  std::vector<double> approx, reference, fmm_values, p2p_ms, path_ms, field_ms;
  std::size_t exact_answers = 0, unreachable = 0, path_exact_segments = 0, paths_done = 0;
  double samples_settled = 0;
  double worst_path_length_error = 0;
  for (std::size_t k = 0; k < num_sources; ++k) {
    for (std::size_t j = 0; j < targets[k].size(); ++j) {
      const auto start = Clock::now();
      double d = kInfinity;
      try {
        const DistanceResult r = query.distance(sources[k], targets[k][j], scratch);
        d = r.distance;
        exact_answers += r.exact ? 1 : 0;
        samples_settled += r.samples_settled;
      } catch (const Unreachable&) {
        ++unreachable;
      }
      p2p_ms.push_back(ms_since(start));
      approx.push_back(d);
      reference.push_back(exact[k][j]);
      fmm_values.push_back(fmm[k][j]);
    }
  }
  for (std::size_t k = 0; k < num_sources && paths_done < args.paths; ++k) {
    for (std::size_t j = 0; j < targets[k].size() && paths_done < args.paths; ++j) {
      const auto start = Clock::now();
      try {
        const PathResult p = query.path(sources[k], targets[k][j], scratch);
        path_ms.push_back(ms_since(start));
        double length = 0;
        for (std::size_t i = 1; i < p.points.size(); ++i) {
          length += norm(p.points[i].position - p.points[i - 1].position);
        }
        if (p.distance > 0) {
          worst_path_length_error =
              std::max(worst_path_length_error, std::abs(length - p.distance) / p.distance);
        }
        path_exact_segments += p.exact_segments;
      } catch (const Unreachable&) {
      }
      ++paths_done;
    }
  }
  std::vector<double> field_approx, field_reference, field_fmm_values;
  std::array<std::vector<double>, kFieldKinds> kind_approx, kind_reference;
  for (std::size_t k = 0; k < num_fields; ++k) {
    const auto start = Clock::now();
    const DistanceField f = query.field(field_sources[k], scratch);
    field_ms.push_back(ms_since(start));
    for (std::size_t v = 0; v < f.distances.size(); ++v) {
      field_approx.push_back(f.distances[v]);
      field_reference.push_back(field_exact[k][v]);
      field_fmm_values.push_back(args.fmm ? field_fmm[k][v] : kInfinity);
      kind_approx[k % kFieldKinds].push_back(f.distances[v]);
      kind_reference[k % kFieldKinds].push_back(field_exact[k][v]);
    }
  }
  std::array<ErrorStats, kFieldKinds> kind_err;
  for (std::size_t k = 0; k < kFieldKinds; ++k) {
    kind_err[k] = error_stats(kind_approx[k], kind_reference[k]);
  }
  // The vertex behind the worst field error, and its field's sources.
  const ErrorStats field_err = error_stats(field_approx, field_reference);
  std::string worst_field = "none";
  double worst_field_exact = 0, worst_field_graph = 0;
  if (field_err.worst != SIZE_MAX) {
    const std::size_t nv = mesh.num_vertices();
    worst_field = "v:" + std::to_string(field_err.worst % nv) + " from";
    for (const SurfacePoint& p : field_sources[field_err.worst / nv]) {
      worst_field += ' ';
      worst_field += p.to_string();
    }
    worst_field_exact = field_reference[field_err.worst];
    worst_field_graph = field_approx[field_err.worst];
  }

  const ErrorStats pair_err = error_stats(approx, reference);
  const ErrorStats pair_fmm = error_stats(fmm_values, reference);
  // The pair behind the worst error, so that it can be looked at (`geoprox distance`, `path`).
  const std::size_t worst = pair_err.worst == SIZE_MAX ? 0 : pair_err.worst;
  const SurfacePoint& worst_s = sources[worst / per_source];
  const SurfacePoint& worst_t = targets[worst / per_source][worst % per_source];
  const std::string worst_pair = pair_err.worst == SIZE_MAX ? std::string("none")
                                                 : worst_s.to_string() + " " + worst_t.to_string();
  const ErrorStats field_fmm_err = error_stats(field_fmm_values, field_reference);
  const ProximityGraphView view = g.file.view();
  // Theorem 4.2 bounds every pair's relative error when it is finite.
  const double bound = view.error_bound();
  std::size_t beyond_bound = 0;
  if (std::isfinite(bound)) {
    for (std::size_t k = 0; k < approx.size(); ++k) {
      beyond_bound += std::isfinite(reference[k]) && approx[k] > reference[k] * (1 + bound);
    }
  }

  std::string text;
  char buf[512];
  auto add = [&](const char* fmt, auto... values) {
    std::snprintf(buf, sizeof buf, fmt, values...);
    text += buf;
  };
  add("mesh            %s (%zu faces, %zu vertices)\n", args.mesh.c_str(), mesh.num_faces(),
      mesh.num_vertices());
  add("graph           %u samples, m_P %u, link radius %.6g, near pairs solved exactly within %g "
      "and refined within %g link radii\n",
      view.num_samples, view.neighbors, query.link_radius(), args.exact_within,
      args.refine_within);
  add("pairs           %zu (%zu answered exactly, %zu unreachable), seed %llu\n", approx.size(),
      exact_answers, unreachable, static_cast<unsigned long long>(args.seed));
  add("distance error  mean %.4f%%  p50 %.4f%%  p99 %.4f%%  max %.4f%%  (below exact: %zu)\n",
      100 * pair_err.mean, 100 * pair_err.p50, 100 * pair_err.p99, 100 * pair_err.max,
      pair_err.below_exact);
  if (std::isfinite(bound)) {
    add("error bound     %.4g (Theorem 4.2: 2r / (rho - 2r)); pairs beyond it: %zu\n", bound,
        beyond_bound);
  } else {
    add("error bound     none (Theorem 4.2 needs rho > 2r; r %.6g, rho %.6g)\n",
        view.covering_radius, view.link_radius);
  }
  if (pair_err.worst != SIZE_MAX) {
    add("worst pair      %s  (exact %.9g, graph %.9g, %.2f link radii apart)\n",
        worst_pair.c_str(), reference[worst], approx[worst], reference[worst] / query.link_radius());
  }
  if (args.fmm) {
    add("fast marching   mean %.4f%%  p50 %.4f%%  p99 %.4f%%  max %.4f%%\n", 100 * pair_fmm.mean,
        100 * pair_fmm.p50, 100 * pair_fmm.p99, 100 * pair_fmm.max);
  }
  add("field error     %zu fields, mean %.4f%%  p99 %.4f%%  max %.4f%%  (below exact: %zu)\n",
      num_fields, 100 * field_err.mean, 100 * field_err.p99, 100 * field_err.max,
      field_err.below_exact);
  for (std::size_t k = 0; k < kFieldKinds; ++k) {
    add("  %-6s sources mean %.4f%%  p99 %.4f%%  max %.4f%%  (below exact: %zu)\n",
        kFieldKindNames[k], 100 * kind_err[k].mean, 100 * kind_err[k].p99, 100 * kind_err[k].max,
        kind_err[k].below_exact);
  }
  if (field_err.worst != SIZE_MAX) {
    add("worst field     %s  (exact %.9g, graph %.9g, %.2f link radii)\n", worst_field.c_str(),
        worst_field_exact, worst_field_graph, worst_field_exact / query.link_radius());
  }
  if (args.fmm) {
    add("field fmm       mean %.4f%%  p99 %.4f%%  max %.4f%%\n", 100 * field_fmm_err.mean,
        100 * field_fmm_err.p99, 100 * field_fmm_err.max);
  }
  add("p2p time        median %.3f ms  p99 %.3f ms  (graph search: %.0f samples settled on "
      "average)\n",
      quantile(p2p_ms, 0.5), quantile(p2p_ms, 0.99),
      samples_settled / static_cast<double>(std::max<std::size_t>(1, approx.size())));
  add("path time       median %.3f ms  p99 %.3f ms  (%zu paths, %zu exact segments, length "
      "error max %.2e)\n",
      quantile(path_ms, 0.5), quantile(path_ms, 0.99), path_ms.size(), path_exact_segments,
      worst_path_length_error);
  add("field time      median %.3f ms\n", quantile(field_ms, 0.5));
  if (args.json) {
    add("{\"mesh\":\"%s\",\"faces\":%zu,\"vertices\":%zu,\"samples\":%u,\"neighbors\":%u,",
        json_escape(args.mesh).c_str(), mesh.num_faces(), mesh.num_vertices(),
        view.num_samples, view.neighbors);
    add("\"link_radius\":%.17g,\"exact_within\":%.17g,\"refine_within\":%.17g,\"pairs\":%zu,"
        "\"exact_answers\":%zu,\"unreachable\":%zu,",
        query.link_radius(), args.exact_within, args.refine_within, approx.size(), exact_answers,
        unreachable);
    add("\"seed\":%llu,\"error\":{\"mean\":%.6g,\"p50\":%.6g,\"p99\":%.6g,\"max\":%.6g,"
        "\"below_exact\":%zu},",
        static_cast<unsigned long long>(args.seed), pair_err.mean, pair_err.p50, pair_err.p99,
        pair_err.max, pair_err.below_exact);
    add("\"worst_pair\":\"%s\",", json_escape(worst_pair).c_str());
    if (std::isfinite(bound)) {
      add("\"error_bound\":%.6g,\"beyond_bound\":%zu,", bound, beyond_bound);
    } else {
      add("%s", "\"error_bound\":null,\"beyond_bound\":0,");
    }
    add("\"fmm_error\":{\"mean\":%.6g,\"p50\":%.6g,\"p99\":%.6g,\"max\":%.6g},", pair_fmm.mean,
        pair_fmm.p50, pair_fmm.p99, pair_fmm.max);
    add("\"fields\":%zu,\"field_error\":{\"mean\":%.6g,\"p99\":%.6g,\"max\":%.6g,"
        "\"below_exact\":%zu},",
        num_fields, field_err.mean, field_err.p99, field_err.max, field_err.below_exact);
    add("%s", "\"field_error_by_source\":{");
    for (std::size_t k = 0; k < kFieldKinds; ++k) {
      add("\"%s\":{\"mean\":%.6g,\"p99\":%.6g,\"max\":%.6g,\"below_exact\":%zu}%s",
          kFieldKindNames[k], kind_err[k].mean, kind_err[k].p99, kind_err[k].max,
          kind_err[k].below_exact, k + 1 < kFieldKinds ? "," : "},");
    }
    add("\"field_fmm_error\":{\"mean\":%.6g,\"p99\":%.6g,\"max\":%.6g},", field_fmm_err.mean,
        field_fmm_err.p99, field_fmm_err.max);
    add("\"p2p_ms\":{\"p50\":%.6g,\"p99\":%.6g},\"path_ms\":{\"p50\":%.6g,\"p99\":%.6g},",
        quantile(p2p_ms, 0.5), quantile(p2p_ms, 0.99), quantile(path_ms, 0.5),
        quantile(path_ms, 0.99));
    add("\"path_exact_segments\":%zu,\"path_length_error_max\":%.6g,\"field_ms\":%.6g}\n",
        path_exact_segments, worst_path_length_error, quantile(field_ms, 0.5));
  }
  write_output(text, "");
}

/// --metric on a command that reads a graph: the graph's edge lengths must be the mesh's under
/// that metric (docs/metrics.md), else opening it fails with MeshMismatch.
void add_metric_option(CLI::App& command, std::string& metric) {
  command.add_option("--metric", metric,
                     "Riemannian metric side file the graph was built with (docs/metrics.md)");
}

void add_graph_options(CLI::App& command, std::string& graph, std::string& metric) {
  command.add_option("-g,--graph", graph, "Graph file from 'geoprox build'")->required();
  add_metric_option(command, metric);
}

}  // namespace

void add_query_commands(CLI::App& app, std::vector<Command>& commands) {
  const std::string mesh_help = "Triangle mesh file the graph was built from";
  const std::string point_help =
      "Points: v:ID, e:ID:t, f:ID:b0:b1:b2, s:SAMPLE (a graph sample) or p:X,Y,Z (a position,\n"
      "snapped to the closest surface point; refused beyond 5% of the bounding-box diagonal).";

  auto distance_args = std::make_shared<DistanceArgs>();
  CLI::App* distance =
      app.add_subcommand("distance", "Graph distances between pairs of points (one per line)");
  distance->add_option("MESH", distance_args->mesh, mesh_help)->required();
  add_graph_options(*distance, distance_args->graph, distance_args->metric);
  distance
      ->add_option("--pairs", distance_args->pairs,
                   "File of lines 'SOURCE TARGET' ('-' for standard input)")
      ->required();
  distance->footer(point_help +
                   "\nOutput: one distance per pair at full precision (%.17g), 'inf' when the\n"
                   "points lie in different components. Query timings (median, p99) on stderr.\n\n" +
                   exit_code_footer());
  commands.push_back({distance, [distance_args] { run_distance(*distance_args); }});

  auto field_args = std::make_shared<FieldArgs>();
  CLI::App* field =
      app.add_subcommand("field", "Graph distance field: distance of every vertex from a source");
  field->add_option("MESH", field_args->mesh, mesh_help)->required();
  add_graph_options(*field, field_args->graph, field_args->metric);
  field
      ->add_option("-s,--source", field_args->sources,
                   "Source point(s); with several, the distance to the nearest")
      ->required()
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  field->add_option("--max-distance", field_args->max_distance,
                    "Vertices farther than this print inf")
      ->check(CLI::Validator(check_radius, "D>=0"));
  field->add_option("--threads", field_args->threads, "Threads for the per-vertex pass")
      ->check(CLI::Range(1, 256));
  field->add_option("-o,--out", field_args->out,
                    "Write the mesh with the field as a PLY file instead (see below)");
  field->footer(point_help +
                "\nOutput: one distance per vertex in vertex order (%.17g, 'inf' where\n"
                "unreachable). Timing on stderr.\n" +
                field_ply_footer() + "\n\n" + exit_code_footer());
  commands.push_back({field, [field_args] { run_field(*field_args); }});

  auto path_args = std::make_shared<PathArgs>();
  CLI::App* path = app.add_subcommand("path", "Shortest path between two points on a graph");
  path->add_option("MESH", path_args->mesh, mesh_help)->required();
  add_graph_options(*path, path_args->graph, path_args->metric);
  path->add_option("-s,--source", path_args->source, "Source point")->required();
  path->add_option("-t,--target", path_args->target, "Target point")->required();
  path->add_option("-o,--out", path_args->out,
                   "Write the path as an OBJ polyline instead of printing its points");
  path->footer(point_help +
               "\nOutput: one 'X Y Z' line per path point from the source to the target\n"
               "(%.17g): the source, every edge crossing, the target. On stderr: 'geoprox: path:\n"
               "distance D, N points, exact yes|no' and the timing. Points in different\n"
               "components have no path: error [Unreachable], exit 2.\n"
               "--out FILE: a Wavefront OBJ (Blender, MeshLab): one 'v X Y Z' line per point and\n"
               "one 'l 1 2 ... N' line; nothing on stdout.\n\n" +
               exit_code_footer());
  commands.push_back({path, [path_args] { run_path(*path_args); }});

  auto render_args = std::make_shared<RenderArgs>();
  CLI::App* render_command = app.add_subcommand(
      "render", "Draw a PNG of the mesh coloured by a distance field, with iso-lines and a path");
  render_command->add_option("MESH", render_args->mesh, mesh_help)->required();
  add_graph_options(*render_command, render_args->graph, render_args->metric);
  render_command
      ->add_option("-s,--source", render_args->sources,
                   "Source point(s) of the distance field (drawn as white dots)")
      ->required()
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  render_command->add_option("-t,--target", render_args->target,
                             "Also draw the shortest path from the first source to this point");
  render_command->add_option("-o,--out", render_args->out, "PNG file to write")->required();
  render_command->add_option("--width", render_args->options.width, "Picture width in pixels")
      ->check(CLI::Range(1, 8192))
      ->capture_default_str();
  render_command->add_option("--height", render_args->options.height, "Picture height in pixels")
      ->check(CLI::Range(1, 8192))
      ->capture_default_str();
  render_command
      ->add_option("--view", render_args->view,
                   "AZIMUTH,ELEVATION in degrees: where the camera looks from")
      ->check(CLI::Validator(check_view, "AZ,EL"))
      ->capture_default_str();
  render_command->add_option("--up", render_args->up, "The mesh's up axis")
      ->check(CLI::IsMember({"x", "y", "z"}))
      ->capture_default_str();
  render_command
      ->add_option("--isolines", render_args->options.isolines,
                   "Iso-lines at N evenly spaced distances (0: none)")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  render_command->add_option("--max-distance", render_args->max_distance,
                             "Vertices farther than this are grey (unreachable)")
      ->check(CLI::Validator(check_radius, "D>=0"));
  render_command
      ->add_option("--decal-radius", render_args->decal_radius,
                   "Draw a checkerboard decal through the exponential map of the (first) source, "
                   "out to this geodesic radius (paper Fig. 14); 0: none")
      ->check(CLI::NonNegativeNumber);
  render_command
      ->add_option("--decal-squares", render_args->decal_squares,
                   "Checkerboard squares across the decal's diameter")
      ->check(CLI::Range(1, 1000));
  render_command->add_option("--threads", render_args->threads, "Threads for the field")
      ->check(CLI::Range(1, 256));
  render_command->footer(
      point_help +
      "\nA software rasterizer (no display needed): orthographic view fitted to the mesh,\n"
      "z-buffer, Gouraud shading under a headlight, 3x3 supersampling. --view 0,0 looks from\n"
      "+z (up y), +x (up z) or +y (up x); the azimuth turns about the up axis, the elevation\n"
      "raises the camera. Colours: viridis from 0 (dark purple) to the largest finite distance\n"
      "(yellow); unreachable vertices grey (128,128,128). Iso-lines (dark) at k*max/(N+1),\n"
      "k = 1..N. The path (with --target) is red with a dark outline, hidden where the mesh is\n"
      "in front of it; sources and target are white dots; a target in another component\n"
      "than the first source has no path: error [Unreachable], exit 2. The PNG (8-bit RGB)\n"
      "is written atomically; one line on stderr says what was drawn.\n\n" +
      exit_code_footer());
  commands.push_back({render_command, [render_args] { run_render(*render_args); }});

  auto eval_args = std::make_shared<EvalArgs>();
  CLI::App* eval = app.add_subcommand(
      "eval", "Accuracy of graph queries against the exact solver, and their timings");
  eval->add_option("MESH", eval_args->mesh, mesh_help)->required();
  eval->add_option("GRAPH", eval_args->graph, "Graph file from 'geoprox build'")->required();
  add_metric_option(*eval, eval_args->metric);
  eval->add_option("--pairs", eval_args->pairs, "Random point pairs (uniform by area)")
      ->check(CLI::PositiveNumber);
  eval->add_option("--fields", eval_args->fields,
                   "Distance fields of each kind of source: a vertex, an edge point, a face point "
                   "and three face points (corner, side and face drawn uniformly by area)");
  eval->add_option("--paths", eval_args->paths, "Pairs also queried for their path");
  eval->add_option("--seed", eval_args->seed, "Seed of the random points (same seed, same points)");
  eval->add_flag("--json", eval_args->json, "End with one JSON line holding every figure");
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
