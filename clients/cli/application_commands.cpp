// Applications of the queries (paper §6), calling core directly:
//   geoprox expmap MESH --graph G --source P --radius R [--exact] [--metric FILE] [--out FILE]
//                  [--repair]
//   geoprox spline MESH --graph G --type bezier|bspline --samples N --control P P P P ...
//                  [--exact] [--metric FILE] [--out FILE] [--repair]
#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "clients/cli/cli.h"
#include "core/base/errors.h"
#include "core/apps/exponential_map.h"
#include "core/query/geodesic_query.h"
#include "core/apps/geodesic_spline.h"
#include "core/graph/graph_file.h"
#include "core/graph/loaded_graph.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh_io.h"

namespace geoprox::cli {
namespace {

using Clock = std::chrono::steady_clock;

/// A mesh (repaired with --repair) under its optional metric, and its graph file (checked
/// against both) when given.
struct LoadedMesh {
  std::shared_ptr<const MeshData> data;
  const TriangleMesh& mesh;           ///< data->mesh
  const IntrinsicGeometry& geometry;  ///< data->geometry
  std::optional<MappedGraphFile> file;
  std::unique_ptr<GeodesicQuery> query;

  LoadedMesh(const std::string& mesh_path, const std::string& metric_path,
             const std::string& graph_path, bool repair)
      : data(load_command_mesh_data(mesh_path, metric_path, repair)),
        mesh(data->mesh),
        geometry(data->geometry) {
    if (graph_path.empty()) return;
    file = MappedGraphFile::open(graph_path);
    file->verify_mesh(mesh, geometry);
    query = std::make_unique<GeodesicQuery>(mesh, geometry, file->view());
  }

