// Faults of graph builds (issue 8, section 3), against the real binaries as child processes:
// geoproxd killed with SIGKILL while it builds and writes a graph file (no half-written file is
// ever opened, the temporaries left behind are removed at the next start, the build restarts
// and the mesh becomes ready with the offline answers), and a full disk during a build, for
// `geoprox build` and for the daemon (an error naming the file and the cause, nothing left
// behind, an older graph file untouched and still served). The disk is "full" in two ways:
// RLIMIT_FSIZE in the writer's process with SIGXFSZ ignored (writes past the limit fail with
// EFBIG; works in any container), and a real tmpfs with little room left (ENOSPC; needs the right
// to mount, and says so on stdout when it is missing).
#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/inotify.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/statvfs.h>
#include <sys/wait.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <deque>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tests/server/server_test_support.h"

namespace geoprox::server::testing {
namespace {

/// A child process running `argv`, its stdout and stderr to `log`. With `file_size_limit` > 0,
/// RLIMIT_FSIZE is set to it and SIGXFSZ ignored: writes past the limit fail with EFBIG, which
/// is what a full disk looks like to the writer, instead of killing the process.
class ChildProcess {
 public:
  ChildProcess(std::vector<std::string> argv, const fs::path& log, rlim_t file_size_limit = 0) {
    std::vector<char*> args;
    for (std::string& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    pid_ = ::fork();
    if (pid_ == 0) {  // only async-signal-safe calls until exec
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd < 0) _exit(126);
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
      if (file_size_limit > 0) {
        struct sigaction ignore {};
        ignore.sa_handler = SIG_IGN;
        ::sigaction(SIGXFSZ, &ignore, nullptr);  // an ignored signal stays ignored across exec
        const rlimit limit{file_size_limit, file_size_limit};
        if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) _exit(125);
      }
      ::execv(args[0], args.data());
      _exit(127);
    }
  }
  ~ChildProcess() {
    if (pid_ > 0) kill9();
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  /// SIGSTOP, returning once the whole process (every thread) is stopped; false if it exited.
  bool stop() {
    if (reaped_) return false;
    ::kill(pid_, SIGSTOP);
    int status = 0;
    if (::waitpid(pid_, &status, WUNTRACED) != pid_) return false;
    if (WIFSTOPPED(status)) return true;
    reaped_ = true;
    return false;
  }
  void kill9() {
    if (reaped_) return;
    ::kill(pid_, SIGKILL);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    reaped_ = true;
  }
  void signal(int sig) {
    if (!reaped_) ::kill(pid_, sig);
  }
  bool running() {
    if (reaped_) return false;
    int status = 0;
    const pid_t r = ::waitpid(pid_, &status, WNOHANG);
    if (r == 0) return true;
    reaped_ = true;
    exit_code_ = r == pid_ && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return false;
  }
  /// The exit code, or -1 when killed by a signal or still running after `timeout`.
  int wait(std::chrono::milliseconds timeout = 60s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (running() && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(5ms);
    }
    return reaped_ ? exit_code_ : -1;
  }

 private:
  pid_t pid_ = -1;
  bool reaped_ = false;
  int exit_code_ = -1;
};

/// `geoprox ARGS`: exit code and everything it printed.
struct CliRun {
  int exit_code;
  std::string output;
};
CliRun run_geoprox(const std::vector<std::string>& args, const fs::path& log,
                   rlim_t file_size_limit = 0) {
  std::vector<std::string> argv{GEOPROX_CLI_BINARY};
  argv.insert(argv.end(), args.begin(), args.end());
  ChildProcess cli(argv, log, file_size_limit);
  const int code = cli.wait(120s);
  return {code, read_bytes(log)};
}

/// The temporaries of write_graph_file(`graph`) in its directory, by name, with their sizes.
std::map<std::string, std::uintmax_t> temporaries(const fs::path& graph) {
  std::map<std::string, std::uintmax_t> found;
  const std::string prefix = graph.filename().string() + ".tmp-";
  for (const auto& entry : fs::directory_iterator(graph.parent_path())) {
    const std::string name = entry.path().filename().string();
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(entry.path(), ec);
    if (name.starts_with(prefix) && !ec) found[name] = size;
  }
  return found;
}

/// The names in `dir`, for messages.
std::string listing(const fs::path& dir) {
  std::string names;
  for (const auto& entry : fs::directory_iterator(dir)) {
    names += " " + entry.path().filename().string();
  }
  return names.empty() ? "(empty)" : names;
}

/// inotify on a directory: files created, written and renamed away in it.
class DirectoryWatch {
 public:
  struct Event {
    std::uint32_t mask;
    std::string name;
  };
  explicit DirectoryWatch(const fs::path& dir) {
    fd_ = ::inotify_init1(IN_CLOEXEC | IN_NONBLOCK);
    ok_ = fd_ >= 0 &&
          ::inotify_add_watch(fd_, dir.c_str(), IN_CREATE | IN_MODIFY | IN_MOVED_FROM) >= 0;
  }
  ~DirectoryWatch() {
    if (fd_ >= 0) ::close(fd_);
  }
  DirectoryWatch(const DirectoryWatch&) = delete;
  DirectoryWatch& operator=(const DirectoryWatch&) = delete;
  bool ok() const { return ok_; }

