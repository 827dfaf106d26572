// `geoprox build` and `geoprox inspect`: proximity-graph files, calling core directly.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include "clients/cli/cli.h"
#include "core/base/errors.h"
#include "core/graph/graph_file.h"
#include "core/graph/loaded_graph.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh_io.h"
#include "core/graph/proximity_graph.h"
#include "core/graph/refined_surface.h"

namespace geoprox::cli {

namespace {

struct BuildArgs {
  std::string mesh;
  std::string out;
  std::uint32_t samples = 0;
  std::uint32_t neighbors = 0;
  std::uint32_t link_samples = 0;
  std::uint32_t candidate_vertices = 0;  ///< 0: every vertex may be a sample
  double target_error = 0;  ///< 0: not given
  int threads = 0;
  std::string sampling = "auto";
  std::string export_text;
  std::string metric;  ///< Riemannian metric side file; empty: the mesh's own lengths
  bool no_refine = false;  ///< --no-refine: keep the first build even if it leaves gaps
  bool quiet = false;
  bool repair = false;  ///< build on the repaired mesh (core/mesh/mesh_repair.h)
};

struct InspectArgs {
  std::string file;
  std::string verify_mesh;
  std::string metric;
  bool verify_given = false;
  bool repair = false;  ///< verify against the repaired mesh
};

const char* sampling_name(SamplingMethod m) {
  switch (m) {
    case SamplingMethod::Automatic:
      return "auto";
    case SamplingMethod::FastMarching:
      return "fmm";
    case SamplingMethod::Exact:
      return "exact";
  }
  return "?";
}

std::string human_bytes(double bytes) {
  char buf[64];
  if (bytes >= 1 << 20) {
    std::snprintf(buf, sizeof buf, "%.2f MiB", bytes / (1 << 20));
  } else {
    std::snprintf(buf, sizeof buf, "%.1f KiB", bytes / 1024);
  }
  return buf;
}

// Progress on stderr, redrawn in place: phase, percent, elapsed, ETA. Silent unless stderr is a
// terminal, so logs and pipes stay clean.
class ProgressLine {
 public:
  explicit ProgressLine(bool enabled) : enabled_(enabled && isatty(STDERR_FILENO) != 0) {}
  ~ProgressLine() { finish(); }
  void update(const std::string& phase, double fraction) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    if (phase != phase_) {
      phase_ = phase;
      phase_start_ = now;
    }
    const double elapsed = std::chrono::duration<double>(now - phase_start_).count();
    const double eta = fraction > 0.01 ? elapsed * (1 - fraction) / fraction : -1;
    char buf[160];
    if (eta >= 0) {
      std::snprintf(buf, sizeof buf, "\r%-14s %5.1f%%  elapsed %6.1fs  eta %6.1fs ", phase.c_str(),
                    100 * fraction, elapsed, eta);
    } else {
      std::snprintf(buf, sizeof buf, "\r%-14s %5.1f%%  elapsed %6.1fs             ",
                    phase.c_str(), 100 * fraction, elapsed);
    }
    std::fputs(buf, stderr);
    drawn_ = true;
  }
  void finish() {
    if (drawn_) std::fputs("\n", stderr);
    drawn_ = false;
  }

