// The registry of meshes: for each id, the mesh's files and build parameters, its state
// (building / ready / failed, with progress and error) and, once ready, an immutable LoadedMesh.
//
// A LoadedMesh is a core::LoadedGraph (mesh, intrinsic geometry, the mapped graph file, the
// GeodesicQuery over them: everything a query reads) plus a bounded pool of QueryScratch leased
// per request. It is held
// by shared_ptr and swapped atomically on reload or rebuild: a request keeps the LoadedMesh it
// started with, so queries in flight finish on the old graph, which is unmapped when the last of
// them ends. Nothing in a LoadedMesh changes after construction except the scratch pool (its own
// mutex) and the GeodesicQuery's lazily built snap index (std::call_once inside core).
//
// Graphs are loaded and built by one background builder thread: at start, each mesh's graph file
// is mapped if present and built for that mesh (verify_mesh), else built (BuildProgress feeds
// mesh.list), written atomically (write_graph_file) and then mapped. A mesh that fails to load or
// build is marked failed; the others are not affected.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/apps/exponential_map.h"
#include "core/query/geodesic_query.h"
#include "core/apps/geodesic_spline.h"
#include "core/graph/graph_file.h"
#include "core/graph/loaded_graph.h"
#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"
#include "protocol/messages.h"
#include "server/config.h"

namespace geoprox::server {

/// Per-request working memory on one LoadedMesh: the query scratch (which exact distances use
/// too) and, for the requests that need them, an exponential map and a spline evaluator (each
/// created on first use, then reused: they hold buffers sized by the mesh).
struct ScratchSlot {
  QueryScratch scratch;
  std::unique_ptr<ExponentialMap> expmap;
  std::unique_ptr<GeodesicSpline> spline;
  /// The thread that leased it last: lease() gives a thread back its own slot when free, whose
  /// buffers are still in that core's cache.
  std::thread::id last_thread;
};

class LoadedMesh {
 public:
  /// Builds the GeodesicQuery over `file` (which must match `data`; the caller verified it).
  /// `max_scratch` bounds the pool (the number of compute threads); every scratch runs the two
  /// halves of a query through `run_both` (QueryScratch::set_run_both).
  LoadedMesh(std::shared_ptr<const MeshData> data, MappedGraphFile file, std::size_t max_scratch,
             QueryScratch::RunBoth run_both = {});
  ~LoadedMesh();
  LoadedMesh(const LoadedMesh&) = delete;
  LoadedMesh& operator=(const LoadedMesh&) = delete;

  /// A leased scratch slot, returned to the pool by the destructor (interrupt cleared).
  class Lease {
   public:
    Lease(Lease&& other) noexcept : owner_(other.owner_), slot_(std::move(other.slot_)) {
      other.owner_ = nullptr;
    }
    Lease& operator=(Lease&&) = delete;
    ~Lease();
    QueryScratch& scratch() { return slot_->scratch; }
    ExponentialMap& exponential_map();
    GeodesicSpline& spline();

   private:
    friend class LoadedMesh;
    Lease(const LoadedMesh* owner, std::unique_ptr<ScratchSlot> slot)
        : owner_(owner), slot_(std::move(slot)) {}
    const LoadedMesh* owner_;
    std::unique_ptr<ScratchSlot> slot_;
  };
  /// Blocks while `max_scratch` slots are leased (cannot happen when only compute threads lease).
  Lease lease() const;

  const std::string& version() const { return version_; }
  const MeshData& data() const { return *graph_.data; }
  const std::shared_ptr<const MeshData>& data_ptr() const { return graph_.data; }
  const TriangleMesh& mesh() const { return graph_.mesh; }
  const MappedGraphFile& file() const { return graph_.file; }
  const GeodesicQuery& query() const { return *graph_.query; }
  std::size_t scratch_created() const;

 private:
  LoadedGraph graph_;
  std::string version_;
  std::size_t max_scratch_;
  QueryScratch::RunBoth run_both_;
  mutable std::mutex pool_mutex_;
  mutable std::condition_variable pool_cv_;
  mutable std::vector<std::unique_ptr<ScratchSlot>> free_;
  mutable std::size_t created_ = 0;
};

/// Hex of the graph file's checksum: what results carry as mesh_version.
std::string mesh_version_of(const MappedGraphFile& file);

/// What mesh.list / mesh.info report for one mesh, taken under its lock.
struct MeshStatus {
  std::string id;
  protocol::MeshState state = protocol::MeshState::Building;
  double progress = 0;
  std::optional<std::string> phase;
  std::optional<std::string> error;
  std::shared_ptr<const LoadedMesh> loaded;
  std::uint64_t vertices = 0, faces = 0, edges = 0;
  std::filesystem::path mesh_path, graph_path;
  BuildParams build;  ///< registered parameters
};

class MeshEntry {
 public:
  MeshEntry(std::string id, std::filesystem::path mesh_path, std::filesystem::path graph_path,
            BuildParams build)
      : id_(std::move(id)),
        mesh_path_(std::move(mesh_path)),
        graph_path_(std::move(graph_path)),
        build_(build) {}

