// Benchmark of the exact geodesic solver (issue 2, section 6). Not a test: it only measures.
//
//   exact_geodesic_bench MESH... [--runs N] [--sources K] [--samples S] [--nearest K]
//                                [--local-solves M] [--seed X] [--disks-out DIR]
//
// For each mesh:
//  - full: a single-source solve over the whole surface from K deterministic random vertices,
//    N timed runs each (after one warm-up run); the median over all K*N runs is reported, with
//    the windows created by one solve (median over the sources);
//  - one-shot: N solves from the first source, each by a new solver (its buffers allocated and
//    grown by that solve, as in `geoprox exact`), median;
//  - bounded: the paper's local solve. S samples spread over the surface (the first S vertices of
//    a deterministic random permutation, a stand-in for farthest-point samples) are the targets;
//    from M of those samples a solve runs with stop_after_targets = 36 (the 36 nearest samples,
//    the source itself included), as the graph builder runs them: the samples prepared once as
//    a GeodesicTargets, halfedges queued (the solver's choice for such solves); the median
//    time (two rounds of M solves) and the median radius reached are reported, and on the
//    details line the median of the same solves with one queue entry per window (two rounds,
//    alternated with the others), and of radius solves over the same disks (from each source
//    out to the radius its bounded solve reached: what the reference solvers time, below);
//  - with --disks-out DIR: DIR/MESH.disks lists those disks, one `source_vertex radius` line per
//    bounded solve, for the reference solvers' drivers (bench/reference/README.md) to solve the
//    same disks;
//  - peak RSS: VmHWM of /proc/self/status, reset per mesh through /proc/self/clear_refs.
// Otherwise one solver object per mesh is reused for every solve, as the daemon does. Single
// thread.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <numeric>
#include <string>
#include <vector>

#include "bench/bench_support.h"
#include "core/geodesic/window_propagation.h"
#include "core/base/errors.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/mesh_io.h"

namespace {

using namespace geoprox;
using namespace geoprox::bench;

struct Settings {
  int runs = 5;
  int sources = 5;
  std::size_t samples = 5000;
  std::size_t nearest = 36;
  int local_solves = 200;
  std::uint64_t seed = 2024;
  std::string disks_out;  ///< directory for MESH.disks; empty: none written
};

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr,
               "exact_geodesic_bench: %s\n"
               "usage: exact_geodesic_bench MESH... [--runs N] [--sources K] [--samples S]\n"
               "                            [--nearest K] [--local-solves M] [--seed X]\n"
               "                            [--disks-out DIR]\n",
               why);
  std::exit(2);
}

long parse_count(const char* flag, const char* text) {
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (*end != 0 || value <= 0) {
    std::fprintf(stderr, "exact_geodesic_bench: %s needs a positive integer, got '%s'\n", flag,
                 text);
    std::exit(2);
  }
  return value;
}