  /// The next event, or nothing by `deadline`.
  std::optional<Event> next(std::chrono::steady_clock::time_point deadline) {
    while (pending_.empty()) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      pollfd p{fd_, POLLIN, 0};
      if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) <= 0) {
        return std::nullopt;
      }
      alignas(inotify_event) char buffer[8192];
      const ssize_t n = ::read(fd_, buffer, sizeof buffer);
      for (ssize_t at = 0; at < n;) {
        const auto* event = reinterpret_cast<const inotify_event*>(buffer + at);
        pending_.push_back({event->mask, event->len > 0 ? std::string(event->name) : ""});
        at += static_cast<ssize_t>(sizeof(inotify_event) + event->len);
      }
    }
    Event event = pending_.front();
    pending_.pop_front();
    return event;
  }

 private:
  int fd_ = -1;
  bool ok_ = false;
  std::deque<Event> pending_;
};

/// A tmpfs of `size` (mount's syntax, e.g. "2m") on `dir`, in a mount namespace of the calling
/// thread (unshare): visible to this thread and the processes it starts, gone with them, never
/// in the host's namespace. ok() is false, with why(), where mounting is not allowed.
class PrivateTmpfs {
 public:
  PrivateTmpfs(const fs::path& dir, const std::string& size) : dir_(dir) {
    if (::unshare(CLONE_NEWNS) != 0) {
      why_ = std::string("unshare(CLONE_NEWNS): ") + std::strerror(errno);
    } else if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) {
      why_ = std::string("making / private: ") + std::strerror(errno);
    } else if (::mount("tmpfs", dir.c_str(), "tmpfs", MS_NOSUID | MS_NODEV,
                       ("size=" + size).c_str()) != 0) {
      why_ = "mount -t tmpfs -o size=" + size + ": " + std::strerror(errno);
    } else {
      mounted_ = true;
    }
  }
  ~PrivateTmpfs() {
    if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);
  }
  PrivateTmpfs(const PrivateTmpfs&) = delete;
  PrivateTmpfs& operator=(const PrivateTmpfs&) = delete;
  bool ok() const { return mounted_; }
  const std::string& why() const { return why_; }

 private:
  fs::path dir_;
  bool mounted_ = false;
  std::string why_;
};

std::uintmax_t free_bytes(const fs::path& dir) {
  struct statvfs st {};
  if (::statvfs(dir.c_str(), &st) != 0) return 0;
  return static_cast<std::uintmax_t>(st.f_bavail) * st.f_frsize;
}