  const std::string& id() const { return id_; }
  const std::filesystem::path& mesh_path() const { return mesh_path_; }
  const std::filesystem::path& graph_path() const { return graph_path_; }

  /// The graph in service, or null (never loaded, or failed before any load).
  std::shared_ptr<const LoadedMesh> loaded() const;
  MeshStatus status() const;

 private:
  friend class Registry;
  const std::string id_;
  const std::filesystem::path mesh_path_;
  const std::filesystem::path graph_path_;

  mutable std::mutex mutex_;
  BuildParams build_;
  std::shared_ptr<const LoadedMesh> loaded_;
  bool busy_ = false;  ///< a load or build job is queued or running
  bool removed_ = false;
  double progress_ = 0;
  std::optional<std::string> phase_;
  std::optional<std::string> error_;
  std::uint64_t vertices_ = 0, faces_ = 0, edges_ = 0;
};

struct RegistryOptions {
  std::filesystem::path data_dir;
  std::filesystem::path graph_dir;
  std::size_t max_scratch_per_mesh = 1;  ///< the number of compute threads
  int build_threads = 0;                 ///< OpenMP threads per build (0: all)
  /// Given to every query scratch (QueryScratch::set_run_both); empty: one after the other.
  QueryScratch::RunBoth run_both;
};

/// Called after each successful swap or failed load (for logs and metrics); may be empty.
struct RegistryHooks {
  std::function<void(const std::string& mesh, const std::string& version)> on_ready;
  std::function<void(const std::string& mesh, const std::string& error)> on_failed;
};

class Registry {
 public:
  explicit Registry(RegistryOptions options, RegistryHooks hooks = {});
  /// Stops the builder after its current job (a build cannot be interrupted midway).
  ~Registry();
  Registry(const Registry&) = delete;
  Registry& operator=(const Registry&) = delete;

  /// Registers the config's meshes and queues their loads (returns at once).
  void add_configured(const std::vector<MeshConfig>& meshes);

  std::shared_ptr<MeshEntry> find(const std::string& id) const;
  /// In registration order.
  std::vector<std::shared_ptr<MeshEntry>> entries() const;
  std::size_t ready_count() const;
  std::size_t size() const;

  // Admin operations; throw protocol::ProtocolError with the reason to answer.
  MeshStatus register_mesh(const protocol::AdminRegisterParams& params);
  MeshStatus rebuild(const std::string& id, const protocol::BuildOptions& overrides);
  void unregister(const std::string& id);
  /// Reopens graph files (one mesh or all): opened and verified beside the old graph, then
  /// swapped; on failure the old one stays and the outcome has the error. Synchronous.
  std::vector<protocol::ReloadOutcome> reload(const std::optional<std::string>& id);

  /// Resolves an admin path against the data directory: refuses absolute paths outside it and
  /// paths whose symlinks resolve outside it (PathNotAllowed). `field` names it in messages.
  std::filesystem::path confine(const std::string& path, const std::string& field) const;

  /// True while a load or build job is queued or running.
  bool builder_busy() const;
  /// Waits until the builder has nothing to do (tests), up to `timeout`.
  bool wait_idle(std::chrono::milliseconds timeout) const;
  /// Stops taking jobs; the current one finishes. Idempotent.
  void stop();
  /// Joins the builder if it finishes within `timeout`; false if it is still building (the
  /// caller may then exit without joining).
  bool join(std::chrono::milliseconds timeout);

  const RegistryOptions& options() const { return options_; }

 private:
  enum class JobKind { Load, Build };
  struct Job {
    std::shared_ptr<MeshEntry> entry;
    JobKind kind;
    BuildParams build;
  };

  std::shared_ptr<MeshEntry> add_entry(std::shared_ptr<MeshEntry> entry);
  void enqueue(Job job);
  void builder_loop();
  void run_job(const Job& job);
  void build_graph(const std::shared_ptr<MeshEntry>& entry, std::shared_ptr<const MeshData> data,
                   const BuildParams& build);
  void install(const std::shared_ptr<MeshEntry>& entry, std::shared_ptr<const LoadedMesh> mesh);
  void fail(const std::shared_ptr<MeshEntry>& entry, const std::string& error);

  RegistryOptions options_;
  RegistryHooks hooks_;
  mutable std::mutex mutex_;  // map, order, jobs
  std::map<std::string, std::shared_ptr<MeshEntry>> by_id_;
  std::vector<std::shared_ptr<MeshEntry>> order_;
  std::deque<Job> jobs_;
  bool stopping_ = false;
  bool running_job_ = false;
  mutable std::condition_variable jobs_cv_;
  mutable std::condition_variable idle_cv_;
  std::mutex reload_mutex_;  // one reload at a time
  std::thread builder_;
  std::atomic<bool> builder_done_{false};
};

/// The status as the protocol's summary (mesh.list, admin replies).
protocol::MeshSummary to_summary(const MeshStatus& status);
/// "message [Reason]" of a core error, or what() of anything else.
std::string describe_exception(const std::exception& e);
/// `text` in double quotes, as error messages name mesh ids and files.
std::string quote(std::string_view text);

}  // namespace geoprox::server
