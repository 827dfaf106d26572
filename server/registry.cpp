#include "server/registry.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>

#include "core/base/errors.h"
#include "core/mesh/mesh_io.h"
#include "core/mesh/mesh_repair.h"
#include "core/graph/proximity_graph.h"
#include "core/graph/refined_surface.h"
#include "core/mesh/riemannian_metric.h"

namespace geoprox::server {

namespace fs = std::filesystem;
using protocol::ErrorReason;
using protocol::ProtocolError;

std::string describe_exception(const std::exception& e) {
  if (const auto* error = dynamic_cast<const geoprox::Error*>(&e)) {
    return std::string(e.what()) + " [" + error->reason() + "]";
  }
  return e.what();
}

std::string quote(std::string_view text) {
  std::string out = "\"";
  out += text;
  out += '"';
  return out;
}

std::string mesh_version_of(const MappedGraphFile& file) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(file.checksum()));
  return buf;
}

// ---- LoadedMesh ----

LoadedMesh::LoadedMesh(std::shared_ptr<const MeshData> data, MappedGraphFile file,
                       std::size_t max_scratch, QueryScratch::RunBoth run_both)
    : graph_(std::move(data), std::move(file)),
      version_(mesh_version_of(graph_.file)),
      max_scratch_(max_scratch == 0 ? 1 : max_scratch),
      run_both_(std::move(run_both)) {}

LoadedMesh::~LoadedMesh() = default;

LoadedMesh::Lease::~Lease() {
  if (!owner_ || !slot_) return;
  slot_->scratch.set_interrupt(nullptr);
  {
    std::lock_guard lock(owner_->pool_mutex_);
    owner_->free_.push_back(std::move(slot_));
  }
  owner_->pool_cv_.notify_one();
}

ExponentialMap& LoadedMesh::Lease::exponential_map() {
  if (!slot_->expmap) slot_->expmap = std::make_unique<ExponentialMap>(owner_->query());
  return *slot_->expmap;
}

GeodesicSpline& LoadedMesh::Lease::spline() {
  if (!slot_->spline) slot_->spline = std::make_unique<GeodesicSpline>(owner_->query());
  return *slot_->spline;
}

LoadedMesh::Lease LoadedMesh::lease() const {
  std::unique_lock lock(pool_mutex_);
  for (;;) {
    if (!free_.empty()) {
      // This thread's own slot if it is free (few slots: one per compute thread), else the
      // one released last.
      const std::thread::id me = std::this_thread::get_id();
      auto own = std::find_if(free_.begin(), free_.end(),
                              [&](const auto& slot) { return slot->last_thread == me; });
      if (own != free_.end()) std::iter_swap(own, free_.end() - 1);
      auto slot = std::move(free_.back());
      free_.pop_back();
      slot->last_thread = me;
      return Lease(this, std::move(slot));
    }
    if (created_ < max_scratch_) {
      ++created_;
      lock.unlock();
      try {
        auto slot = std::make_unique<ScratchSlot>(ScratchSlot{
            graph_.query->make_scratch(), nullptr, nullptr, std::this_thread::get_id()});
        slot->scratch.set_run_both(run_both_);
        return Lease(this, std::move(slot));
      } catch (...) {
        std::lock_guard relock(pool_mutex_);
        --created_;
        throw;
      }
    }
    pool_cv_.wait(lock);
  }
}

std::size_t LoadedMesh::scratch_created() const {
  std::lock_guard lock(pool_mutex_);
  return created_;
}

// ---- MeshEntry ----

std::shared_ptr<const LoadedMesh> MeshEntry::loaded() const {
  std::lock_guard lock(mutex_);
  return loaded_;
}

