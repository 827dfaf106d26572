// Benchmark of the proximity-graph build and its file (issue 3, section 7). Not a test: it only
// measures.
//
//   graph_build_bench MESH... [--runs N] [--threads T] [--out-dir DIR] [--samples N]
//                             [--neighbors M]
//
// For each mesh: load it, then N times build the graph with the paper's Table 1 parameters for
// its face count (or --samples / --neighbors) and write it to DIR (a fresh temporary directory,
// removed at the end, unless --out-dir is given: then DIR/<mesh name>.geoprox is kept). Reported
// per phase is the median over the N runs:
//  - sampling: farthest-point sampling (ProximityGraphStats::sampling_seconds),
//  - solves: local exact solves, connectivity repair, CSR and cover table
//    (ProximityGraphStats::local_solve_seconds),
//  - covering: r over the whole surface (ProximityGraphStats::covering_seconds),
//  - write: write_graph_file (temporary file, fsync, rename, directory fsync),
//  - total: the four together (build + write);
//  - cores: process CPU time of the build over its wall time (about the thread count when the
//    machine is otherwise idle, less when it is shared);
// and, once: samples, graph edges, cover entries, file size, R, r, the Theorem 4.2 bound, and
// the open time of the written file (MappedGraphFile::open, median of 9 opens, wall time with
// and without the checksum and process CPU time with it; the file was just written, so its
// pages are in the page cache). The runs must produce bit-identical graphs ("same" column).
// The load average is printed before and after each mesh: the machine may be shared.
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "bench/bench_support.h"
#include "core/base/errors.h"
#include "core/graph/graph_file.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "core/mesh/mesh_io.h"
#include "core/graph/proximity_graph.h"

namespace {

using namespace geoprox;
using namespace geoprox::bench;
namespace fs = std::filesystem;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  if (!(in >> a >> b >> c)) return "?";
  return a + " " + b + " " + c;
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

bool same_graph(const ProximityGraph& a, const ProximityGraph& b) {
  return same_bits(a.sample_vertex, b.sample_vertex) && same_bits(a.edge_offsets, b.edge_offsets) &&
         same_bits(a.edge_target, b.edge_target) && same_bits(a.edge_distance, b.edge_distance) &&
         same_bits(a.edge_direction, b.edge_direction) &&
         same_bits(a.cover_offsets, b.cover_offsets) && same_bits(a.cover_sample, b.cover_sample) &&
         same_bits(a.cover_distance, b.cover_distance) &&
         std::memcmp(&a.longest_edge, &b.longest_edge, sizeof(double)) == 0 &&
         std::memcmp(&a.covering_radius, &b.covering_radius, sizeof(double)) == 0;
}

struct Settings {
  int runs = 3;
  int threads = 0;
  std::string out_dir;  // empty: a temporary directory, removed at the end
  std::uint32_t samples = 0;
  std::uint32_t neighbors = 0;
};

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr,
               "graph_build_bench: %s\n"
               "usage: graph_build_bench MESH... [--runs N] [--threads T] [--out-dir DIR]\n"
               "                         [--samples N] [--neighbors M]\n",
               why);
  std::exit(2);
}

long parse_count(const char* flag, const char* text, long minimum) {
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (*end != 0 || end == text || value < minimum) {
    std::fprintf(stderr, "graph_build_bench: %s needs an integer >= %ld, got '%s'\n", flag,
                 minimum, text);
    std::exit(2);
  }
  return value;
}

const char* method_name(SamplingMethod m) {
  switch (m) {
    case SamplingMethod::FastMarching:
      return "fmm";
    case SamplingMethod::Exact:
      return "exact";
    default:
      return "auto";
  }
}

struct Row {
  std::string name;
  std::size_t faces = 0, vertices = 0;
  double load_s = 0;
  double sampling_s = 0, solves_s = 0, covering_s = 0, write_s = 0, total_s = 0;
  double total_min_s = 0, total_max_s = 0;
  double cores = 0;  ///< build CPU time / build wall time (median)
  std::uint32_t samples = 0, neighbors = 0;
  std::size_t edges = 0, covers = 0;
  std::uint64_t file_bytes = 0;
  double R = 0, r = 0, bound = 0;
  double open_ms = 0, open_nocheck_ms = 0;  ///< wall time, median of 9
  double open_cpu_ms = 0;                    ///< CPU time of the process, with checksum
  SamplingMethod method = SamplingMethod::FastMarching;
  bool deterministic = true;
  std::string load_before, load_after;
};