/// Fills the file system of `dir` with a file `dir`/filler until `left` bytes remain free.
void fill_leaving(const fs::path& dir, std::uintmax_t left) {
  const std::uintmax_t available = free_bytes(dir);
  ASSERT_GT(available, left) << dir;
  std::ofstream filler(dir / "filler", std::ios::binary | std::ios::trunc);
  const std::string chunk(4096, 'x');
  for (std::uintmax_t written = 0; written + chunk.size() <= available - left;
       written += chunk.size()) {
    filler << chunk;
  }
  filler.close();
  ASSERT_TRUE(filler.good()) << "filling " << dir;
  EXPECT_LE(free_bytes(dir), left + 8192);
}

/// Build parameters of the graphs the daemon writes in these tests (small, so quick to build;
/// the file is about 1 MiB, most of it the mesh).
BuildParams quick_params() { return BuildParams{100, 8, 0, SamplingMethod::FastMarching}; }

/// A daemon's directory: config file, data/meshes/spot.obj, graphs/ (empty), port file, logs.
struct DaemonDir {
  TempDir dir;
  fs::path graph_dir() const { return dir.path() / "graphs"; }
  fs::path port_file() const { return dir.path() / "ports.json"; }
  fs::path config() const { return dir.path() / "geoproxd.json"; }
  fs::path mesh() const { return dir.path() / "data/meshes/spot.obj"; }

  /// `meshes`: id and build parameters; each is spot.obj, its graph graphs/<id>.geoprox.
  explicit DaemonDir(const std::vector<std::pair<std::string, BuildParams>>& meshes) {
    fs::create_directories(dir.path() / "data/meshes");
    fs::create_directories(graph_dir());
    fs::copy_file(spot_obj(), mesh());
    json list = json::array();
    for (const auto& [id, params] : meshes) {
      list.push_back({{"id", id},
                      {"mesh", "meshes/spot.obj"},
                      {"samples", params.samples},
                      {"neighbors", params.neighbors},
                      {"sampling", "fmm"}});
    }
    const json settings = {{"bind", "127.0.0.1"},   {"port", 0},
                         {"admin_port", 0}, {"http_port", 0},        {"compute_threads", 2},
                         {"build_threads", 2},     {"data_dir", "data"},
                         {"graph_dir", "graphs"},  {"shutdown_timeout_ms", 5000},
                         {"admin_token", "s3cret"}, {"meshes", list}};
    std::ofstream(config()) << settings.dump(2);
  }

  std::unique_ptr<ChildProcess> start(const fs::path& log, rlim_t file_size_limit = 0) const {
    std::error_code ec;
    fs::remove(port_file(), ec);
    return std::make_unique<ChildProcess>(
        std::vector<std::string>{GEOPROXD_BINARY, "--config", config().string(), "--port-file",
                                 port_file().string()},
        log, file_size_limit);
  }

  /// The query port, once the daemon listens (0 and a failure if it does not within 30 s).
  std::uint16_t wait_for_port(ChildProcess& daemon, const fs::path& log) const {
    const auto deadline = std::chrono::steady_clock::now() + 30s;
    while (std::chrono::steady_clock::now() < deadline && daemon.running()) {
      try {
        return json::parse(read_bytes(port_file()))["port"].get<std::uint16_t>();
      } catch (const std::exception&) {
        std::this_thread::sleep_for(10ms);
      }
    }
    ADD_FAILURE() << "geoproxd did not start:\n" << read_bytes(log);
    return 0;
  }
};

/// The mesh.list entry of `id` once `done` holds for it (up to 60 s).
template <typename Predicate>
json wait_for_mesh(std::uint16_t port, const std::string& id, Predicate done) {
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  json last;
  while (std::chrono::steady_clock::now() < deadline) {
    const json list = Client(port).result("mesh.list");
    for (const json& m : list["meshes"]) {
      if (m["id"] == id) last = m;
    }
    if (!last.is_null() && done(last)) return last;
    std::this_thread::sleep_for(20ms);
  }
  ADD_FAILURE() << "mesh " << id << " never reached the expected state: " << last.dump();
  return last;
}