MeshStatus MeshEntry::status() const {
  std::lock_guard lock(mutex_);
  MeshStatus s;
  s.id = id_;
  s.loaded = loaded_;
  s.state = busy_ ? protocol::MeshState::Building
                  : (loaded_ ? protocol::MeshState::Ready : protocol::MeshState::Failed);
  s.progress = loaded_ && !busy_ ? 1.0 : progress_;
  s.phase = busy_ ? phase_ : std::nullopt;
  s.error = error_;
  s.vertices = vertices_;
  s.faces = faces_;
  s.edges = edges_;
  s.mesh_path = mesh_path_;
  s.graph_path = graph_path_;
  s.build = build_;
  return s;
}

protocol::MeshSummary to_summary(const MeshStatus& status) {
  protocol::MeshSummary out;
  out.mesh = status.id;
  out.state = status.state;
  out.progress = status.progress;
  out.phase = status.phase;
  out.error = status.error;
  out.vertices = status.vertices;
  out.faces = status.faces;
  if (status.loaded) {
    out.mesh_version = status.loaded->version();
    out.samples = status.loaded->file().counts().samples;
  }
  return out;
}

// ---- Registry ----

Registry::Registry(RegistryOptions options, RegistryHooks hooks)
    : options_(std::move(options)), hooks_(std::move(hooks)) {
  builder_ = std::thread([this] { builder_loop(); });
}

Registry::~Registry() {
  stop();
  if (builder_.joinable()) builder_.join();
}

void Registry::stop() {
  std::deque<Job> dropped;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    dropped.swap(jobs_);
  }
  for (const Job& job : dropped) {
    std::lock_guard lock(job.entry->mutex_);
    job.entry->busy_ = false;
  }
  jobs_cv_.notify_all();
  idle_cv_.notify_all();
}

bool Registry::join(std::chrono::milliseconds timeout) {
  stop();
  std::unique_lock lock(mutex_);
  if (!idle_cv_.wait_for(lock, timeout, [&] { return builder_done_.load(); })) return false;
  lock.unlock();
  if (builder_.joinable()) builder_.join();
  return true;
}

bool Registry::builder_busy() const {
  std::lock_guard lock(mutex_);
  return running_job_ || !jobs_.empty();
}

bool Registry::wait_idle(std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  return idle_cv_.wait_for(lock, timeout,
                           [&] { return (!running_job_ && jobs_.empty()) || stopping_; });
}

std::shared_ptr<MeshEntry> Registry::find(const std::string& id) const {
  std::lock_guard lock(mutex_);
  auto it = by_id_.find(id);
  return it == by_id_.end() ? nullptr : it->second;
}

std::vector<std::shared_ptr<MeshEntry>> Registry::entries() const {
  std::lock_guard lock(mutex_);
  return order_;
}

std::size_t Registry::size() const {
  std::lock_guard lock(mutex_);
  return order_.size();
}

std::size_t Registry::ready_count() const {
  std::size_t n = 0;
  for (const auto& entry : entries()) {
    if (entry->loaded()) ++n;
  }
  return n;
}

std::shared_ptr<MeshEntry> Registry::add_entry(std::shared_ptr<MeshEntry> entry) {
  // Caller holds mutex_.
  entry->busy_ = true;
  entry->phase_ = "queued";
  by_id_[entry->id()] = entry;
  order_.push_back(entry);
  return entry;
}

void Registry::enqueue(Job job) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) {
      std::lock_guard entry_lock(job.entry->mutex_);
      job.entry->busy_ = false;
      return;
    }
    jobs_.push_back(std::move(job));
  }
  jobs_cv_.notify_one();
}

void Registry::add_configured(const std::vector<MeshConfig>& meshes) {
  for (const MeshConfig& m : meshes) {
    std::shared_ptr<MeshEntry> entry;
    {
      std::lock_guard lock(mutex_);
      if (by_id_.count(m.id)) continue;
      entry = add_entry(std::make_shared<MeshEntry>(m.id, m.mesh_path, m.graph_path, m.build));
    }
    enqueue(Job{entry, JobKind::Load, m.build});
  }
}

