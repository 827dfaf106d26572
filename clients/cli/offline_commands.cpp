// Offline commands of `geoprox`, which call geoprox::core directly (no daemon):
//   geoprox info MESH [--repair]
//   geoprox exact MESH --source POINT... [--radius R] [--to POINT] [--metric FILE] [--out FILE]
//                 [--repair]
//   geoprox repair MESH --out FILE [--map FILE] [--no-orient]
//   geoprox refine MESH --out FILE [--max-edge L] [--map FILE] [--repair]
#include <CLI/CLI.hpp>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "clients/cli/cli.h"
#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/graph/loaded_graph.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/mesh_io.h"
#include "core/mesh/mesh_refinement.h"
#include "core/graph/refined_surface.h"
#include "core/mesh/mesh_repair.h"
#include "core/graph/proximity_graph.h"
#include "core/mesh/mesh_report.h"
#include "core/mesh/surface_point.h"

namespace geoprox::cli {
namespace {

struct InfoArgs {
  std::string mesh;
  bool repair = false;
};

struct RefineArgs {
  std::string mesh;
  std::string out;          ///< .obj or .off
  std::string map;          ///< empty: no map written
  double max_edge = 0;      ///< 0: half the link radius of a default graph of the input
  bool repair = false;
};

struct RepairArgs {
  std::string mesh;
  std::string out;  ///< .obj or .off
  std::string map;  ///< empty: no map written
  bool no_orient = false;
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
  bool repair = false;
};

void run_info(const InfoArgs& args) {
  const std::shared_ptr<const MeshData> data = load_command_mesh_data(args.mesh, "", args.repair);
  std::string text = format_mesh_report(compute_mesh_report(data->mesh, data->geometry));
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
    throw InvalidInput(ErrorCode::BadRadius, "--radius must be a non-negative number");
  }