double daemon_distance(std::uint16_t port, const std::string& mesh) {
  return Client(port)
      .result("geodesic.distance", {{"mesh", mesh}, {"source", "v:0"}, {"target", "v:1500"}})
      .at("distance")
      .get<double>();
}

double offline_distance(const fs::path& graph) {
  Reference reference(spot_obj(), graph);
  return reference.query
      .distance(SurfacePoint::vertex(0), SurfacePoint::vertex(1500), reference.scratch)
      .distance;
}

// ---- kill -9 during the build and the write ----

/// Where a kill landed, seen while the daemon was stopped just before it.
struct KillFigures {
  int kills = 0;
  int before_write = 0;   // no temporary of this run yet: loading, sampling, local solves
  int empty = 0;          // mid-write: the temporary exists with 0 bytes
  int partial = 0;        // mid-write: some bytes written, not all
  int unrenamed = 0;      // mid-write: every byte written, not yet renamed (fsync)
  int after_rename = 0;   // the graph file complete under its name
  int stale_removed = 0;  // temporaries of killed runs removed by a later start
  int mid_write() const { return empty + partial + unrenamed; }
};

TEST(BuildFaults, KillNineWhileWritingTheGraphNeverLeavesAHalfWrittenFile) {
  const auto began = std::chrono::steady_clock::now();
  DaemonDir d({{"spot", quick_params()}});
  const fs::path graph = d.graph_dir() / "spot.geoprox";
  const fs::path offline_graph = cached_graph(spot_obj(), quick_params());
  const std::uintmax_t full_size = fs::file_size(offline_graph);
  const TriangleMesh mesh = load_mesh(spot_obj().string());
  const IntrinsicGeometry geometry(mesh);
  KillFigures figures;
  std::set<std::string> stale;  // temporaries left by the kills so far

  // Stops the daemon (SIGSTOP: every thread frozen where it is), records where it was, kills it
  // with SIGKILL, and checks what a next start would find. Returns how many temporaries of
  // earlier kills were still there.
  const auto stop_and_kill = [&](ChildProcess& daemon, const std::string& round) -> std::size_t {
    SCOPED_TRACE(round);
    const bool stopped = daemon.stop();
    EXPECT_TRUE(stopped) << "geoproxd exited before the kill";
    const auto temps = temporaries(graph);
    std::set<std::string> still_stale;
    for (const std::string& name : stale) {
      if (temps.count(name)) still_stale.insert(name);
    }
    figures.stale_removed += static_cast<int>(stale.size() - still_stale.size());
    std::optional<std::uintmax_t> own_temp;
    for (const auto& [name, size] : temps) {
      if (!stale.count(name)) {
        EXPECT_FALSE(own_temp) << "two temporaries of one writer: " << listing(d.graph_dir());
        own_temp = size;
        still_stale.insert(name);
      }
    }
    const bool renamed = fs::exists(graph);
    daemon.kill9();
    ++figures.kills;
    if (renamed) {
      ++figures.after_rename;
    } else if (!own_temp) {
      ++figures.before_write;
    } else if (*own_temp == 0) {
      ++figures.empty;
    } else if (*own_temp < full_size) {
      ++figures.partial;
    } else {
      EXPECT_EQ(*own_temp, full_size);
      ++figures.unrenamed;
    }
    stale = still_stale;
    // What the next start sees under the graph's name: nothing, or a complete file.
    if (renamed) {
      EXPECT_EQ(fs::file_size(graph), full_size);
      EXPECT_NO_THROW(MappedGraphFile::open(graph.string()).verify_mesh(mesh, geometry));
      fs::remove(graph);  // so that the next start builds again
    }
    return still_stale.size() - (own_temp ? 1 : 0);
  };

  // 1. Deterministic mid-write kills: inotify reports the daemon's temporary as it is created
  // and as each write(2) lands; the daemon is stopped at the k-th such event, so the kill finds
  // the temporary empty (k = 0), with the arrays but not the checksum (k = 1: the ~1 MiB file
  // goes out in one buffered write, then the 8-byte checksum), or complete and not yet renamed
  // (k = 2: fsync is under way). A very late stop can still find it renamed; the rounds go on
  // until three landed mid-write, at most 9 rounds.
  std::chrono::duration<double> slowest_to_write{0};
  int round = 0;
  for (; round < 9 && figures.mid_write() < 3; ++round) {
    DirectoryWatch watch(d.graph_dir());
    ASSERT_TRUE(watch.ok()) << "inotify: " << std::strerror(errno);
    const fs::path log = d.dir.path() / ("kill-" + std::to_string(round) + ".log");
    const auto started = std::chrono::steady_clock::now();
    auto daemon = d.start(log);
    const int k = round % 3;
    const auto deadline = started + 20s;
    std::string temp;
    int writes = 0;
    while (auto event = watch.next(deadline)) {
      if (temp.empty()) {
        if ((event->mask & IN_CREATE) && event->name.starts_with("spot.geoprox.tmp-")) {
          temp = event->name;
          slowest_to_write = std::max(slowest_to_write,
                                      std::chrono::duration<double>(
                                          std::chrono::steady_clock::now() - started));
          if (k == 0) break;
        }
      } else if (event->name == temp) {
        if ((event->mask & IN_MOVED_FROM) || ((event->mask & IN_MODIFY) && ++writes == k)) break;
      }
    }
    ASSERT_FALSE(temp.empty()) << "no temporary within 20 s:\n" << read_bytes(log);
    // This start got as far as writing, so it removed every temporary of earlier kills first.
    EXPECT_EQ(stop_and_kill(*daemon, "stopped at event " + std::to_string(k) + " of " + temp), 0u)
        << listing(d.graph_dir());
  }
  EXPECT_GE(figures.mid_write(), 3) << "no kill landed while the graph was being written";
  const int stopped_rounds = round;

  // 2. Kills at random moments from the start to a little past the slowest write seen above:
  // most land while loading or building, some while writing.
  std::mt19937 random(std::random_device{}());
  std::uniform_real_distribution<double> moment(0.0, 1.2 * slowest_to_write.count());
  const int random_rounds = 6;
  for (int i = 0; i < random_rounds; ++i) {
    const double delay = moment(random);
    const fs::path log = d.dir.path() / ("random-" + std::to_string(i) + ".log");
    auto daemon = d.start(log);
    std::this_thread::sleep_for(std::chrono::duration<double>(delay));
    stop_and_kill(*daemon, "killed after " + std::to_string(delay) + " s");
  }

  // 3. A last start: stale temporaries are removed, the build restarts from the beginning and
  // the mesh becomes ready with the answers of a graph built offline.
  const std::size_t stale_before_last = stale.size();
  const fs::path log = d.dir.path() / "final.log";
  auto daemon = d.start(log);
  const std::uint16_t port = d.wait_for_port(*daemon, log);
  ASSERT_NE(port, 0);
  wait_for_state(port, "spot", "ready");
  const auto left = temporaries(graph);
  EXPECT_TRUE(left.empty()) << listing(d.graph_dir());
  for (const std::string& name : stale) figures.stale_removed += left.count(name) ? 0 : 1;
  const std::string text = read_bytes(log);
  EXPECT_EQ(stale_before_last > 0, text.find("left by a graph write that was interrupted") !=
                                       std::string::npos)
      << text;
  const CliRun inspect = run_geoprox({"inspect", graph.string(), "--verify", d.mesh().string()},
                                     d.dir.path() / "inspect.log");
  EXPECT_EQ(inspect.exit_code, 0) << inspect.output;
  EXPECT_NE(inspect.output.find("matches"), std::string::npos) << inspect.output;
  EXPECT_DOUBLE_EQ(daemon_distance(port, "spot"), offline_distance(offline_graph));
  daemon->signal(SIGTERM);
  EXPECT_EQ(daemon->wait(30s), 0) << read_bytes(log);

  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
  std::cout << "kill -9 figures: " << figures.kills << " kills (" << stopped_rounds
            << " at inotify events, " << random_rounds << " at random moments up to "
            << 1.2 * slowest_to_write.count() << " s); mid-write " << figures.mid_write()
            << " (empty " << figures.empty << ", partial " << figures.partial
            << ", complete but not renamed " << figures.unrenamed << "); before the write "
            << figures.before_write << "; after the rename " << figures.after_rename
            << "; stale temporaries removed at a later start " << figures.stale_removed
            << "; " << seconds << " s" << std::endl;
}