void Registry::builder_loop() {
  for (;;) {
    Job job;
    {
      std::unique_lock lock(mutex_);
      jobs_cv_.wait(lock, [&] { return stopping_ || !jobs_.empty(); });
      if (stopping_) break;
      job = std::move(jobs_.front());
      jobs_.pop_front();
      running_job_ = true;
    }
    bool removed = false;
    {
      std::lock_guard lock(job.entry->mutex_);
      removed = job.entry->removed_;
      if (removed) job.entry->busy_ = false;
    }
    if (!removed) run_job(job);
    {
      std::lock_guard lock(mutex_);
      running_job_ = false;
    }
    idle_cv_.notify_all();
  }
  {
    std::lock_guard lock(mutex_);
    builder_done_ = true;
    running_job_ = false;
  }
  idle_cv_.notify_all();
}

namespace {

void set_phase(std::mutex& mutex, std::optional<std::string>& phase, double& progress,
               const std::string& name, double fraction) {
  std::lock_guard lock(mutex);
  phase = name;
  progress = fraction;
}

// A mesh refused for what repair fixes, loaded without repair: the error says how to serve it.
std::string repair_hint(const std::exception& e, bool repair) {
  const auto* error = dynamic_cast<const MeshError*>(&e);
  if (repair || error == nullptr || !repair_fixes(error->code())) return {};
  return " (\"repair\": true serves it repaired)";
}

// A graph whose samples leave points beyond its link radius is served, with a warning that
// says where and what to do (the build's stats, when it was just built, say more).
void warn_if_sparse(const std::string& id, const ProximityGraphView& graph,
                    const ProximityGraphStats* stats = nullptr) {
  if (const std::string warning = sparse_sampling_warning(graph, stats); !warning.empty()) {
    spdlog::warn("mesh {}: {}", id, warning);
  }
}

}  // namespace

void Registry::run_job(const Job& job) {
  const auto& entry = job.entry;
  const auto start = std::chrono::steady_clock::now();
  std::shared_ptr<const MeshData> data;
  try {
    set_phase(entry->mutex_, entry->phase_, entry->progress_, "loading", 0);
    spdlog::info("mesh {}: loading {}", entry->id(), entry->mesh_path().string());
    if (!job.build.metric_path.empty()) {
      spdlog::info("mesh {}: metric {}", entry->id(), job.build.metric_path.string());
    }
    data = MeshData::load(entry->mesh_path().string(), job.build.metric_path.string(),
                          MeshLoadOptions{.repair = job.build.repair});
    if (data->repair) {
      spdlog::info("mesh {}: repaired {}: {}", entry->id(), entry->mesh_path().filename().string(),
                   describe_repair_changes(*data->repair));
    }
    {
      std::lock_guard lock(entry->mutex_);
      entry->vertices_ = data->mesh.num_vertices();
      entry->faces_ = data->mesh.num_faces();
      entry->edges_ = data->mesh.num_edges();
    }
  } catch (const std::exception& e) {
    fail(entry, entry->mesh_path().filename().string() + ": " + describe_exception(e) +
                    repair_hint(e, job.build.repair));
    return;
  }
  // Temporaries of a write that a kill -9 interrupted: never opened, removed here.
  for (const std::string& stale : remove_stale_graph_temporaries(entry->graph_path().string())) {
    spdlog::warn("mesh {}: removed {}, left by a graph write that was interrupted", entry->id(),
                 stale);
  }
  if (job.kind == JobKind::Load) {
    std::error_code ec;
    if (fs::exists(entry->graph_path(), ec)) {
      try {
        set_phase(entry->mutex_, entry->phase_, entry->progress_, "mapping graph", 0);
        MappedGraphFile file = MappedGraphFile::open(entry->graph_path().string());
        file.verify_mesh(data->mesh, data->geometry);
        auto loaded =
            std::make_shared<const LoadedMesh>(data, std::move(file), options_.max_scratch_per_mesh,
                                             options_.run_both);
        const double ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                .count();
        spdlog::info("mesh {}: ready, graph {} mapped (version {}, {:.1f} ms)", entry->id(),
                     entry->graph_path().string(), loaded->version(), ms);
        if (const auto from = loaded->file().refined_from()) {
          spdlog::info("mesh {}: the graph is over a refinement to {} vertices, {} faces "
                       "(edges <= {:.6g}); queries stay in the mesh's ids",
                       entry->id(), loaded->file().counts().vertices,
                       loaded->file().counts().faces, from->max_edge_length);
        }
        warn_if_sparse(entry->id(), loaded->file().view());
        install(entry, std::move(loaded));
        return;
      } catch (const std::exception& e) {
        spdlog::warn("mesh {}: graph {} is unusable ({}); rebuilding it", entry->id(),
                     entry->graph_path().string(), describe_exception(e));
      }
    } else {
      spdlog::info("mesh {}: no graph at {}; building it", entry->id(),
                   entry->graph_path().string());
    }
  }
  try {
    build_graph(entry, std::move(data), job.build);
  } catch (const std::exception& e) {
    fail(entry, "graph build: " + describe_exception(e));
  }
}