/// Prints the mesh's table row; returns a line of details for after the table.
std::string bench_mesh(const std::string& path, const Settings& s) {
  reset_peak_rss();
  const auto load_start = Clock::now();
  TriangleMesh mesh = load_mesh(path);
  IntrinsicGeometry geometry(mesh);
  const double load_ms = ms_since(load_start);
  // The engine behind ExactGeodesicSolver, so that both queue strategies can be timed.
  detail::WindowPropagation solver(mesh, geometry);
  const auto nv = static_cast<std::uint32_t>(mesh.num_vertices());

  // Full solves.
  Rng rng{s.seed};
  std::vector<double> full_ms, windows, one_shot_ms;
  std::size_t reached = 0;
  for (int k = 0; k < s.sources; ++k) {
    std::uint32_t v;
    do {
      v = rng.below(nv);
    } while (mesh.is_isolated_vertex(v));
    const SurfacePoint source = SurfacePoint::vertex(v);
    if (k == 0) {
      // One-shot (what `geoprox exact` does): a new solver, its buffers grown by this solve.
      for (int r = 0; r < s.runs; ++r) {
        const auto start = Clock::now();
        ExactGeodesicSolver fresh(mesh, geometry);
        fresh.solve(source);
        one_shot_ms.push_back(ms_since(start));
      }
    }
    solver.solve(source);  // warm-up
    for (int r = 0; r < s.runs; ++r) {
      const auto start = Clock::now();
      solver.solve(source);
      full_ms.push_back(ms_since(start));
    }
    windows.push_back(static_cast<double>(solver.stats().windows_created));
    std::size_t finite = 0;
    for (double d : solver.vertex_distances()) finite += d < kInfinity ? 1 : 0;
    reached = std::max(reached, finite);
  }

  // Bounded local solves to the `nearest` nearest of `samples` spread samples.
  std::vector<std::uint32_t> order;
  for (std::uint32_t v = 0; v < nv; ++v) {
    if (!mesh.is_isolated_vertex(v)) order.push_back(v);
  }
  Rng shuffle{s.seed ^ 0x5EEDull};
  for (std::size_t i = order.size(); i > 1; --i)
    std::swap(order[i - 1], order[shuffle.below(static_cast<std::uint32_t>(i))]);
  order.resize(std::min(order.size(), s.samples));
  std::vector<SurfacePoint> targets;
  for (std::uint32_t v : order) targets.push_back(SurfacePoint::vertex(v));
  // Prepared once, as the graph builder does: every local solve waits for the same samples.
  const GeodesicTargets prepared(geometry, targets);
  ExactGeodesicSolver::Options opt;
  opt.stop_after_targets = std::min(s.nearest, targets.size());
  std::vector<double> local_ms, per_window_ms, radius, local_windows;
  // The k-th bounded solve starts from the k-th sample.
  auto source_vertex = [&](int k) { return order[static_cast<std::size_t>(k) % order.size()]; };
  auto source_of = [&](int k) {
    return std::vector<GeodesicSource>{{SurfacePoint::vertex(source_vertex(k)), 0.0}};
  };
  // Two rounds of each kind, alternated; a round solves from every one of the M samples (a
  // solve repeated at once from the same source would find its disk in cache).
  for (int round = 0; round < 4; ++round) {
    const bool queued = round % 2 == 0;
    for (int k = 0; k < s.local_solves; ++k) {
      const std::vector<GeodesicSource> source = source_of(k);
      const auto start = Clock::now();
      solver.force_queue_strategy(queued);
      solver.solve(source, prepared, opt);
      (queued ? local_ms : per_window_ms).push_back(ms_since(start));
      if (round == 0) {
        radius.push_back(solver.radius_reached());
        local_windows.push_back(static_cast<double>(solver.stats().windows_created));
      }
    }
  }
  // The same disks by radius: the stop the reference solvers offer.
  std::vector<double> radius_ms;
  ExactGeodesicSolver::Options by_radius;
  solver.force_queue_strategy(std::nullopt);
  for (int round = 0; round < 2; ++round) {
    for (int k = 0; k < s.local_solves; ++k) {
      const std::vector<GeodesicSource> source = source_of(k);
      by_radius.max_distance = radius[static_cast<std::size_t>(k)];
      const auto start = Clock::now();
      solver.solve(source, {}, by_radius);
      radius_ms.push_back(ms_since(start));
    }
  }
  if (!s.disks_out.empty()) {
    const std::string disks_path = s.disks_out + "/" + base_name(path) + ".disks";
    std::string text;
    char line[64];
    for (int k = 0; k < s.local_solves; ++k) {
      std::snprintf(line, sizeof line, "%u %.17g\n", source_vertex(k),
                    radius[static_cast<std::size_t>(k)]);
      text += line;
    }
    write_atomically(disks_path, text);
  }

  std::printf("| %s | %zu | %.1f | %.1f | %.0f | %.3f | %.4g (%.2f edges) | %.0f | %.0f |\n",
              base_name(path).c_str(), mesh.num_faces(), median(full_ms), median(one_shot_ms),
              median(windows), median(local_ms),
              median(radius), median(radius) / geometry.mean_edge_length(), median(local_windows),
              peak_rss_mib());
  std::fflush(stdout);
  char details[640];
  std::snprintf(
      details, sizeof details,
      "- %s: load+geometry %.0f ms; full solve min %.1f / max %.1f ms over %zu runs, %zu of %u "
      "vertices reached; local solves: %zu targets, stop after %zu, min %.3f / max %.3f ms; "
      "with one queue entry per window: median %.3f ms; radius solves over the same disks: "
      "median %.3f ms",
      base_name(path).c_str(), load_ms, *std::min_element(full_ms.begin(), full_ms.end()),
      *std::max_element(full_ms.begin(), full_ms.end()), full_ms.size(), reached, nv,
      targets.size(), opt.stop_after_targets, *std::min_element(local_ms.begin(), local_ms.end()),
      *std::max_element(local_ms.begin(), local_ms.end()), median(per_window_ms),
      median(radius_ms));
  return details;
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  std::vector<std::string> meshes;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> const char* {
      if (i + 1 >= argc) usage((a + " needs a value").c_str());
      return argv[++i];
    };
    if (a == "--runs") {
      s.runs = static_cast<int>(parse_count("--runs", value()));
    } else if (a == "--sources") {
      s.sources = static_cast<int>(parse_count("--sources", value()));
    } else if (a == "--samples") {
      s.samples = static_cast<std::size_t>(parse_count("--samples", value()));
    } else if (a == "--nearest") {
      s.nearest = static_cast<std::size_t>(parse_count("--nearest", value()));
    } else if (a == "--local-solves") {
      s.local_solves = static_cast<int>(parse_count("--local-solves", value()));
    } else if (a == "--disks-out") {
      s.disks_out = value();
    } else if (a == "--seed") {
      s.seed = static_cast<std::uint64_t>(parse_count("--seed", value()));
    } else if (a == "-h" || a == "--help") {
      usage("benchmark of the exact geodesic solver");
    } else if (!a.empty() && a[0] == '-') {
      usage(("unknown option " + a).c_str());
    } else {
      meshes.push_back(a);
    }
  }
  if (meshes.empty()) usage("no mesh given");
  std::printf("runs %d x %d sources (full); %d local solves to the %zu nearest of %zu samples\n",
              s.runs, s.sources, s.local_solves, s.nearest, s.samples);
  std::printf("| mesh | faces | full median ms | one-shot median ms | windows created | "
              "bounded median ms | radius reached | bounded windows | peak RSS MiB |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  int failures = 0;
  std::vector<std::string> details;
  for (const std::string& path : meshes) {
    try {
      details.push_back(bench_mesh(path, s));
    } catch (const std::exception& e) {
      std::printf("| %s | error: %s |\n", base_name(path).c_str(), e.what());
      std::fflush(stdout);
      ++failures;
    }
  }
  std::printf("\n");
  for (const std::string& d : details) std::printf("%s\n", d.c_str());
  return failures ? 1 : 0;
}
