// Benchmark of fast marching (core/geodesic/fast_marching.h, issue 3 section 1). Not a test: it measures.
//
//   fast_marching_bench MESH... [--runs N] [--sources K] [--fps N] [--accuracy K] [--seed X]
//
// For each mesh (one solver object reused throughout, single thread):
//  - full: a whole-surface solve from K deterministic random vertices, N timed runs each after
//    one warm-up; the median wall time is reported, and in parentheses the median CPU time of the
//    thread (the two differ when other processes share the cores);
//  - fps: N rounds of farthest-point sampling from distances = inf: lower() from the current
//    farthest vertex (the argmax scan is not timed); total time of the N lower() calls and the
//    mean number of vertices each lowered. Then the same N sources again, comparing every
//    lower() with min(distances, fresh solve): vertices that differ and the largest difference
//    relative to the covering radius;
//  - accuracy (--accuracy K, 0 to skip): from K random vertices, the relative error
//    |fmm - exact| / exact against ExactGeodesicSolver over every vertex with exact > 0: mean
//    and max; "far" max is over vertices at least 10 mean edge lengths from the source (near
//    the source the relative error of a first-order scheme is largest). With the default
//    unfolding, and without (max_unfold_steps = 0) for comparison.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include "bench/bench_support.h"
#include "core/geodesic/exact_geodesic.h"
#include "core/geodesic/fast_marching.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/mesh_io.h"

namespace {

using namespace geoprox;
using namespace geoprox::bench;

struct Settings {
  int runs = 5;
  int sources = 5;
  int fps = 100;
  int accuracy = 5;
  std::uint64_t seed = 2024;
};

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr,
               "fast_marching_bench: %s\n"
               "usage: fast_marching_bench MESH... [--runs N] [--sources K] [--fps N]\n"
               "                           [--accuracy K] [--seed X]\n",
               why);
  std::exit(2);
}

long parse_count(const char* flag, const char* text, bool allow_zero) {
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (*end != 0 || value < 0 || (value == 0 && !allow_zero)) {
    std::fprintf(stderr, "fast_marching_bench: %s needs a %s integer, got '%s'\n", flag,
                 allow_zero ? "non-negative" : "positive", text);
    std::exit(2);
  }
  return value;
}

std::uint32_t random_vertex(const TriangleMesh& mesh, Rng& rng) {
  std::uint32_t v;
  do {
    v = rng.below(static_cast<std::uint32_t>(mesh.num_vertices()));
  } while (mesh.is_isolated_vertex(v));
  return v;
}

std::uint32_t argmax(const std::vector<double>& d) {
  std::uint32_t best = 0;
  for (std::uint32_t v = 1; v < d.size(); ++v) {
    // Unreached vertices (other components) are infinite: skip them once one is finite.
    if (d[v] < kInfinity && (d[best] == kInfinity || d[v] > d[best])) best = v;
  }
  return best;
}

struct Accuracy {
  double mean = 0, max = 0, far_max = 0;
};