void Registry::build_graph(const std::shared_ptr<MeshEntry>& entry,
                           std::shared_ptr<const MeshData> data, const BuildParams& build) {
  const auto start = std::chrono::steady_clock::now();
  ProximityGraphOptions options;
  options.num_samples = build.samples;
  options.neighbors = build.neighbors;
  options.link_samples = build.link_samples;
  options.sampling = build.sampling;
  options.threads = options_.build_threads;
  set_phase(entry->mutex_, entry->phase_, entry->progress_, "sampling", 0);
  MeshEntry* raw = entry.get();
  std::optional<ProximityGraphStats> stats;
  {
    ProximityGraph graph = build_proximity_graph(
        data->mesh, data->geometry, options, [raw](const std::string& phase, double fraction) {
          std::lock_guard lock(raw->mutex_);
          raw->phase_ = phase;
          raw->progress_ = fraction;
        });
    set_phase(entry->mutex_, entry->phase_, entry->progress_, "writing", 1);
    const fs::path& path = entry->graph_path();
    if (path.has_parent_path()) fs::create_directories(path.parent_path());
    GraphFileMetadata metadata;
    metadata.sampling = build.sampling;
    metadata.source_mesh = entry->mesh_path().filename().string();
    write_graph_file(path.string(), data->mesh, data->geometry, graph, metadata);
    stats = graph.stats;
    if (graph.refined) {
      spdlog::info(
          "mesh {}: the first pass left points {:.6g} from every sample, over half its link "
          "radius {:.6g} ({} faces, {:.3g}% of the area, beyond it); built on a refinement to "
          "{} vertices, {} faces (edges <= {:.6g}) instead ({:.2f} s first pass, {:.2f} s "
          "refining); queries stay in the mesh's ids",
          entry->id(), graph.stats.unrefined_covering_radius, graph.stats.unrefined_link_radius,
          graph.stats.unrefined_faces_beyond_link,
          100 * graph.stats.unrefined_area_fraction_beyond_link,
          graph.refined->mesh().num_vertices(), graph.refined->mesh().num_faces(),
          graph.refined->max_edge_length(), graph.stats.unrefined_build_seconds,
          graph.stats.refinement_seconds);
    }
  }
  MappedGraphFile file = MappedGraphFile::open(entry->graph_path().string());
  file.verify_mesh(data->mesh, data->geometry);
  auto loaded =
      std::make_shared<const LoadedMesh>(data, std::move(file), options_.max_scratch_per_mesh,
                                             options_.run_both);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  spdlog::info("mesh {}: graph built and written to {} in {:.2f} s (version {}, {} samples)",
               entry->id(), entry->graph_path().string(), seconds, loaded->version(),
               loaded->file().counts().samples);
  warn_if_sparse(entry->id(), loaded->file().view(), &*stats);
  install(entry, std::move(loaded));
}