 private:
  bool enabled_;
  bool drawn_ = false;
  std::string phase_;
  std::chrono::steady_clock::time_point phase_start_;
};

void run_build(const BuildArgs& args) {
  ProximityGraphOptions options;
  options.num_samples = args.samples;
  options.neighbors = args.neighbors;
  options.candidate_vertices = args.candidate_vertices;
  options.link_samples = args.link_samples;
  options.threads = args.threads;
  options.refine_long_faces = !args.no_refine;
  if (args.sampling == "fmm") {
    options.sampling = SamplingMethod::FastMarching;
  } else if (args.sampling == "exact") {
    options.sampling = SamplingMethod::Exact;
  } else {
    options.sampling = SamplingMethod::Automatic;
  }
  const auto start = std::chrono::steady_clock::now();
  const std::shared_ptr<const MeshData> data =
      load_command_mesh_data(args.mesh, args.metric, args.repair);
  const TriangleMesh& mesh = data->mesh;
  const IntrinsicGeometry& geometry = data->geometry;
  std::optional<GraphSizeForError> for_error;
  if (args.target_error != 0) {
    for_error = graph_size_for_error(mesh.num_faces(), args.target_error);
    if (options.num_samples == 0) options.num_samples = for_error->num_samples;
    options.neighbors = for_error->neighbors;
  }
  const double load_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  ProximityGraph graph;
  {
    ProgressLine progress(!args.quiet);
    graph = build_proximity_graph(mesh, geometry, options,
                                  [&](const std::string& phase, double fraction) {
                                    progress.update(phase, fraction);
                                  });
  }
  const auto write_start = std::chrono::steady_clock::now();
  GraphFileMetadata metadata;
  // Says, in `geoprox inspect`, that queries must load the mesh with --repair too.
  metadata.source_mesh = args.repair ? args.mesh + " (repaired)" : args.mesh;
  write_graph_file(args.out, mesh, geometry, graph, metadata);
  if (!args.export_text.empty()) {
    std::ostringstream text;
    // The text format names samples by position: those of the mesh the graph is over.
    export_paper_text(text, graph.refined ? graph.refined->mesh() : mesh,
                      graph.refined ? graph.refined->geometry() : geometry, graph.view());
    write_file_atomically(args.export_text, text.str());
  }
  const double write_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - write_start).count();
  const double total =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const ProximityGraphView view = graph.view();
  std::string out;
  char line[512];
  auto add = [&](const char* fmt, auto... values) {
    std::snprintf(line, sizeof line, fmt, values...);
    out += line;
  };
  add("mesh            %s (%zu vertices, %zu faces)\n", args.mesh.c_str(), mesh.num_vertices(),
      mesh.num_faces());
  if (data->repair) add("repair          %s\n", describe_repair_changes(*data->repair).c_str());
  if (!args.metric.empty()) add("metric          %s\n", args.metric.c_str());
  add("samples         %u (m_P %u, sampling %s; %zu at corners)\n", view.num_samples,
      view.neighbors, sampling_name(graph.stats.sampling_used), graph.stats.corner_samples);
  add("graph edges     %zu (directed, symmetric)\n", view.num_edges());
  add("cover entries   %zu\n", view.cover_sample.size());
  add("R longest edge  %.6g\n", view.longest_edge);
  add("r covering      %.6g (vertices %.6g; farthest %s)\n", view.covering_radius,
      graph.stats.vertex_covering_radius, graph.stats.largest_empty_disk.to_string().c_str());
  add("link radius     %.6g\n", view.link_radius);
  if (graph.refined) {
    const TriangleMesh& refined = graph.refined->mesh();
    add("refined         to %zu vertices, %zu faces (edges <= %.6g): the first pass left "
        "points %.6g from every sample, over half its link radius %.6g (%zu faces, %.3g%% of "
        "the area, beyond it); queries, fields and paths stay in the mesh's ids\n",
        refined.num_vertices(), refined.num_faces(), graph.refined->max_edge_length(),
        graph.stats.unrefined_covering_radius, graph.stats.unrefined_link_radius,
        graph.stats.unrefined_faces_beyond_link,
        100 * graph.stats.unrefined_area_fraction_beyond_link);
  }
  add("error bound     %.4g (Theorem 4.2: 2r / (rho - 2r))\n", view.error_bound());
  if (for_error) {
    add("predicted error mean %.3g%%, p99 %.3g%% (target %.3g%%; docs/accuracy.md)\n",
        100 * for_error->predicted_mean, 100 * for_error->predicted_p99, 100 * args.target_error);
  }
  add("time load       %.3f s\n", load_seconds);
  if (graph.refined) {
    add("time first      %.3f s (sampling and r on the mesh as given)\n",
        graph.stats.unrefined_build_seconds);
    add("time refining   %.3f s\n", graph.stats.refinement_seconds);
  }
  add("time sampling   %.3f s\n", graph.stats.sampling_seconds);
  add("time local      %.3f s\n", graph.stats.local_solve_seconds);
  add("time covering   %.3f s\n", graph.stats.covering_seconds);
  add("time write      %.3f s\n", write_seconds);
  add("time total      %.3f s\n", total);
  add("file            %s (%s)\n", args.out.c_str(),
      human_bytes(static_cast<double>(std::filesystem::file_size(args.out))).c_str());
  write_output(out, "");
  if (const std::string warning = sparse_sampling_warning(view, &graph.stats); !warning.empty()) {
    std::fprintf(stderr, "geoprox: warning: %s\n", warning.c_str());
  }
}