TEST(BuildFaults, StartRemovesOnlyTemporariesNoWriterHolds) {
  TempDir dir;
  const fs::path graph = dir.path() / "spot.geoprox";
  const auto touch = [&](const std::string& name) {
    std::ofstream(dir.path() / name) << "partial";
  };
  touch("spot.geoprox.tmp-a1B2c3");   // left by a killed writer: removed
  touch("spot.geoprox.tmp-Zz9Yy8");   // locked by a live writer: kept
  touch("spot.geoprox.tmp-abc");      // not the pattern: kept
  touch("spot.geoprox.tmp-abcdefg");
  touch("spot.geoprox.tmp-ab.def");
  touch("other.geoprox.tmp-abcdef");
  touch("spot.geoprox");
  fs::create_directory(dir.path() / "spot.geoprox.tmp-dir123");
  fs::create_symlink(dir.path() / "spot.geoprox", dir.path() / "spot.geoprox.tmp-link12");
  const int live = ::open((dir.path() / "spot.geoprox.tmp-Zz9Yy8").c_str(), O_RDONLY | O_CLOEXEC);
  ASSERT_GE(live, 0);
  ASSERT_EQ(::flock(live, LOCK_EX), 0);  // another open file description: conflicts
  const std::vector<std::string> removed = remove_stale_graph_temporaries(graph.string());
  ::close(live);
  EXPECT_EQ(removed, std::vector<std::string>{(dir.path() / "spot.geoprox.tmp-a1B2c3").string()});
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir.path())) {
    names.insert(entry.path().filename().string());
  }
  EXPECT_EQ(names, (std::set<std::string>{"spot.geoprox.tmp-Zz9Yy8", "spot.geoprox.tmp-abc",
                                          "spot.geoprox.tmp-abcdefg", "spot.geoprox.tmp-ab.def",
                                          "other.geoprox.tmp-abcdef", "spot.geoprox",
                                          "spot.geoprox.tmp-dir123", "spot.geoprox.tmp-link12"}));
  // Unlocked now: its writer is gone.
  EXPECT_EQ(remove_stale_graph_temporaries(graph.string()),
            std::vector<std::string>{(dir.path() / "spot.geoprox.tmp-Zz9Yy8").string()});
}