void Registry::install(const std::shared_ptr<MeshEntry>& entry,
                       std::shared_ptr<const LoadedMesh> mesh) {
  std::string version = mesh->version();
  {
    std::lock_guard lock(entry->mutex_);
    entry->busy_ = false;
    if (entry->removed_) return;
    entry->loaded_ = std::move(mesh);
    entry->error_.reset();
    entry->progress_ = 1;
    entry->phase_.reset();
  }
  if (hooks_.on_ready) hooks_.on_ready(entry->id(), version);
}

void Registry::fail(const std::shared_ptr<MeshEntry>& entry, const std::string& error) {
  bool serving = false;
  {
    std::lock_guard lock(entry->mutex_);
    entry->busy_ = false;
    entry->error_ = error;
    entry->phase_.reset();
    serving = entry->loaded_ != nullptr;
  }
  if (serving) {
    spdlog::error("mesh {}: {} (the graph in service stays)", entry->id(), error);
  } else {
    spdlog::error("mesh {}: failed: {}", entry->id(), error);
  }
  if (hooks_.on_failed) hooks_.on_failed(entry->id(), error);
}

// ---- Admin ----

namespace {

bool is_within(const fs::path& path, const fs::path& base) {
  auto p = path.begin();
  for (auto b = base.begin(); b != base.end(); ++b, ++p) {
    if (b->empty()) continue;  // trailing separator
    if (p == path.end() || *p != *b) return false;
  }
  return true;
}


}  // namespace

fs::path Registry::confine(const std::string& text, const std::string& field) const {
  if (text.empty()) {
    throw ProtocolError(ErrorReason::PathNotAllowed, field + " is empty");
  }
  if (text.find('\0') != std::string::npos || text.find('\\') != std::string::npos) {
    throw ProtocolError(ErrorReason::PathNotAllowed,
                        field + " contains a NUL byte or a backslash");
  }
  const fs::path given(text);
  for (const auto& part : given) {
    if (part == "..") {
      throw ProtocolError(ErrorReason::PathNotAllowed,
                          field + " " + quote(text) +
                              " contains a '..' component (paths stay inside the data directory)");
    }
  }
  const fs::path base = options_.data_dir.lexically_normal();
  const fs::path full =
      given.is_absolute() ? given.lexically_normal() : (base / given).lexically_normal();
  if (!is_within(full, base)) {
    throw ProtocolError(ErrorReason::PathNotAllowed,
                        field + " " + quote(text) + " is outside the data directory");
  }
  std::error_code ec;
  const fs::path real_base = fs::weakly_canonical(base, ec);
  if (ec) {
    throw ProtocolError(ErrorReason::Internal, "the data directory cannot be resolved: " +
                                                   ec.message());
  }
  const fs::path real = fs::weakly_canonical(full, ec);
  if (ec || !is_within(real, real_base)) {
    throw ProtocolError(ErrorReason::PathNotAllowed,
                        field + " " + quote(text) +
                            " resolves (through a symbolic link) outside the data directory");
  }
  return full;
}

namespace {

BuildParams apply_overrides(BuildParams build, const protocol::BuildOptions& options) {
  if (options.samples) build.samples = *options.samples;
  if (options.neighbors) build.neighbors = *options.neighbors;
  if (options.sampling) {
    switch (*options.sampling) {
      case protocol::SamplingMethod::Fmm:
        build.sampling = SamplingMethod::FastMarching;
        break;
      case protocol::SamplingMethod::Exact:
        build.sampling = SamplingMethod::Exact;
        break;
      case protocol::SamplingMethod::Auto:
        build.sampling = SamplingMethod::Automatic;
        break;
    }
  }
  return build;
}

}  // namespace