void run_inspect(const InspectArgs& args) {
  const auto start = std::chrono::steady_clock::now();
  const MappedGraphFile file = MappedGraphFile::open(args.file);
  const double open_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  const GraphFileParams params = file.params();
  const GraphFileCounts counts = file.counts();
  const ProximityGraphView view = file.view();
  std::string out;
  char line[512];
  auto add = [&](const char* fmt, auto... values) {
    std::snprintf(line, sizeof line, fmt, values...);
    out += line;
  };
  add("file            %s (%s, format version %u)\n", args.file.c_str(),
      human_bytes(static_cast<double>(file.file_size())).c_str(), file.format_version());
  add("source mesh     %s\n", std::string(file.source_mesh()).c_str());
  if (const auto from = file.refined_from()) {
    add("mesh            %llu vertices, %llu faces, %llu edges (queries are given in its ids)\n",
        static_cast<unsigned long long>(from->vertices),
        static_cast<unsigned long long>(from->faces),
        static_cast<unsigned long long>(from->edges));
    add("refined         to %llu vertices, %llu faces, %llu edges (edges <= %.6g), which the "
        "graph is over\n",
        static_cast<unsigned long long>(counts.vertices),
        static_cast<unsigned long long>(counts.faces),
        static_cast<unsigned long long>(counts.edges), from->max_edge_length);
  } else {
    add("mesh            %llu vertices, %llu faces, %llu edges\n",
        static_cast<unsigned long long>(counts.vertices),
        static_cast<unsigned long long>(counts.faces),
        static_cast<unsigned long long>(counts.edges));
  }
  add("fingerprint     %016llx\n", static_cast<unsigned long long>(file.fingerprint()));
  add("checksum        %016llx (verified)\n", static_cast<unsigned long long>(file.checksum()));
  add("samples         %u (m_P %u, sampling %s)\n", params.num_samples, params.neighbors,
      sampling_name(params.sampling));
  add("graph edges     %llu\n", static_cast<unsigned long long>(counts.graph_edges));
  add("cover entries   %llu\n", static_cast<unsigned long long>(counts.covers));
  add("R longest edge  %.6g\n", file.longest_edge());
  add("r covering      %.6g\n", file.covering_radius());
  add("link radius     %.6g\n", file.link_radius());
  add("error bound     %.4g (Theorem 4.2: 2r / (rho - 2r))\n", view.error_bound());
  std::size_t min_degree = SIZE_MAX, max_degree = 0;
  for (std::uint32_t i = 0; i < view.num_samples; ++i) {
    const std::size_t degree = view.edge_offsets[i + 1] - view.edge_offsets[i];
    min_degree = std::min(min_degree, degree);
    max_degree = std::max(max_degree, degree);
  }
  add("degree          min %zu, mean %.2f, max %zu\n", min_degree,
      view.num_samples ? static_cast<double>(view.num_edges()) / view.num_samples : 0.0,
      max_degree);
  add("open time       %.2f ms\n", open_ms);
  if (args.verify_given) {
    const std::shared_ptr<const MeshData> data =
        load_command_mesh_data(args.verify_mesh, args.metric, args.repair);
    file.verify_mesh(data->mesh, data->geometry);
    add("verify          %s%s matches%s%s\n", args.verify_mesh.c_str(),
        args.repair ? " (repaired)" : "", args.metric.empty() ? "" : " under the metric ",
        args.metric.c_str());
  }
  write_output(out, "");
  if (const std::string warning = sparse_sampling_warning(view); !warning.empty()) {
    std::fprintf(stderr, "geoprox: warning: %s\n", warning.c_str());
  }
}

}  // namespace