TEST(BuildFaults, ACleanerRunningAllTheTimeNeverBreaksAWrite) {
  // Another process starting (its cleanup) while this one writes the same graph: the writer's
  // lock keeps its temporary, and a temporary unlinked between its creation and its lock is
  // replaced. 20 writes against a cleaner in a loop: every write succeeds and leaves nothing.
  TempDir dir;
  const fs::path graph = dir.path() / "spot.geoprox";
  const TriangleMesh mesh = load_mesh(spot_obj().string());
  const IntrinsicGeometry geometry(mesh);
  ProximityGraphOptions options;
  options.num_samples = 50;
  options.neighbors = 6;
  options.sampling = SamplingMethod::FastMarching;
  const ProximityGraph built = build_proximity_graph(mesh, geometry, options);
  std::atomic<bool> writing{true};
  std::size_t cleaned = 0;
  std::thread cleaner([&] {
    while (writing) cleaned += remove_stale_graph_temporaries(graph.string()).size();
  });
  int failures = 0;
  for (int i = 0; i < 20; ++i) {
    try {
      write_graph_file(graph.string(), mesh, geometry, built);
    } catch (const std::exception& e) {
      ++failures;
      ADD_FAILURE() << e.what();
    }
  }
  writing = false;
  cleaner.join();
  // (`cleaned` counts temporaries taken between mkostemp and flock; the writer made new ones.)
  EXPECT_EQ(failures, 0) << cleaned << " temporaries were taken by the cleaner";
  EXPECT_TRUE(temporaries(graph).empty()) << listing(dir.path());
  EXPECT_NO_THROW(MappedGraphFile::open(graph.string()).verify_mesh(mesh, geometry));
}