void bench_mesh(const std::string& path, const Settings& s, std::vector<std::string>& notes) {
  const auto load_start = Clock::now();
  TriangleMesh mesh = load_mesh(path);
  IntrinsicGeometry geometry(mesh);
  const double load_ms = ms_since(load_start);
  FastMarchingSolver solver(mesh, geometry);
  const auto nv = static_cast<std::uint32_t>(mesh.num_vertices());
  const std::string name = base_name(path);

  // Full solves.
  Rng rng{s.seed};
  std::vector<double> full_ms, full_cpu_ms;
  std::size_t pushes = 0, settled = 0;
  for (int k = 0; k < s.sources; ++k) {
    const SurfacePoint source = SurfacePoint::vertex(random_vertex(mesh, rng));
    solver.solve(source);  // warm-up (and the splitting table on the first call)
    for (int r = 0; r < s.runs; ++r) {
      const auto start = Clock::now();
      const double cpu_start = thread_cpu_ms();
      solver.solve(source);
      full_cpu_ms.push_back(thread_cpu_ms() - cpu_start);
      full_ms.push_back(ms_since(start));
    }
    pushes = solver.stats().heap_pushes;
    settled = solver.stats().vertices_settled;
  }
  const std::size_t obtuse = solver.stats().obtuse_corners;
  const std::size_t unsplit = solver.stats().unsplit_corners;

  // Farthest-point sampling with lower().
  std::vector<double> field(nv, kInfinity);
  std::vector<std::uint32_t> samples;
  double lower_ms = 0, lower_cpu_ms = 0;
  std::size_t lowered = 0;
  samples.push_back(random_vertex(mesh, rng));
  for (int i = 0; i < s.fps; ++i) {
    const auto start = Clock::now();
    const double cpu_start = thread_cpu_ms();
    lowered += solver.lower(field, SurfacePoint::vertex(samples.back()));
    lower_cpu_ms += thread_cpu_ms() - cpu_start;
    lower_ms += ms_since(start);
    samples.push_back(argmax(field));
  }
  const double radius = field[samples.back()];
  // The same sequence of sources, against min(field, fresh solve).
  std::fill(field.begin(), field.end(), kInfinity);
  std::vector<double> reference(nv, kInfinity);
  std::size_t differing = 0;
  double worst = 0;
  for (int i = 0; i < s.fps; ++i) {
    solver.solve(SurfacePoint::vertex(samples[static_cast<std::size_t>(i)]));
    for (std::uint32_t v = 0; v < nv; ++v) reference[v] = std::min(reference[v], solver.distance(v));
    solver.lower(field, SurfacePoint::vertex(samples[static_cast<std::size_t>(i)]));
    for (std::uint32_t v = 0; v < nv; ++v) {
      if (field[v] != reference[v]) {
        ++differing;
        worst = std::max(worst, std::abs(field[v] - reference[v]));
      }
      field[v] = reference[v];  // compare each lower() alone, from the same input
    }
  }

  std::printf("| %s | %zu | %.2f (%.2f) | %zu | %zu | %.1f (%.1f) | %.0f | %zu | %.3g | %.2f%% |\n",
              name.c_str(), mesh.num_faces(), median(full_ms), median(full_cpu_ms), settled, pushes,
              lower_ms, lower_cpu_ms,
              static_cast<double>(lowered) / s.fps, differing, worst / radius,
              100.0 * static_cast<double>(obtuse) / static_cast<double>(mesh.num_halfedges()));
  std::fflush(stdout);

  char line[640];
  std::snprintf(line, sizeof line,
                "- %s: load+geometry %.0f ms; full solve min %.2f / max %.2f ms; obtuse corners "
                "%zu, unsplit %zu; fps covering radius after %d samples %.4g (%.1f mean edges)",
                name.c_str(), load_ms, *std::min_element(full_ms.begin(), full_ms.end()),
                *std::max_element(full_ms.begin(), full_ms.end()), obtuse, unsplit, s.fps, radius,
                radius / geometry.mean_edge_length());
  notes.push_back(line);

  if (s.accuracy == 0) return;
  ExactGeodesicSolver exact(mesh, geometry);
  Accuracy with, without;
  std::size_t count = 0;
  double exact_ms = 0;
  const double far = 10 * geometry.mean_edge_length();
  for (int k = 0; k < s.accuracy; ++k) {
    const SurfacePoint source = SurfacePoint::vertex(random_vertex(mesh, rng));
    const auto start = Clock::now();
    exact.solve(source);
    exact_ms += ms_since(start);
    const std::vector<double> truth = exact.vertex_distances();
    for (int pass = 0; pass < 2; ++pass) {
      FastMarchingOptions options;
      if (pass == 1) options.max_unfold_steps = 0;
      solver.solve(source, options);
      Accuracy& acc = pass == 0 ? with : without;
      for (std::uint32_t v = 0; v < nv; ++v) {
        if (!(truth[v] > 0) || truth[v] == kInfinity) continue;
        const double rel = std::abs(solver.distance(v) - truth[v]) / truth[v];
        acc.mean += rel;
        acc.max = std::max(acc.max, rel);
        if (truth[v] >= far) acc.far_max = std::max(acc.far_max, rel);
        if (pass == 0) ++count;
      }
    }
  }
  with.mean /= static_cast<double>(count);
  without.mean /= static_cast<double>(count);
  std::snprintf(line, sizeof line,
                "- %s accuracy vs exact (%d sources, %zu vertex distances; exact solve %.0f ms "
                "each): unfolding mean %.3f%% max %.2f%% far max %.2f%%; without unfolding mean "
                "%.3f%% max %.2f%% far max %.2f%%",
                name.c_str(), s.accuracy, count, exact_ms / s.accuracy, 100 * with.mean,
                100 * with.max, 100 * with.far_max, 100 * without.mean, 100 * without.max,
                100 * without.far_max);
  notes.push_back(line);
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
      s.runs = static_cast<int>(parse_count("--runs", value(), false));
    } else if (a == "--sources") {
      s.sources = static_cast<int>(parse_count("--sources", value(), false));
    } else if (a == "--fps") {
      s.fps = static_cast<int>(parse_count("--fps", value(), false));
    } else if (a == "--accuracy") {
      s.accuracy = static_cast<int>(parse_count("--accuracy", value(), true));
    } else if (a == "--seed") {
      s.seed = static_cast<std::uint64_t>(parse_count("--seed", value(), false));
    } else if (a == "-h" || a == "--help") {
      usage("benchmark of fast marching");
    } else if (!a.empty() && a[0] == '-') {
      usage(("unknown option " + a).c_str());
    } else {
      meshes.push_back(a);
    }
  }
  if (meshes.empty()) usage("no mesh given");
  std::printf("full: median of %d runs x %d sources; fps: %d lower() calls\n", s.runs, s.sources,
              s.fps);
  std::printf(
      "| mesh | faces | full solve ms (cpu) | settled | heap pushes | %d lower() ms (cpu) | "
      "lowered per call | lower != min(old, fresh) | worst diff / r | obtuse corners |\n",
      s.fps);
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  int failures = 0;
  std::vector<std::string> notes;
  for (const std::string& path : meshes) {
    try {
      bench_mesh(path, s, notes);
    } catch (const std::exception& e) {
      std::printf("| %s | error: %s |\n", base_name(path).c_str(), e.what());
      std::fflush(stdout);
      ++failures;
    }
  }
  std::printf("\n");
  for (const std::string& n : notes) std::printf("%s\n", n.c_str());
  return failures ? 1 : 0;
}