Row bench_mesh(const std::string& path, const Settings& s, const std::string& dir) {
  Row row;
  row.name = base_name(path);
  row.load_before = load_average();
  const auto load_start = Clock::now();
  const TriangleMesh mesh = load_mesh(path);
  const IntrinsicGeometry geometry(mesh);
  row.load_s = seconds_since(load_start);
  row.faces = mesh.num_faces();
  row.vertices = mesh.num_vertices();

  ProximityGraphOptions options;
  options.threads = s.threads;
  options.num_samples = s.samples;
  options.neighbors = s.neighbors;
  const std::string file = dir + "/" + row.name + ".geoprox";

  std::vector<double> sampling, solves, covering, writes, totals, cores;
  ProximityGraph first;
  for (int run = 0; run < s.runs; ++run) {
    const double cpu_start = process_cpu_seconds();
    const auto build_start = Clock::now();
    ProximityGraph graph = build_proximity_graph(mesh, geometry, options);
    const double build_wall = seconds_since(build_start);
    // Cores the build kept busy: below the thread count when the machine is shared.
    cores.push_back((process_cpu_seconds() - cpu_start) / build_wall);
    const auto write_start = Clock::now();
    write_graph_file(file, mesh, geometry, graph, {SamplingMethod::Automatic, row.name});
    const double write_s = seconds_since(write_start);
    sampling.push_back(graph.stats.sampling_seconds);
    solves.push_back(graph.stats.local_solve_seconds);
    covering.push_back(graph.stats.covering_seconds);
    writes.push_back(write_s);
    totals.push_back(graph.stats.sampling_seconds + graph.stats.local_solve_seconds +
                     graph.stats.covering_seconds + write_s);
    if (run == 0) {
      first = std::move(graph);
    } else if (!same_graph(first, graph)) {
      row.deterministic = false;
    }
  }
  row.sampling_s = median(sampling);
  row.solves_s = median(solves);
  row.covering_s = median(covering);
  row.write_s = median(writes);
  row.total_s = median(totals);
  row.cores = median(cores);
  row.total_min_s = *std::min_element(totals.begin(), totals.end());
  row.total_max_s = *std::max_element(totals.begin(), totals.end());
  const ProximityGraphView view = first.view();
  row.samples = view.num_samples;
  row.neighbors = first.neighbors;
  row.edges = view.num_edges();
  row.covers = first.cover_sample.size();
  row.R = first.longest_edge;
  row.r = first.covering_radius;
  row.bound = view.error_bound();
  row.method = first.stats.sampling_used;

  struct stat st {};
  if (::stat(file.c_str(), &st) == 0) row.file_bytes = static_cast<std::uint64_t>(st.st_size);
  for (bool checksum : {true, false}) {
    std::vector<double> opens;
    GraphFileOpenOptions open_options;
    open_options.verify_checksum = checksum;
    std::vector<double> cpu;
    for (int k = 0; k < 9; ++k) {
      const double cpu_start = process_cpu_seconds();
      const auto open_start = Clock::now();
      const MappedGraphFile mapped = MappedGraphFile::open(file, open_options);
      opens.push_back(1e3 * seconds_since(open_start));
      cpu.push_back(1e3 * (process_cpu_seconds() - cpu_start));
      if (mapped.view().num_samples != row.samples) {
        std::fprintf(stderr, "graph_build_bench: %s: reopened file has %u samples, built %u\n",
                     file.c_str(), mapped.view().num_samples, row.samples);
        std::exit(1);
      }
    }
    (checksum ? row.open_ms : row.open_nocheck_ms) = median(opens);
    if (checksum) row.open_cpu_ms = median(cpu);
  }
  row.load_after = load_average();
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  Settings s;
  std::vector<std::string> meshes;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> const char* {
      if (i + 1 >= argc) usage((arg + " needs a value").c_str());
      return argv[++i];
    };
    if (arg == "--runs") {
      s.runs = static_cast<int>(parse_count("--runs", value(), 1));
    } else if (arg == "--threads") {
      s.threads = static_cast<int>(parse_count("--threads", value(), 0));
    } else if (arg == "--out-dir") {
      s.out_dir = value();
    } else if (arg == "--samples") {
      s.samples = static_cast<std::uint32_t>(parse_count("--samples", value(), 0));
    } else if (arg == "--neighbors") {
      s.neighbors = static_cast<std::uint32_t>(parse_count("--neighbors", value(), 0));
    } else if (arg == "-h" || arg == "--help") {
      usage("benchmark of the proximity-graph build");
    } else if (!arg.empty() && arg[0] == '-') {
      usage(("unknown option " + arg).c_str());
    } else {
      meshes.push_back(arg);
    }
  }
  if (meshes.empty()) usage("no mesh given");

  std::string dir = s.out_dir;
  bool remove_dir = false;
  if (dir.empty()) {
    std::string pattern = (fs::temp_directory_path() / "geoprox-graph-bench-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) {
      std::perror("graph_build_bench: mkdtemp");
      return 1;
    }
    dir = pattern;
    remove_dir = true;
  } else {
    std::error_code ec;
    fs::create_directories(dir, ec);
  }

  std::printf("graph_build_bench: %d run(s) per mesh, threads %s (%ld cores online), files in %s\n",
              s.runs, s.threads > 0 ? std::to_string(s.threads).c_str() : "default",
              sysconf(_SC_NPROCESSORS_ONLN), dir.c_str());
  std::fflush(stdout);
  std::vector<Row> rows;
  int status = 0;
  for (const std::string& path : meshes) {
    try {
      rows.push_back(bench_mesh(path, s, dir));
      const Row& r = rows.back();
      std::printf("  %-26s done: total %.2f s (min %.2f, max %.2f), load average %s -> %s\n",
                  r.name.c_str(), r.total_s, r.total_min_s, r.total_max_s, r.load_before.c_str(),
                  r.load_after.c_str());
      std::fflush(stdout);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "graph_build_bench: %s: %s\n", path.c_str(), e.what());
      status = 1;
    }
  }

  std::printf(
      "\n| mesh | faces | n_P/m_P | sampling | sampling s | solves s | covering s | write s | "
      "total s | cores | "
      "edges | covers | file MiB | R | r | bound | open ms | open CPU ms | open ms (no checksum) | "
      "same |\n"
      "|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:"
      "|---:|---|\n");
  for (const Row& r : rows) {
    std::printf(
        "| %s | %zu | %u/%u | %s | %.2f | %.2f | %.3f | %.3f | %.2f | %.2f | %zu | %zu | %.2f | "
        "%.4g | "
        "%.4g | %.3g | %.2f | %.2f | %.2f | %s |\n",
        r.name.c_str(), r.faces, r.samples, r.neighbors, method_name(r.method), r.sampling_s,
        r.solves_s, r.covering_s, r.write_s, r.total_s, r.cores, r.edges, r.covers,
        static_cast<double>(r.file_bytes) / (1024.0 * 1024.0), r.R, r.r, r.bound, r.open_ms,
        r.open_cpu_ms, r.open_nocheck_ms, r.deterministic ? "yes" : "NO");
  }
  // Growth with the face count: seconds per 100k faces.
  std::printf("\n| mesh | faces | vertices | load s | total s per 100k faces | file bytes | "
              "graph part (edges x 24 B) MiB | cover part (covers x 8 B) MiB |\n"
              "|---|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const Row& r : rows) {
    std::printf("| %s | %zu | %zu | %.2f | %.2f | %llu | %.2f | %.2f |\n", r.name.c_str(),
                r.faces, r.vertices, r.load_s, r.total_s * 1e5 / static_cast<double>(r.faces),
                static_cast<unsigned long long>(r.file_bytes),
                static_cast<double>(r.edges) * 24 / (1024.0 * 1024.0),
                static_cast<double>(r.covers) * 8 / (1024.0 * 1024.0));
  }
  std::printf("\nload average now: %s\n", load_average().c_str());
  if (remove_dir) {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  return status;
}