// ---- a full disk ----

/// What `geoprox build` must do on a full disk, with and without an older graph at `out`:
/// exit 2 naming the file and `cause`, nothing new in the directory, the older file's bytes.
void expect_cli_build_fails_cleanly(const fs::path& out, const std::string& cause,
                                    const fs::path& log_dir, rlim_t file_size_limit) {
  const std::vector<std::string> build = {
      "build", spot_obj().string(), "--out", out.string(), "--samples",
      std::to_string(quick_params().samples), "--neighbors",
      std::to_string(quick_params().neighbors), "--sampling", "fmm", "--threads", "2", "-q"};
  const std::string old = fs::exists(out) ? read_bytes(out) : "";
  const CliRun run = run_geoprox(build, log_dir / "build.log", file_size_limit);
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("geoprox: error: cannot write graph file '" + out.string() + "'"),
            std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find(cause), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("[WriteError]"), std::string::npos) << run.output;
  EXPECT_TRUE(temporaries(out).empty()) << listing(out.parent_path());
  if (old.empty()) {
    EXPECT_FALSE(fs::exists(out));
  } else {
    EXPECT_EQ(read_bytes(out), old);
  }
}

TEST(BuildFaults, GeoproxBuildOnAFullDiskFailsNamingTheFileAndLeavesNothing) {
  TempDir dir;
  const fs::path older = cached_graph(spot_obj(), small_spot_params());  // ~1 MiB
  {
    SCOPED_TRACE("RLIMIT_FSIZE 256 KiB: EFBIG");
    const fs::path out_dir = dir.path() / "limited";
    fs::create_directories(out_dir);
    expect_cli_build_fails_cleanly(out_dir / "spot.geoprox", "File too large", dir.path(),
                                   256 << 10);
    fs::copy_file(older, out_dir / "spot.geoprox");
    expect_cli_build_fails_cleanly(out_dir / "spot.geoprox", "File too large", dir.path(),
                                   256 << 10);
  }
  {
    SCOPED_TRACE("tmpfs with 256 KiB free: ENOSPC");
    const fs::path out_dir = dir.path() / "tmpfs";
    fs::create_directories(out_dir);
    const PrivateTmpfs tmpfs(out_dir, "2m");
    if (!tmpfs.ok()) {
      std::cout << "BuildFaults: the tmpfs case (ENOSPC) did not run: " << tmpfs.why()
                << "; the RLIMIT_FSIZE case (EFBIG) did" << std::endl;
    } else {
      fill_leaving(out_dir, 256 << 10);
      expect_cli_build_fails_cleanly(out_dir / "spot.geoprox", "No space left on device",
                                     dir.path(), 0);
      fs::remove(out_dir / "filler");
      fs::copy_file(older, out_dir / "spot.geoprox");
      fill_leaving(out_dir, 256 << 10);
      expect_cli_build_fails_cleanly(out_dir / "spot.geoprox", "No space left on device",
                                     dir.path(), 0);
    }
  }
}