  const std::shared_ptr<const MeshData> data =
      load_command_mesh_data(args.mesh, args.metric, args.repair);
  const TriangleMesh& mesh = data->mesh;
  const IntrinsicGeometry& geometry = data->geometry;
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

/// ".obj", ".OFF", ... lower-cased ("" when there is none), as load_mesh reads extensions.
std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

/// The mesh as OBJ (with `comment` as its first line) or OFF, positions at full precision.
std::string format_mesh(const std::vector<Vec3>& positions, const std::vector<Triangle>& faces,
                        bool obj, const std::string& comment) {
  std::string text;
  text.reserve(positions.size() * 64 + faces.size() * 24);
  // 1-based in OBJ, 0-based in OFF.
  const std::uint32_t base = obj ? 1 : 0;
  if (obj) {
    text += "# " + comment + "\n";
  } else {
    text += "OFF\n";  // no comment: OFF readers take none (docs/meshes.md)
    text += std::to_string(positions.size()) + ' ' + std::to_string(faces.size()) + " 0\n";
  }
  for (const Vec3& p : positions) {
    if (obj) text += "v ";
    append_number(text, p.x);
    text += ' ';
    append_number(text, p.y);
    text += ' ';
    append_number(text, p.z);
    text += '\n';
  }
  for (const Triangle& t : faces) {
    text += obj ? "f" : "3";
    for (std::uint32_t v : t) text += ' ' + std::to_string(v + base);
    text += '\n';
  }
  return text;
}

std::string format_repair_map(const RepairedMesh& repaired, const std::string& source,
                              const std::string& out) {
  std::string text = "# geoprox repair map: " + source + " -> " + out + "\n";
  text += "# v NEW OLD: a copy appended to the mesh (vertices below " +
          std::to_string(repaired.report.vertices_in) + " keep their ids)\n";
  for (std::size_t v = repaired.report.vertices_in; v < repaired.source_vertex.size(); ++v) {
    text += "v " + std::to_string(v) + ' ' + std::to_string(repaired.source_vertex[v]) + '\n';
  }
  text += "# f NEW OLD [flipped]: every face; flipped: corners 1 and 2 swapped\n";
  for (std::size_t f = 0; f < repaired.faces.size(); ++f) {
    text += "f " + std::to_string(f) + ' ' + std::to_string(repaired.source_face[f]);
    if (repaired.flipped[f]) text += " flipped";
    text += '\n';
  }
  return text;
}

/// `--out` must name an .obj or .off file; returns whether it is OBJ.
bool mesh_output_is_obj(const std::string& out, const char* command) {
  const std::string ext = lower_extension(out);
  if (ext != ".obj" && ext != ".off") {
    throw InvalidInput(ErrorCode::UnsupportedFormat,
                       "--out " + out + ": " + command + " writes .obj or .off files");
  }
  return ext == ".obj";
}

void run_repair(const RepairArgs& args) {
  const bool obj = mesh_output_is_obj(args.out, "repair");
  MeshSoup soup = load_mesh_soup(args.mesh);
  MeshRepairOptions options;
  options.orient = !args.no_orient;
  const RepairedMesh repaired = repair_mesh(soup.positions, soup.faces, options);
  // The result must load: anything else is a bug of repair_mesh, not of the input.
  std::optional<TriangleMesh> mesh;
  try {
    mesh.emplace(repaired.positions, repaired.faces);
  } catch (const MeshError& e) {
    throw InternalError(std::string("the repaired mesh does not load: ") + e.what());
  }
  const MeshRepairReport& r = repaired.report;
  const MeshReport after = compute_mesh_report(*mesh, IntrinsicGeometry(*mesh));
  std::string text;
  auto line = [&text](const char* label, const std::string& value) {
    char head[40];
    std::snprintf(head, sizeof head, "%24s: ", label);
    text += head + value + '\n';
  };
  auto count = [](std::size_t n) { return std::to_string(n); };
  line("input", count(r.vertices_in) + " vertices, " + count(r.faces_in) + " faces");
  line("degenerate faces dropped", count(r.degenerate_faces_dropped));
  line("duplicate faces dropped", count(r.duplicate_faces_dropped));
  line("edges cut", count(r.edges_cut));
  line("faces flipped", count(r.faces_flipped));
  line("vertices split", count(r.vertices_split));
  line("vertices added", count(r.vertices_added) + " (one copy per extra fan, appended)");
  line("output", count(r.vertices_out) + " vertices, " + count(r.faces_out) + " faces, " +
                     count(after.components) + " components, " + count(after.boundary_loops) +
                     " boundary loops");
  write_file_atomically(args.out, format_mesh(repaired.positions, repaired.faces, obj,
                                             "geoprox repair of " + args.mesh));
  if (!args.map.empty()) {
    write_file_atomically(args.map, format_repair_map(repaired, args.mesh, args.out));
  }
  write_output(text, "");
}

std::string format_refine_map(const RefinedMesh& refined, const std::string& source,
                              const std::string& out) {
  std::string text = "# geoprox refine map: " + source + " -> " + out + "\n";
  text += "# v NEW POINT: a vertex added at POINT of the input (vertices below " +
          std::to_string(refined.input_vertices) + " keep their ids)\n";
  for (std::size_t k = 0; k < refined.new_vertex_source.size(); ++k) {
    text += "v " + std::to_string(refined.input_vertices + k) + ' ' +
            refined.new_vertex_source[k].to_string() + '\n';
  }
  text += "# f NEW OLD B0 B1 B2: a part of input face OLD, its corners at barycentrics B0, B1, B2\n"
          "# of OLD (three numbers each); faces not listed are input faces with their ids\n";
  const std::array<RefinedMesh::Bary, 3> whole{RefinedMesh::Bary{1, 0, 0},
                                               RefinedMesh::Bary{0, 1, 0},
                                               RefinedMesh::Bary{0, 0, 1}};
  for (std::size_t f = 0; f < refined.faces.size(); ++f) {
    if (f < refined.input_faces && refined.source_bary[f] == whole) continue;
    text += "f " + std::to_string(f) + ' ' + std::to_string(refined.source_face[f]);
    for (const RefinedMesh::Bary& b : refined.source_bary[f]) {
      for (double x : b) {
        text += ' ';
        append_number(text, x);
      }
    }
    text += '\n';
  }
  return text;
}

void run_refine(const RefineArgs& args) {
  const bool obj = mesh_output_is_obj(args.out, "refine");
  const TriangleMesh input = load_command_mesh(args.mesh, args.repair).mesh;
  // By default the refinement a graph build makes (core/graph/refined_surface.h): edges of at
  // most half the link radius of a default graph of the output.
  GraphRefinement refinement = refine_for_graph(input, {}, args.max_edge);
  RefinedMesh& refined = refinement.refined;
  const double max_edge = refinement.max_edge_length;
  // The refined mesh must load: anything else is a bug of refine_long_edges, not of the input.
  std::optional<TriangleMesh> mesh;
  try {
    mesh.emplace(refined.positions, refined.faces);
  } catch (const MeshError& e) {
    throw InternalError(std::string("the refined mesh does not load: ") + e.what());
  }
  std::string why;
  if (args.max_edge == 0) {
    char buf[96];
    std::snprintf(buf, sizeof buf, " (half the link radius %.6g of a default graph of the output)",
                  refinement.link_radius);
    why = buf;
  }
  std::size_t faces_split = 0;
  std::vector<std::uint8_t> split(refined.input_faces, 0);
  for (std::size_t f = refined.input_faces; f < refined.faces.size(); ++f) {
    split[refined.source_face[f]] = 1;
  }
  for (std::uint8_t s : split) faces_split += s;
  auto longest = [](const TriangleMesh& m) {
    double l = 0;
    for (std::uint32_t e = 0; e < m.num_edges(); ++e) {
      l = std::max(l, norm(m.position(m.edge_origin(e)) - m.position(m.edge_target(e))));
    }
    return l;
  };
  std::string text;
  char buf[256];
  auto add = [&](const char* fmt, auto... values) {
    std::snprintf(buf, sizeof buf, fmt, values...);
    text += buf;
  };
  add("%24s: %zu vertices, %zu faces, longest edge %.6g\n", "input", input.num_vertices(),
      input.num_faces(), longest(input));
  add("%24s: %.6g%s\n", "longest edge allowed", max_edge, why.c_str());
  add("%24s: %zu of %zu (%zu edges halved in %zu rounds)\n", "faces split", faces_split,
      input.num_faces(), refined.edges_split, refined.rounds);
  add("%24s: %zu vertices, %zu faces, longest edge %.6g\n", "output", mesh->num_vertices(),
      mesh->num_faces(), longest(*mesh));
  write_file_atomically(args.out, format_mesh(refined.positions, refined.faces, obj,
                                              "geoprox refine of " + args.mesh));
  if (!args.map.empty()) {
    write_file_atomically(args.map, format_refine_map(refined, args.mesh, args.out));
  }
  write_output(text, "");
}

/// MESH and -o/--out of the commands that write a changed copy of a mesh.
void add_mesh_copy_options(CLI::App& command, const std::string& mesh_help,
                           const std::string& what, std::string& mesh, std::string& out) {
  command.add_option("MESH", mesh, mesh_help)->required();
  command.add_option("-o,--out", out, "The " + what + " mesh (.obj or .off), written atomically")
      ->required();
}

}  // namespace

void add_offline_commands(CLI::App& app, std::vector<Command>& commands) {
  const std::string mesh_help =
      "Triangle mesh file: OBJ, OFF, PLY (ascii or binary) or STL; ids are file order";

  auto info_args = std::make_shared<InfoArgs>();
  CLI::App* info = app.add_subcommand("info", "Print the validation report of a mesh");
  info->add_option("MESH", info_args->mesh, mesh_help)->required();
  add_repair_flag(*info, info_args->repair);
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
  add_repair_flag(*exact, exact_args->repair);
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
  auto repair_args = std::make_shared<RepairArgs>();
  CLI::App* repair = app.add_subcommand(
      "repair", "Write a copy of a non-manifold or badly oriented mesh that geoprox loads");
  add_mesh_copy_options(*repair, mesh_help, "repaired", repair_args->mesh, repair_args->out);
  repair->add_option("--map", repair_args->map,
                     "Also write which input vertex each added vertex copies, and each face's "
                     "input id and whether it was turned round");
  repair->add_flag("--no-orient", repair_args->no_orient,
                   "Turn no face round: cut the mesh where two faces disagree instead");
  repair->footer(
      "What changes, in this order (docs/meshes.md): faces that repeat a vertex and faces over\n"
      "the same three vertices as an earlier face are dropped; edges with three or more faces\n"
      "are cut open; faces are turned round to orient each sheet consistently, turning the\n"
      "fewer (an edge no orientation fixes, as on a Moebius strip, is cut); a vertex whose\n"
      "faces form several fans gets a copy per extra fan. Vertex ids are kept (copies are\n"
      "appended), faces keep their order less those dropped, and positions are copied bit\n"
      "for bit. The counts are printed on standard output.\n\n" +
      exit_code_footer());
  commands.push_back({repair, [repair_args] { run_repair(*repair_args); }});

  auto refine_args = std::make_shared<RefineArgs>();
  CLI::App* refine = app.add_subcommand(
      "refine", "Write a copy of a mesh whose long faces are split (the same surface)");
  add_mesh_copy_options(*refine, mesh_help, "refined", refine_args->mesh, refine_args->out);
  refine
      ->add_option("--max-edge", refine_args->max_edge,
                   "Longest edge allowed (mesh units); default: half the link radius of a "
                   "default graph of the output (Table 1 samples for its face count)")
      ->check(CLI::PositiveNumber);
  refine->add_option("--map", refine_args->map,
                     "Also write where each added vertex lies on MESH, and each split face's "
                     "parts with their corners' barycentrics");
  add_repair_flag(*refine, refine_args->repair);
  refine->footer(
      "Longest-edge bisection (docs/meshes.md): every edge longer than the limit is halved,\n"
      "with the longest side of each face it touches, round after round until none is\n"
      "longer; faces are split only there and where conformity needs it. New vertices are\n"
      "midpoints of edges, so the surface is the same. Vertex ids are kept (new ones are\n"
      "appended), as are the ids of faces not split; a split face's first part keeps its\n"
      "id, the others are appended. For meshes whose long faces leave points far from every\n"
      "sample of a graph, which 'geoprox build' warns about.\n\n" +
      exit_code_footer());
  commands.push_back({refine, [refine_args] { run_refine(*refine_args); }});


  commands.push_back({exact, [exact_args, exact] {
                        exact_args->out_given = exact->count("--out") > 0;
                        exact_args->to_given = exact->count("--to") > 0;
                        run_exact(*exact_args);
                      }});
}

}  // namespace geoprox::cli
