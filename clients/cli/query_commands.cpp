// `geoprox distance`, `geoprox field`, `geoprox path` and `geoprox render`: queries on a built
// graph, calling core directly (`geoprox eval` is in eval_command.cpp).
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
#include "clients/cli/stats.h"
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
  bool repair = false;  ///< --repair: the graph was built for the repaired mesh
  std::string mesh, graph, pairs;
};

void run_distance(const DistanceArgs& args) {
  const LoadedGraph g(args.mesh, args.graph, args.metric, {}, {.repair = args.repair});
  report_repair(args.mesh, g.data->repair);
  std::ifstream file;
  std::istream* in = &std::cin;
  if (args.pairs != "-") {
    file.open(args.pairs);
    if (!file)
      throw FileError(ErrorCode::FileNotFound, "cannot open pairs file '" + args.pairs + "'");
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
  bool repair = false;  ///< --repair: the graph was built for the repaired mesh
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
  const LoadedGraph g(args.mesh, args.graph, args.metric, {}, {.repair = args.repair});
  report_repair(args.mesh, g.data->repair);
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
  bool repair = false;  ///< --repair: the graph was built for the repaired mesh
  std::string mesh, graph, source, target, out;
};

void run_path(const PathArgs& args) {
  const LoadedGraph g(args.mesh, args.graph, args.metric, {}, {.repair = args.repair});
  report_repair(args.mesh, g.data->repair);
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
  bool repair = false;  ///< --repair: the graph was built for the repaired mesh
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
  const LoadedGraph g(args.mesh, args.graph, args.metric, {}, {.repair = args.repair});
  report_repair(args.mesh, g.data->repair);
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

void add_graph_options(CLI::App& command, std::string& graph, std::string& metric, bool& repair) {
  command.add_option("-g,--graph", graph, "Graph file from 'geoprox build'")->required();
  add_metric_option(command, metric);
  add_repair_flag(command, repair);
}

constexpr const char* kMeshHelp = "Triangle mesh file the graph was built from";
constexpr const char* kPointHelp =
    "Points: v:ID, e:ID:t, f:ID:b0:b1:b2, s:SAMPLE (a graph sample) or p:X,Y,Z (a position,\n"
    "snapped to the closest surface point; refused beyond 5% of the bounding-box diagonal).";

void add_distance_command(CLI::App& app, std::vector<Command>& commands) {
  const std::string mesh_help = kMeshHelp, point_help = kPointHelp;
  auto distance_args = std::make_shared<DistanceArgs>();
  CLI::App* distance =
      app.add_subcommand("distance", "Graph distances between pairs of points (one per line)");
  distance->add_option("MESH", distance_args->mesh, mesh_help)->required();
  add_graph_options(*distance, distance_args->graph, distance_args->metric, distance_args->repair);
  distance
      ->add_option("--pairs", distance_args->pairs,
                   "File of lines 'SOURCE TARGET' ('-' for standard input)")
      ->required();
  distance->footer(
      point_help +
      "\nOutput: one distance per pair at full precision (%.17g), 'inf' when the\n"
      "points lie in different components. Query timings (median, p99) on stderr.\n\n" +
      exit_code_footer());
  commands.push_back({distance, [distance_args] { run_distance(*distance_args); }});
}

void add_field_command(CLI::App& app, std::vector<Command>& commands) {
  const std::string mesh_help = kMeshHelp, point_help = kPointHelp;
  auto field_args = std::make_shared<FieldArgs>();
  CLI::App* field =
      app.add_subcommand("field", "Graph distance field: distance of every vertex from a source");
  field->add_option("MESH", field_args->mesh, mesh_help)->required();
  add_graph_options(*field, field_args->graph, field_args->metric, field_args->repair);
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
}

void add_path_command(CLI::App& app, std::vector<Command>& commands) {
  const std::string mesh_help = kMeshHelp, point_help = kPointHelp;
  auto path_args = std::make_shared<PathArgs>();
  CLI::App* path = app.add_subcommand("path", "Shortest path between two points on a graph");
  path->add_option("MESH", path_args->mesh, mesh_help)->required();
  add_graph_options(*path, path_args->graph, path_args->metric, path_args->repair);
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
}

void add_render_command(CLI::App& app, std::vector<Command>& commands) {
  const std::string mesh_help = kMeshHelp, point_help = kPointHelp;
  auto render_args = std::make_shared<RenderArgs>();
  CLI::App* render_command = app.add_subcommand(
      "render", "Draw a PNG of the mesh coloured by a distance field, with iso-lines and a path");
  render_command->add_option("MESH", render_args->mesh, mesh_help)->required();
  add_graph_options(*render_command, render_args->graph, render_args->metric, render_args->repair);
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
}

}  // namespace

void add_metric_option(CLI::App& command, std::string& metric) {
  command.add_option("--metric", metric,
                     "Riemannian metric side file the graph was built with (docs/metrics.md)");
}

void add_query_commands(CLI::App& app, std::vector<Command>& commands) {
  add_distance_command(app, commands);
  add_field_command(app, commands);
  add_path_command(app, commands);
  add_render_command(app, commands);
}

}  // namespace geoprox::cli