/// The daemon on a full disk: "spot" has a graph (small_spot_params) and serves it, "fresh" has
/// none and must build one. Its build fails: "fresh" is failed with the cause, "spot" keeps
/// serving; then a rebuild of "spot" fails the same way and leaves its graph file and its
/// answers as they were.
void expect_daemon_survives_a_full_disk(DaemonDir& d, const std::string& cause,
                                        rlim_t file_size_limit) {
  const fs::path spot_graph = d.graph_dir() / "spot.geoprox";
  const fs::path fresh_graph = d.graph_dir() / "fresh.geoprox";
  const std::string old_bytes = read_bytes(spot_graph);
  const fs::path log = d.dir.path() / "daemon.log";
  auto daemon = d.start(log, file_size_limit);
  const std::uint16_t port = d.wait_for_port(*daemon, log);
  ASSERT_NE(port, 0);
  const double expected = offline_distance(spot_graph);

  const json spot = wait_for_state(port, "spot", "ready");
  const json fresh = wait_for_state(port, "fresh", "failed");
  ASSERT_TRUE(fresh["error"].is_string()) << fresh.dump();
  const std::string error = fresh["error"];
  EXPECT_NE(error.find("cannot write graph file '" + fresh_graph.string() + "'"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find(cause), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(fresh_graph));
  EXPECT_EQ(temporaries(fresh_graph).size(), 0u) << listing(d.graph_dir());
  EXPECT_EQ(daemon_distance(port, "spot"), expected);
  Client c(port);
  EXPECT_EQ(c.error_reason("geodesic.distance",
                           {{"mesh", "fresh"}, {"source", "v:0"}, {"target", "v:1"}}),
            "MeshBuildFailed");

  // A rebuild of the mesh in service fails the same way; the old graph stays.
  const json rebuilding = c.result("admin.rebuild", {{"token", "s3cret"}, {"mesh", "spot"}});
  EXPECT_EQ(rebuilding["mesh_version"], spot["mesh_version"]);
  const json after = wait_for_mesh(port, "spot", [](const json& m) {
    return m["state"] != "building" && m["error"].is_string();
  });
  EXPECT_EQ(after["state"], "ready") << after.dump();
  EXPECT_NE(after["error"].get<std::string>().find(cause), std::string::npos) << after.dump();
  EXPECT_EQ(after["mesh_version"], spot["mesh_version"]);
  EXPECT_TRUE(read_bytes(spot_graph) == old_bytes) << "the graph file in service was changed";
  EXPECT_TRUE(temporaries(spot_graph).empty()) << listing(d.graph_dir());
  EXPECT_EQ(daemon_distance(port, "spot"), expected);

  daemon->signal(SIGTERM);
  EXPECT_EQ(daemon->wait(30s), 0) << read_bytes(log);
}

TEST(BuildFaults, DaemonOnAFullDiskFailsTheBuildAndKeepsServing) {
  const std::vector<std::pair<std::string, BuildParams>> meshes = {
      {"spot", small_spot_params()}, {"fresh", quick_params()}};
  const fs::path spot_graph = cached_graph(spot_obj(), small_spot_params());
  {
    SCOPED_TRACE("RLIMIT_FSIZE 256 KiB: EFBIG");
    DaemonDir d(meshes);
    fs::copy_file(spot_graph, d.graph_dir() / "spot.geoprox");
    expect_daemon_survives_a_full_disk(d, "File too large", 256 << 10);
  }
  {
    SCOPED_TRACE("graph_dir on a tmpfs with 256 KiB free: ENOSPC");
    DaemonDir d(meshes);
    const PrivateTmpfs tmpfs(d.graph_dir(), "2m");
    if (!tmpfs.ok()) {
      std::cout << "BuildFaults: the tmpfs case (ENOSPC) did not run: " << tmpfs.why()
                << "; the RLIMIT_FSIZE case (EFBIG) did" << std::endl;
    } else {
      fs::copy_file(spot_graph, d.graph_dir() / "spot.geoprox");
      fill_leaving(d.graph_dir(), 256 << 10);
      expect_daemon_survives_a_full_disk(d, "No space left on device", 0);
    }
  }
}

}  // namespace
}  // namespace geoprox::server::testing