MeshStatus Registry::register_mesh(const protocol::AdminRegisterParams& params) {
  if (!protocol::is_valid_mesh_id(params.mesh)) {
    throw ProtocolError(ErrorReason::InvalidParams,
                        "params.mesh: " + quote(params.mesh) + " is not a valid mesh id");
  }
  if (find(params.mesh)) {
    throw ProtocolError(ErrorReason::MeshExists,
                        "params.mesh: a mesh " + quote(params.mesh) + " is already registered");
  }
  const fs::path mesh_path = confine(params.mesh_file, "params.mesh_file");
  std::error_code ec;
  const auto status = fs::status(mesh_path, ec);
  if (ec || !fs::exists(status)) {
    throw ProtocolError(ErrorReason::NotFound,
                        "params.mesh_file " + quote(params.mesh_file) + " does not exist");
  }
  if (!fs::is_regular_file(status)) {
    throw ProtocolError(ErrorReason::BadMeshFile,
                        "params.mesh_file " + quote(params.mesh_file) + " is not a regular file");
  }
  if (!std::ifstream(mesh_path, std::ios::binary)) {
    throw ProtocolError(ErrorReason::BadMeshFile,
                        "params.mesh_file " + quote(params.mesh_file) + " cannot be read");
  }
  const fs::path graph_path =
      params.graph_file ? confine(*params.graph_file, "params.graph_file")
                        : (options_.graph_dir / (params.mesh + ".geoprox")).lexically_normal();
  if (params.graph_file && fs::is_directory(graph_path, ec)) {
    throw ProtocolError(ErrorReason::BadMeshFile,
                        "params.graph_file " + quote(*params.graph_file) + " is a directory");
  }
  BuildParams build = apply_overrides(BuildParams{}, params.build);
  build.repair = params.repair;
  std::shared_ptr<MeshEntry> entry;
  {
    std::lock_guard lock(mutex_);
    if (by_id_.count(params.mesh)) {
      throw ProtocolError(ErrorReason::MeshExists,
                          "params.mesh: a mesh " + quote(params.mesh) + " is already registered");
    }
    for (const auto& other : order_) {
      if (other->graph_path() == graph_path) {
        throw ProtocolError(ErrorReason::InvalidParams,
                            "params.graph_file: " + graph_path.filename().string() +
                                " is the graph file of mesh " + quote(other->id()));
      }
    }
    entry = add_entry(std::make_shared<MeshEntry>(params.mesh, mesh_path, graph_path, build));
  }
  spdlog::info("mesh {}: registered (mesh {}{}, graph {})", params.mesh, mesh_path.string(),
               build.repair ? ", repaired" : "", graph_path.string());
  enqueue(Job{entry, JobKind::Load, build});
  return entry->status();
}

MeshStatus Registry::rebuild(const std::string& id, const protocol::BuildOptions& overrides) {
  auto entry = find(id);
  if (!entry) {
    throw ProtocolError(ErrorReason::UnknownMesh,
                        "params.mesh: no mesh " + quote(id) + " (mesh.list lists them)");
  }
  BuildParams build;
  bool start = false;
  {
    std::lock_guard lock(entry->mutex_);
    // Already loading or building: that job's result will be swapped in.
    if (!entry->busy_) {
      build = apply_overrides(entry->build_, overrides);
      entry->busy_ = true;
      entry->progress_ = 0;
      entry->phase_ = "queued";
      start = true;
    }
  }
  if (start) {
    spdlog::info("mesh {}: rebuild requested", id);
    enqueue(Job{entry, JobKind::Build, build});
  }
  return entry->status();
}