  /// An `Application` (ExponentialMap, GeodesicSpline) on the graph when one was loaded, else
  /// on the mesh alone (exact geodesics only).
  template <typename Application>
  std::unique_ptr<Application> make() const {
    return query ? std::make_unique<Application>(*query)
                 : std::make_unique<Application>(mesh, geometry);
  }
};

struct CommonArgs {
  std::string mesh, graph, metric, out;
  bool exact = false;
  bool out_given = false;
  bool repair = false;
};

void add_common_options(CLI::App* command, CommonArgs& args) {
  command->add_option("MESH", args.mesh, "Triangle mesh file: OBJ, OFF, PLY or STL")->required();
  command->add_option("-g,--graph", args.graph,
                      "Proximity graph file built for MESH (geoprox build); needed unless --exact");
  command->add_flag("--exact", args.exact,
                    "Use the exact solver instead of the graph (the reference; slower)");
  command->add_option("--metric", args.metric,
                      "Riemannian metric side file (docs/metrics.md) the graph was built with");
  command->add_option("-o,--out", args.out,
                      "Write to FILE (replaced atomically) instead of standard output");
  add_repair_flag(*command, args.repair);
}

void check_graph_given(const CommonArgs& args) {
  if (!args.exact && args.graph.empty()) {
    throw InvalidInput(ErrorCode::MissingGraph,
                       "--graph FILE is required (or --exact for the exact solver)");
  }
}

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// Registers `run(*args)` as what `command` runs, after noting whether --out was given.
template <typename Args>
void add_command(std::vector<Command>& commands, CLI::App* command, std::shared_ptr<Args> args,
                 void (*run)(const Args&)) {
  commands.push_back({command, [command, args, run] {
                        args->out_given = command->count("--out") > 0;
                        run(*args);
                      }});
}

// ---------------------------------------------------------------------------------------------

struct ExpmapArgs : CommonArgs {
  std::string source;
  double radius = 0;
};

void run_expmap(const ExpmapArgs& args) {
  const SurfacePoint source = parse_point("--source", args.source);
  if (std::isnan(args.radius) || args.radius < 0) {
    throw InvalidInput(ErrorCode::BadRadius, "--radius must be a non-negative number");
  }
  check_graph_given(args);
  const LoadedMesh m(args.mesh, args.metric, args.exact ? "" : args.graph, args.repair);
  validate_point("--source", args.source, source, m.mesh);
  const auto start = Clock::now();
  const std::unique_ptr<ExponentialMap> map = m.make<ExponentialMap>();
  ExponentialMapOptions options;
  options.radius = args.radius;
  options.mode = args.exact ? ExponentialMapMode::Exact : ExponentialMapMode::Graph;
  const ExponentialMapResult result = map->compute(source, options);
  const double elapsed = ms_since(start);
  std::string text;
  text.reserve(result.vertices.size() * 48);
  for (const ExponentialMapVertex& e : result.vertices) {
    text += std::to_string(e.vertex);
    text += ' ';
    append_number(text, e.u);
    text += ' ';
    append_number(text, e.v);
    text += '\n';
  }
  write_result(text, args.out, args.out_given);
  std::fprintf(stderr, "geoprox: timing: exponential map of %zu vertices in %.3f ms (%s)\n",
               result.vertices.size(), elapsed, args.exact ? "exact" : "graph");
}

// ---------------------------------------------------------------------------------------------

struct SplineArgs : CommonArgs {
  std::string type = "bezier";
  std::uint32_t samples = 100;
  int threads = 0;
  std::vector<std::string> control;
};

void run_spline(const SplineArgs& args) {
  std::vector<SurfacePoint> control;
  for (const std::string& text : args.control) control.push_back(parse_point("--control", text));
  check_graph_given(args);
  const LoadedMesh m(args.mesh, args.metric, args.exact ? "" : args.graph, args.repair);
  for (std::size_t i = 0; i < control.size(); ++i) {
    validate_point("--control", args.control[i], control[i], m.mesh);
  }
  const auto start = Clock::now();
  const std::unique_ptr<GeodesicSpline> spline = m.make<GeodesicSpline>();
  GeodesicSplineOptions options;
  options.type = args.type == "bspline" ? SplineType::BSpline : SplineType::Bezier;
  options.samples = args.samples;
  options.geodesics = args.exact ? SplineGeodesics::Exact : SplineGeodesics::Graph;
  options.threads = args.threads;
  const GeodesicSplineResult result = spline->compute(control, options);
  const double elapsed = ms_since(start);
  std::string text;
  text.reserve(result.curve.size() * 64);
  for (const PathPoint& p : result.curve) {
    append_number(text, p.position.x);
    text += ' ';
    append_number(text, p.position.y);
    text += ' ';
    append_number(text, p.position.z);
    text += '\n';
  }
  write_result(text, args.out, args.out_given);
  std::fprintf(stderr, "geoprox: timing: spline of %zu points (%u geodesics) in %.3f ms (%s)\n",
               result.curve.size(), result.geodesics, elapsed, args.exact ? "exact" : "graph");
}

}  // namespace

void add_application_commands(CLI::App& app, std::vector<Command>& commands) {
  auto expmap_args = std::make_shared<ExpmapArgs>();
  CLI::App* expmap = app.add_subcommand(
      "expmap", "Discrete exponential map: geodesic polar coordinates around a point (paper §6.1)");
  add_common_options(expmap, *expmap_args);
  expmap
      ->add_option("-s,--source", expmap_args->source,
                   "Centre of the map: v:ID, e:ID:t or f:ID:b0:b1:b2")
      ->required();
  expmap
      ->add_option("-r,--radius", expmap_args->radius,
                   "Map every vertex within this geodesic distance")
      ->required()
      ->check(CLI::Validator(check_radius, "R>=0"));
  expmap->footer(
      "Output: one line 'VERTEX U V' per vertex within --radius, in vertex order, at full\n"
      "precision; (U, V) = d (cos theta, sin theta), d the geodesic distance and theta the angle\n"
      "of the shortest path's start direction in the source's tangent frame "
      "(docs/applications.md).\n"
      "The timing goes to standard error.\n\n" +
      exit_code_footer());
  add_command(commands, expmap, expmap_args, run_expmap);

  auto spline_args = std::make_shared<SplineArgs>();
  CLI::App* spline = app.add_subcommand(
      "spline",
      "Cubic Bezier or B-spline curve on the surface by geodesic de Casteljau / de Boor "
      "(paper §6.2)");
  add_common_options(spline, *spline_args);
  spline
      ->add_option("-t,--type", spline_args->type, "bezier (3k+1 control points) or bspline (>= 4)")
      ->check(CLI::IsMember({"bezier", "bspline"}));
  spline->add_option("-n,--samples", spline_args->samples,
                     "Curve points, both ends included (>= 2)");
  spline
      ->add_option("--threads", spline_args->threads,
                   "Threads over the curve points (default 0: all cores)")
      ->check(CLI::NonNegativeNumber);
  spline
      ->add_option("-c,--control", spline_args->control,
                   "Control points: v:ID, e:ID:t or f:ID:b0:b1:b2")
      ->required()
      ->expected(1, -1);
  spline->footer(
      "Output: one line 'X Y Z' per curve point, in order, at full precision.\n"
      "The timing goes to standard error.\n\n" +
      exit_code_footer());
  add_command(commands, spline, spline_args, run_spline);
}

}  // namespace geoprox::cli