void add_graph_commands(CLI::App& app, std::vector<Command>& commands) {
  auto build_args = std::make_shared<BuildArgs>();
  CLI::App* build = app.add_subcommand(
      "build", "Build a proximity graph file for MESH (farthest-point samples + exact local "
               "geodesics); progress on stderr when it is a terminal.");
  build->add_option("mesh", build_args->mesh, "mesh file (OBJ, OFF, PLY, STL)")->required();
  build->add_option("-o,--out", build_args->out, "graph file to write (atomically)")->required();
  build->add_option("--samples", build_args->samples,
                    "n_P samples (default: the paper's Table 1 for the face count)");
  build->add_option("--neighbors", build_args->neighbors,
                    "m_P nearest samples linked to each (default: Table 1)");
  build->add_option("--candidate-vertices", build_args->candidate_vertices,
                    "only vertices with an id below N may be samples (default: all); e.g. the "
                    "original vertices of a mesh refined by scripts/subdivide_mesh.py");
  build->add_option("--target-error", build_args->target_error,
                    "mean relative error wanted (e.g. 0.005 for 0.5%): picks m_P, and n_P unless "
                    "--samples is given, from the measured relationship in docs/accuracy.md; "
                    "prints the predicted error")
      ->excludes("--neighbors");
  build->add_option("--link-samples", build_args->link_samples,
                    "m_st: samples a query point is linked to on average; sets the link radius "
                    "(default: 2 m_P)");
  build->add_option("--threads", build_args->threads, "OpenMP threads (default: all cores)");
  build->add_option("--sampling", build_args->sampling,
                    "fmm, exact or auto (exact when the mesh quality is poor)")
      ->check(CLI::IsMember({"auto", "fmm", "exact"}));
  build->add_option("--export-text", build_args->export_text,
                    "also write the paper's text format (§2.2) to this file");
  build->add_option("--metric", build_args->metric,
                    "Riemannian metric side file (docs/metrics.md): the graph is built on its "
                    "edge lengths and is then valid only with the same metric");
  build->add_flag("--no-refine", build_args->no_refine,
                  "keep the graph on the mesh as given even where its faces are longer than the "
                  "samples' spacing (by default the build then refines the mesh internally, "
                  "answering in the mesh's own ids; docs/queries.md)");
  build->add_flag("-q,--quiet", build_args->quiet, "no progress display");
  add_repair_flag(*build, build_args->repair);
  commands.push_back({build, [build_args] { run_build(*build_args); }});

  auto inspect_args = std::make_shared<InspectArgs>();
  CLI::App* inspect = app.add_subcommand(
      "inspect", "Print the header and statistics of a graph file; --verify MESH checks that it "
                 "was built for that mesh.");
  inspect->add_option("file", inspect_args->file, "graph file")->required();
  inspect->add_option("--verify", inspect_args->verify_mesh, "mesh file to check against")
      ->each([inspect_args](const std::string&) { inspect_args->verify_given = true; });
  inspect->add_option("--metric", inspect_args->metric,
                      "with --verify: the Riemannian metric the graph was built with")
      ->needs("--verify");
  inspect
      ->add_flag("--repair", inspect_args->repair,
                 "with --verify: check against the mesh repaired, as 'geoprox build --repair' "
                 "built it")
      ->needs("--verify");
  commands.push_back({inspect, [inspect_args] { run_inspect(*inspect_args); }});
}

}  // namespace geoprox::cli