void Registry::unregister(const std::string& id) {
  std::shared_ptr<MeshEntry> entry;
  {
    std::lock_guard lock(mutex_);
    auto it = by_id_.find(id);
    if (it == by_id_.end()) {
      throw ProtocolError(ErrorReason::UnknownMesh,
                          "params.mesh: no mesh " + quote(id) + " (mesh.list lists them)");
    }
    entry = it->second;
    by_id_.erase(it);
    std::erase(order_, entry);
  }
  {
    std::lock_guard lock(entry->mutex_);
    entry->removed_ = true;
    entry->loaded_.reset();  // requests in flight keep their own reference
  }
  spdlog::info("mesh {}: unregistered", id);
}

std::vector<protocol::ReloadOutcome> Registry::reload(const std::optional<std::string>& id) {
  std::lock_guard reload_lock(reload_mutex_);
  std::vector<std::shared_ptr<MeshEntry>> targets;
  if (id) {
    auto entry = find(*id);
    if (!entry) {
      throw ProtocolError(ErrorReason::UnknownMesh,
                          "params.mesh: no mesh " + quote(*id) + " (mesh.list lists them)");
    }
    targets.push_back(std::move(entry));
  } else {
    targets = entries();
  }
  std::vector<protocol::ReloadOutcome> outcomes;
  for (const auto& entry : targets) {
    protocol::ReloadOutcome outcome;
    outcome.mesh = entry->id();
    std::shared_ptr<const LoadedMesh> current;
    bool busy = false;
    {
      std::lock_guard lock(entry->mutex_);
      current = entry->loaded_;
      busy = entry->busy_;
      if (!current && !busy) {
        entry->busy_ = true;
        entry->progress_ = 0;
        entry->phase_ = "queued";
      }
    }
    if (!current) {
      if (!busy) enqueue(Job{entry, JobKind::Load, entry->status().build});
      outcome.error = ProtocolError(ErrorReason::MeshNotReady,
                                    busy ? "mesh " + quote(entry->id()) +
                                               " is still loading or building; nothing to reload"
                                         : "mesh " + quote(entry->id()) +
                                               " had no graph in service; loading it again in "
                                               "the background (mesh.list shows the progress)");
      outcomes.push_back(std::move(outcome));
      continue;
    }
    outcome.mesh_version = current->version();
    try {
      MappedGraphFile file = MappedGraphFile::open(entry->graph_path().string());
      file.verify_mesh(current->data().mesh, current->data().geometry);
      if (mesh_version_of(file) == current->version()) {
        spdlog::info("mesh {}: reload: graph file unchanged (version {})", entry->id(),
                     current->version());
        outcomes.push_back(std::move(outcome));
        continue;
      }
      auto fresh = std::make_shared<const LoadedMesh>(current->data_ptr(), std::move(file),
                                                      options_.max_scratch_per_mesh,
                                                      options_.run_both);
      const std::string version = fresh->version();
      const std::shared_ptr<const LoadedMesh> installed = fresh;
      {
        std::lock_guard lock(entry->mutex_);
        if (entry->removed_) continue;
        entry->loaded_ = std::move(fresh);
        entry->error_.reset();
      }
      spdlog::info("mesh {}: reloaded, version {} -> {}", entry->id(), current->version(),
                   version);
      warn_if_sparse(entry->id(), installed->file().view());
      outcome.reloaded = true;
      outcome.mesh_version = version;
      if (hooks_.on_ready) hooks_.on_ready(entry->id(), version);
    } catch (const std::exception& e) {
      std::string message = entry->graph_path().filename().string() + ": " + e.what();
      ErrorReason reason = ErrorReason::BadMeshFile;
      if (const auto* error = dynamic_cast<const geoprox::Error*>(&e)) {
        if (error->code() == geoprox::ErrorCode::FileNotFound) reason = ErrorReason::NotFound;
      }
      message += "; the old graph stays in service";
      spdlog::error("mesh {}: reload failed: {}", entry->id(), describe_exception(e));
      outcome.error = ProtocolError(reason, message);
      if (hooks_.on_failed) hooks_.on_failed(entry->id(), message);
    }
    outcomes.push_back(std::move(outcome));
  }
  return outcomes;
}

}  // namespace geoprox::server
