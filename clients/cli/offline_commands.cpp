// Offline commands of `geoprox`, which call geoprox::core directly (no daemon):
//   geoprox info MESH
//   geoprox exact MESH --source POINT... [--radius R] [--to POINT] [--metric FILE] [--out FILE]
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "clients/cli/cli.h"
#include "core/errors.h"
#include "core/exact_geodesic.h"
#include "core/intrinsic_geometry.h"
#include "core/mesh.h"
#include "core/mesh_io.h"
#include "core/mesh_report.h"
#include "core/riemannian_metric.h"
#include "core/surface_point.h"

namespace geoprox::cli {
namespace {

struct InfoArgs {
  std::string mesh;
};

struct ExactArgs {
  std::string mesh;
  std::vector<std::string> sources;
  std::string to;
  std::string metric;  ///< Riemannian metric side file (docs/metrics.md); empty: none
  double radius = kInfinity;
  std::string out;
  bool out_given = false;  ///< --out was on the command line (an empty path is an error)
  bool to_given = false;   ///< --to was on the command line (an empty point is an error)
};

void run_info(const InfoArgs& args) {
  const TriangleMesh mesh = load_mesh(args.mesh);
  const IntrinsicGeometry geometry(mesh);
  std::string text = format_mesh_report(compute_mesh_report(mesh, geometry));
  if (text.empty() || text.back() != '\n') text += '\n';
  write_output(text, "");
}

void append_direction(std::string& out, const char* label, const FaceDirection& d) {
  out += label;
  out += ' ';
  out += std::to_string(d.face);
  out += ' ';
  append_number(out, d.x);
  out += ' ';
  append_number(out, d.y);
  out += '\n';
}

void run_exact(const ExactArgs& args) {
  // Syntax first, so a typo fails before a large mesh is loaded.
  std::vector<SurfacePoint> points;
  points.reserve(args.sources.size());
  for (const std::string& text : args.sources) points.push_back(parse_point("--source", text));
  std::optional<SurfacePoint> to;
  if (args.to_given) to = parse_point("--to", args.to);
  if (std::isnan(args.radius) || args.radius < 0) {
    throw InvalidInput("BadRadius", "--radius must be a non-negative number");
  }

  const TriangleMesh mesh = load_mesh(args.mesh);
  const IntrinsicGeometry geometry = load_geometry(mesh, args.metric);
  std::vector<GeodesicSource> sources;
  sources.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    validate_point("--source", args.sources[i], points[i], mesh);
    sources.push_back({points[i], 0.0});
  }
  if (to) validate_point("--to", args.to, *to, mesh);

  ExactGeodesicSolver solver(mesh, geometry);
  ExactGeodesicSolver::Options options;
  options.max_distance = args.radius;
  options.queue_halfedges = true;  // one solve, usually wide, as a full solve always is
  std::string text;

  if (!to) {
    solver.solve(sources, {}, options);
    const std::vector<double> distances = solver.vertex_distances();
    GEOPROX_ASSERT(distances.size() == mesh.num_vertices(), "one distance per vertex");
    text.reserve(distances.size() * 24);
    for (double d : distances) {
      append_number(text, d <= args.radius ? d : kInfinity);  // beyond --radius: unreachable
      text += '\n';
    }
    write_result(text, args.out, args.out_given);
    return;
  }

  solver.solve(sources, std::span<const SurfacePoint>(&*to, 1), options);
  double distance = kInfinity;
  try {
    distance = solver.distance(*to);
  } catch (const Unreachable&) {
    // not reached: reported below as distance inf
  }
  if (!std::isfinite(distance) || distance > args.radius) {
    write_result("distance inf\npath 0\n", args.out, args.out_given);
    print_diagnostic("unreachable",
                     to->to_string() + " is not reachable from the source" +
                         (sources.size() > 1 ? "s" : "") +
                         (std::isinf(args.radius) ? " (another connected component)"
                                                  : " (another component, or beyond --radius)"));
    return;
  }
  const GeodesicPath path = solver.path_to(*to);
  text += "distance ";
  append_number(text, distance);
  text += "\npath ";
  text += std::to_string(path.points.size());
  text += '\n';
  for (const PathPoint& p : path.points) {
    text += p.point.to_string();
    for (double c : {p.position.x, p.position.y, p.position.z}) {
      text += ' ';
      append_number(text, c);
    }
    text += '\n';
  }
  append_direction(text, "source_direction", path.direction_at_source);
  append_direction(text, "target_direction", path.direction_at_target);
  write_result(text, args.out, args.out_given);
}

}  // namespace

void add_offline_commands(CLI::App& app, std::vector<Command>& commands) {
  const std::string mesh_help =
      "Triangle mesh file: OBJ, OFF, PLY (ascii or binary) or STL; ids are file order";

  auto info_args = std::make_shared<InfoArgs>();
  CLI::App* info = app.add_subcommand("info", "Print the validation report of a mesh");
  info->add_option("MESH", info_args->mesh, mesh_help)->required();
  info->footer(exit_code_footer());
  commands.push_back({info, [info_args] { run_info(*info_args); }});

  auto exact_args = std::make_shared<ExactArgs>();
  CLI::App* exact = app.add_subcommand(
      "exact", "Exact geodesic distance of every vertex, or distance and path to one point");
  exact->add_option("MESH", exact_args->mesh, mesh_help)->required();
  exact
      ->add_option("-s,--source", exact_args->sources,
                   "Source point(s): v:ID, e:ID:t or f:ID:b0:b1:b2 (repeat for several)")
      ->required()
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  exact->add_option("-r,--radius", exact_args->radius,
                    "Explore only up to this geodesic distance; farther vertices print inf")
      ->check(CLI::Validator(check_radius, "R>=0"));
  exact->add_option("-t,--to", exact_args->to, "Print the distance and path to this one point");
  exact->add_option("--metric", exact_args->metric,
                    "Riemannian metric side file (docs/metrics.md): distances are measured in it");
  exact->add_option("-o,--out", exact_args->out,
                    "Write to FILE (replaced atomically) instead of standard output");
  exact->footer(
      "Output without --to: the distance of every vertex, one per line in vertex order, at\n"
      "full precision (%.17g), 'inf' where unreachable or beyond --radius.\n"
      "Output with --to POINT:\n"
      "  distance D\n"
      "  path N                     followed by N lines, from the source to POINT:\n"
      "  PATHPOINT X Y Z            a point in v:/e:/f: syntax and its position\n"
      "  source_direction FACE X Y  unit tangent at the source, pointing along the path\n"
      "  target_direction FACE X Y  unit tangent at POINT, pointing back along the path\n"
      "Directions are in the face's frame: origin at its corner 0, x towards corner 1,\n"
      "y towards corner 2's side. An unreachable POINT (another component, or beyond\n"
      "--radius) prints 'distance inf' and 'path 0', says 'unreachable' on stderr, exits 0.\n\n" +
      exit_code_footer());
  commands.push_back({exact, [exact_args, exact] {
                        exact_args->out_given = exact->count("--out") > 0;
                        exact_args->to_given = exact->count("--to") > 0;
                        run_exact(*exact_args);
                      }});
}

}  // namespace geoprox::cli
