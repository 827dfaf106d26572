// geoprox.native: geoprox's queries inside a Python process, on numpy arrays, over the same
// graph files the daemon maps (docs/python.md is the tutorial and the reference).
//
// Points come in the three forms of the client: a 1-D integer array of vertex ids, a tuple
// (faces, bary) of a 1-D integer array and an (n, 3) float array of barycentrics, or an (n, 3)
// float array of positions, snapped to the surface as the daemon snaps them. They are resolved
// and checked as the daemon resolves wire points (server/service.cpp), so that answers equal
// the daemon's to the bit. Unreachable pairs and vertices are NaN.
//
// Every query releases the GIL while it computes; batches (pairs of distance() and path(), rows
// of matrix()) run on OpenMP threads, each with a scratch taken from the graph's pool and given
// back afterwards, so that a scratch's buffers are reused from call to call.
#include <pybind11/eval.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/base/errors.h"
#include "core/graph/graph_file.h"
#include "core/graph/loaded_graph.h"
#include "core/graph/proximity_graph.h"
#include "core/mesh/mesh.h"
#include "core/mesh/mesh_io.h"
#include "core/mesh/surface_point.h"
#include "core/query/geodesic_query.h"

namespace py = pybind11;

namespace geoprox::python {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double nan_if_infinite(double d) { return std::isfinite(d) ? d : kNaN; }

// ---------------------------------------------------------------------------------------------
// Errors: one Python class per core exception class, each with a `reason` attribute (the
// ErrorCode's name, e.g. "FaceOutOfRange").

struct ErrorClasses {
  py::object base, invalid_input, mesh_error, file_error, unreachable, resource_exhausted,
      interrupted, internal_error;
};

ErrorClasses& error_classes() {
  static ErrorClasses* classes = new ErrorClasses();  // lives as long as the interpreter
  return *classes;
}

void define_errors(py::module_& m) {
  py::dict scope;
  scope["__name__"] = "geoprox.native";
  py::exec(R"(
class Error(Exception):
    """A geoprox core error; `reason` is its code's name, e.g. "FaceOutOfRange"."""
    reason = "InternalError"
class InvalidInput(Error, ValueError):
    """A value given by the caller is invalid (point ids, barycentrics, options)."""
class MeshError(Error, ValueError):
    """A mesh is unusable (empty, non-manifold, non-finite coordinates...)."""
class FileError(Error, OSError):
    """A file cannot be read, parsed or written, or a graph file is for another mesh."""
class Unreachable(Error):
    """Two points lie in different components."""
class ResourceExhausted(Error, MemoryError):
    """The work would need more memory than its bound allows."""
class Interrupted(Error):
    """The work was cancelled or ran past its deadline."""
class InternalError(Error, RuntimeError):
    """A bug in geoprox."""
)",
           scope);
  ErrorClasses& c = error_classes();
  c.base = scope["Error"];
  c.invalid_input = scope["InvalidInput"];
  c.mesh_error = scope["MeshError"];
  c.file_error = scope["FileError"];
  c.unreachable = scope["Unreachable"];
  c.resource_exhausted = scope["ResourceExhausted"];
  c.interrupted = scope["Interrupted"];
  c.internal_error = scope["InternalError"];
  for (const char* name : {"Error", "InvalidInput", "MeshError", "FileError", "Unreachable",
                           "ResourceExhausted", "Interrupted", "InternalError"}) {
    m.attr(name) = scope[name];
  }
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      const ErrorClasses& classes = error_classes();
      const py::object* cls = &classes.internal_error;
      if (dynamic_cast<const InvalidInput*>(&e)) cls = &classes.invalid_input;
      else if (dynamic_cast<const MeshError*>(&e)) cls = &classes.mesh_error;
      else if (dynamic_cast<const FileError*>(&e)) cls = &classes.file_error;
      else if (dynamic_cast<const Unreachable*>(&e)) cls = &classes.unreachable;
      else if (dynamic_cast<const ResourceExhausted*>(&e)) cls = &classes.resource_exhausted;
      else if (dynamic_cast<const Interrupted*>(&e)) cls = &classes.interrupted;
      py::object exc = (*cls)(py::str(e.reason() + ": " + e.what()));
      exc.attr("reason") = py::str(e.reason());
      PyErr_SetObject(cls->ptr(), exc.ptr());
    }
  });
}

// ---------------------------------------------------------------------------------------------
// Arrays in and out.

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IndexArray = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;

bool is_integer_array(const py::array& a) {
  const char kind = a.dtype().kind();
  return kind == 'i' || kind == 'u';
}

/// `value` as a C-contiguous int64 array; TypeError unless it holds integers.
IndexArray integer_array(const py::handle& value, const std::string& what) {
  py::array a = py::array::ensure(value);
  if (!a || (a.size() > 0 && !is_integer_array(a))) {
    throw py::type_error(what + " must be an array of integers");
  }
  return IndexArray::ensure(a);
}

DoubleArray float_array(const py::handle& value, const std::string& what) {
  py::array a = py::array::ensure(value);
  if (!a) throw py::type_error(what + " must be an array of numbers");
  const char kind = a.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u') {
    throw py::type_error(what + " must be an array of numbers, not dtype " +
                         std::string(py::str(a.dtype())));
  }
  return DoubleArray::ensure(a);
}

void require_rows_of_3(const py::array& a, const std::string& what) {
  if (a.ndim() != 2 || a.shape(1) != 3) {
    throw py::value_error(what + " must have shape (n, 3), not " +
                          std::string(py::str(py::tuple(py::cast(std::vector<py::ssize_t>(
                              a.shape(), a.shape() + a.ndim()))))));
  }
}

std::uint32_t checked_id(std::int64_t id, const std::string& what, py::ssize_t i) {
  if (id < 0 || id > std::numeric_limits<std::uint32_t>::max()) {
    throw py::value_error(what + "[" + std::to_string(i) + "] = " + std::to_string(id) +
                          " is not an id (0 to 2^32 - 1)");
  }
  return static_cast<std::uint32_t>(id);
}

/// Points as given from Python, parsed (with the GIL) but not yet resolved on a mesh.
struct GivenPoints {
  enum class Kind { Vertex, Face, Position } kind = Kind::Vertex;
  std::vector<SurfacePoint> points;  ///< vertices and face points
  std::vector<Vec3> positions;       ///< positions to snap
  std::size_t size() const { return kind == Kind::Position ? positions.size() : points.size(); }
};

GivenPoints parse_points(const py::handle& value, const std::string& what) {
  GivenPoints given;
  if (py::isinstance<py::tuple>(value)) {
    const py::tuple pair = py::reinterpret_borrow<py::tuple>(value);
    if (pair.size() != 2) {
      throw py::type_error(what + ": face points are a tuple (faces, bary), not a tuple of " +
                           std::to_string(pair.size()));
    }
    const IndexArray faces = integer_array(pair[0], what + " faces");
    const DoubleArray bary = float_array(pair[1], what + " barycentrics");
    if (faces.ndim() != 1) throw py::value_error(what + " faces must be a 1-D array");
    require_rows_of_3(bary, what + " barycentrics");
    if (bary.shape(0) != faces.shape(0)) {
      throw py::value_error(what + ": " + std::to_string(faces.shape(0)) + " faces but " +
                            std::to_string(bary.shape(0)) + " rows of barycentrics");
    }
    given.kind = GivenPoints::Kind::Face;
    auto f = faces.unchecked<1>();
    auto b = bary.unchecked<2>();
    given.points.reserve(static_cast<std::size_t>(faces.shape(0)));
    for (py::ssize_t i = 0; i < faces.shape(0); ++i) {
      std::array<double, 3> w{b(i, 0), b(i, 1), b(i, 2)};
      // As the protocol's parser does; the core checks the coordinates themselves.
      normalize_barycentrics(w);
      given.points.push_back(
          SurfacePoint::face(checked_id(f(i), what + " faces", i), w[0], w[1], w[2]));
    }
    return given;
  }
  py::array a = py::array::ensure(value);
  if (!a) throw py::type_error(what + " must be vertex ids, (faces, bary) or positions");
  if (a.ndim() == 0) a = a.reshape({1});
  if (a.ndim() == 1 && (is_integer_array(a) || a.size() == 0)) {
    const IndexArray ids = IndexArray::ensure(a);
    auto v = ids.unchecked<1>();
    given.points.reserve(static_cast<std::size_t>(ids.shape(0)));
    for (py::ssize_t i = 0; i < ids.shape(0); ++i) {
      given.points.push_back(SurfacePoint::vertex(checked_id(v(i), what, i)));
    }
    return given;
  }
  if (a.ndim() == 2 && a.shape(1) == 3) {
    const DoubleArray p = float_array(a, what + " positions");
    auto r = p.unchecked<2>();
    given.kind = GivenPoints::Kind::Position;
    given.positions.reserve(static_cast<std::size_t>(p.shape(0)));
    for (py::ssize_t i = 0; i < p.shape(0); ++i) {
      given.positions.push_back({r(i, 0), r(i, 1), r(i, 2)});
    }
    return given;
  }
  throw py::type_error(what + " must be a 1-D integer array of vertex ids, a tuple (faces, "
                       "bary) or an (n, 3) float array of positions");
}

// ---------------------------------------------------------------------------------------------
// The graph: a mesh, a graph (mapped from a file or built in memory) and the query over both.

class ScratchPool {
 public:
  explicit ScratchPool(const GeodesicQuery& query) : query_(&query) {}
  QueryScratch take() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!free_.empty()) {
        QueryScratch s = std::move(free_.back());
        free_.pop_back();
        return s;
      }
    }
    return query_->make_scratch();
  }
  void give_back(QueryScratch s) {
    std::lock_guard<std::mutex> lock(mutex_);
    free_.push_back(std::move(s));
  }

 private:
  const GeodesicQuery* query_;
  std::mutex mutex_;
  std::vector<QueryScratch> free_;
};

/// A scratch of the pool for one thread's part of a call.
class PooledScratch {
 public:
  explicit PooledScratch(ScratchPool& pool) : pool_(&pool), scratch_(pool.take()) {}
  ~PooledScratch() { pool_->give_back(std::move(scratch_)); }
  PooledScratch(const PooledScratch&) = delete;
  PooledScratch& operator=(const PooledScratch&) = delete;
  QueryScratch& get() { return scratch_; }

 private:
  ScratchPool* pool_;
  QueryScratch scratch_;
};

/// Runs body(i) for i in [0, n) on `threads` OpenMP threads (0: OpenMP's default), each with a
/// pooled scratch; rethrows the first exception after all threads stop.
template <typename Body>
void parallel_for(std::size_t n, int threads, ScratchPool& pool, const Body& body) {
  if (n == 0) return;
  const int wanted = threads > 0 ? threads : omp_get_max_threads();
  const int count = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(wanted), n));
  std::exception_ptr failure;
  std::mutex failure_mutex;
#pragma omp parallel num_threads(count)
  {
    std::optional<PooledScratch> scratch;
    try {
      scratch.emplace(pool);
    } catch (...) {
      std::lock_guard<std::mutex> lock(failure_mutex);
      if (!failure) failure = std::current_exception();
    }
#pragma omp for schedule(dynamic, 1)
    for (std::size_t i = 0; i < n; ++i) {
      if (!scratch) continue;
      {
        std::lock_guard<std::mutex> lock(failure_mutex);
        if (failure) continue;
      }
      try {
        body(i, scratch->get());
      } catch (...) {
        std::lock_guard<std::mutex> lock(failure_mutex);
        if (!failure) failure = std::current_exception();
      }
    }
  }
  if (failure) std::rethrow_exception(failure);
}

struct PathArrays {
  double distance = kNaN;
  bool exact = false;
  py::array_t<std::int64_t> faces;
  py::array_t<double> bary;
  py::array_t<double> xyz;
};

std::shared_ptr<MeshData> mesh_from_arrays(const py::handle& vertices, const py::handle& faces) {
  const DoubleArray v = float_array(vertices, "V");
  const IndexArray f = integer_array(faces, "F");
  require_rows_of_3(v, "V");
  require_rows_of_3(f, "F");
  std::vector<Vec3> positions(static_cast<std::size_t>(v.shape(0)));
  auto vv = v.unchecked<2>();
  for (py::ssize_t i = 0; i < v.shape(0); ++i) {
    positions[static_cast<std::size_t>(i)] = {vv(i, 0), vv(i, 1), vv(i, 2)};
  }
  std::vector<Triangle> triangles(static_cast<std::size_t>(f.shape(0)));
  auto ff = f.unchecked<2>();
  for (py::ssize_t i = 0; i < f.shape(0); ++i) {
    for (int k = 0; k < 3; ++k) {
      triangles[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] =
          checked_id(ff(i, k), "F", i);
    }
  }
  py::gil_scoped_release release;
  return std::make_shared<MeshData>(TriangleMesh(std::move(positions), std::move(triangles)));
}

std::pair<py::array_t<double>, py::array_t<std::int64_t>> mesh_arrays(const TriangleMesh& mesh) {
  const auto n = static_cast<py::ssize_t>(mesh.num_vertices());
  const auto m = static_cast<py::ssize_t>(mesh.num_faces());
  py::array_t<double> v({n, py::ssize_t{3}});
  py::array_t<std::int64_t> f({m, py::ssize_t{3}});
  auto vv = v.mutable_unchecked<2>();
  auto ff = f.mutable_unchecked<2>();
  for (py::ssize_t i = 0; i < n; ++i) {
    const Vec3& p = mesh.position(static_cast<std::uint32_t>(i));
    vv(i, 0) = p.x;
    vv(i, 1) = p.y;
    vv(i, 2) = p.z;
  }
  for (py::ssize_t i = 0; i < m; ++i) {
    const Triangle& t = mesh.face(static_cast<std::uint32_t>(i));
    for (int k = 0; k < 3; ++k) ff(i, k) = t[static_cast<std::size_t>(k)];
  }
  return {v, f};
}

SamplingMethod parse_sampling(const std::string& name) {
  if (name == "auto") return SamplingMethod::Automatic;
  if (name == "fmm") return SamplingMethod::FastMarching;
  if (name == "exact") return SamplingMethod::Exact;
  throw InvalidInput(ErrorCode::BadOption,
                     "sampling must be \"auto\", \"fmm\" or \"exact\", not \"" + name + "\"");
}

class Graph {
 public:
  /// Builds the graph of `data` as `geoprox build` does with the same options.
  static std::unique_ptr<Graph> build(std::shared_ptr<MeshData> data,
                                      const ProximityGraphOptions& options, double target_error) {
    auto g = std::unique_ptr<Graph>(new Graph());
    g->data_ = std::move(data);
    ProximityGraphOptions o = options;
    if (target_error != 0) {
      const GraphSizeForError size = graph_size_for_error(g->data_->mesh.num_faces(), target_error);
      if (o.num_samples == 0) o.num_samples = size.num_samples;
      o.neighbors = size.neighbors;
    }
    g->built_ = std::make_unique<ProximityGraph>(
        build_proximity_graph(g->data_->mesh, g->data_->geometry, o));
    const TriangleMesh& mesh = g->data_->mesh;
    const IntrinsicGeometry& geometry = g->data_->geometry;
    if (g->built_->refined) {
      g->built_query_ = std::make_unique<GeodesicQuery>(mesh, geometry, g->built_->view(),
                                                        *g->built_->refined);
    } else {
      g->built_query_ = std::make_unique<GeodesicQuery>(mesh, geometry, g->built_->view());
    }
    g->pool_ = std::make_unique<ScratchPool>(*g->built_query_);
    return g;
  }

  /// Maps graph file `path` and checks it against the mesh, as the daemon does.
  static std::unique_ptr<Graph> open(const std::string& path, std::shared_ptr<MeshData> data,
                                     bool verify_checksum) {
    auto g = std::unique_ptr<Graph>(new Graph());
    g->data_ = std::move(data);
    GraphFileOpenOptions options;
    options.verify_checksum = verify_checksum;
    MappedGraphFile file = MappedGraphFile::open(path, options);
    file.verify_mesh(g->data_->mesh, g->data_->geometry);
    g->loaded_ = std::make_unique<LoadedGraph>(g->data_, std::move(file));
    g->pool_ = std::make_unique<ScratchPool>(*g->loaded_->query);
    return g;
  }

  void save(const std::string& path, const std::string& source_mesh) const {
    if (!built_) {
      throw InvalidInput(ErrorCode::BadOption,
                         "this graph was opened from " + loaded_->file.path() +
                             ": it is already a graph file (copy that file)");
    }
    GraphFileMetadata metadata;
    metadata.source_mesh = source_mesh;
    write_graph_file(path, data_->mesh, data_->geometry, *built_, metadata);
  }

  const GeodesicQuery& query() const { return built_ ? *built_query_ : *loaded_->query; }
  const TriangleMesh& mesh() const { return data_->mesh; }
  ScratchPool& pool() const { return *pool_; }
  std::optional<std::string> path() const {
    if (loaded_) return loaded_->file.path();
    return std::nullopt;
  }
  std::size_t num_samples() const { return query().graph().num_samples; }

  /// Resolves given points on the mesh as the daemon resolves wire points (GIL released).
  std::vector<SurfacePoint> resolve(const GivenPoints& given, const std::string& what) const {
    std::vector<SurfacePoint> out;
    out.reserve(given.size());
    for (std::size_t i = 0; i < given.size(); ++i) {
      SurfacePoint p = given.kind == GivenPoints::Kind::Position
                           ? query().snap(given.positions[i]).point
                           : given.points[i];
      try {
        p.validate(mesh());
        if (p.kind == SurfacePoint::Kind::Vertex && mesh().is_isolated_vertex(p.id)) {
          throw InvalidInput(ErrorCode::IsolatedVertex,
                             "vertex " + std::to_string(p.id) +
                                 " belongs to no face, so no geodesic reaches it");
        }
      } catch (const InvalidInput& e) {
        throw InvalidInput(e.code(), what + "[" + std::to_string(i) + "]: " + e.what());
      }
      out.push_back(p);
    }
    return out;
  }

 private:
  Graph() = default;
  std::shared_ptr<MeshData> data_;
  std::unique_ptr<LoadedGraph> loaded_;
  std::unique_ptr<ProximityGraph> built_;
  std::unique_ptr<GeodesicQuery> built_query_;
  std::unique_ptr<ScratchPool> pool_;
};

std::shared_ptr<MeshData> mesh_argument(const py::object& mesh, bool repair) {
  if (py::isinstance<py::tuple>(mesh) || py::isinstance<py::list>(mesh)) {
    const py::sequence pair = mesh;
    if (pair.size() != 2) {
      throw py::type_error("mesh must be a mesh file path or a pair (V, F) of arrays");
    }
    if (repair) throw py::value_error("repair applies to mesh files, not to arrays");
    return mesh_from_arrays(pair[0], pair[1]);
  }
  const std::string path = py::str(py::module_::import("os").attr("fspath")(mesh));
  MeshLoadOptions options;
  options.repair = repair;
  py::gil_scoped_release release;
  return MeshData::load(path, {}, options);
}

/// Pairs (s[i], t[i]); a side of one point pairs with every point of the other.
std::size_t pair_count(std::size_t s, std::size_t t) {
  if (s == t || t == 1) return s;
  if (s == 1) return t;
  throw py::value_error("sources and targets must have the same length, or one of them one "
                        "point (" + std::to_string(s) + " and " + std::to_string(t) + " given)");
}

py::object distances(const Graph& g, const py::handle& sources, const py::handle& targets,
                     bool exact_solver, bool with_exact, int threads) {
  const GivenPoints s_given = parse_points(sources, "sources");
  const GivenPoints t_given = parse_points(targets, "targets");
  const std::size_t n = pair_count(s_given.size(), t_given.size());
  py::array_t<double> out(static_cast<py::ssize_t>(n));
  py::array_t<bool> exact(static_cast<py::ssize_t>(n));
  double* d = out.mutable_data();
  bool* e = exact.mutable_data();
  {
    py::gil_scoped_release release;
    const std::vector<SurfacePoint> s = g.resolve(s_given, "sources");
    const std::vector<SurfacePoint> t = g.resolve(t_given, "targets");
    parallel_for(n, threads, g.pool(), [&](std::size_t i, QueryScratch& scratch) {
      const SurfacePoint& a = s[s.size() == 1 ? 0 : i];
      const SurfacePoint& b = t[t.size() == 1 ? 0 : i];
      try {
        const DistanceResult r = exact_solver ? g.query().exact_distance(a, b, scratch)
                                              : g.query().distance(a, b, scratch);
        d[i] = nan_if_infinite(r.distance);
        e[i] = r.exact;
      } catch (const Unreachable&) {
        d[i] = kNaN;
        e[i] = false;
      }
    });
  }
  if (with_exact) return py::make_tuple(out, exact);
  return out;
}

py::array_t<double> matrix(const Graph& g, const py::handle& sources, const py::handle& targets,
                           int threads) {
  const GivenPoints s_given = parse_points(sources, "sources");
  const GivenPoints t_given = parse_points(targets, "targets");
  const std::size_t S = s_given.size(), T = t_given.size();
  py::array_t<double> out({static_cast<py::ssize_t>(S), static_cast<py::ssize_t>(T)});
  double* d = out.mutable_data();
  {
    py::gil_scoped_release release;
    const std::vector<SurfacePoint> s = g.resolve(s_given, "sources");
    const std::vector<SurfacePoint> t = g.resolve(t_given, "targets");
    // One block of rows per thread: each block links every target once (an exact solve per
    // face point), so fewer, larger blocks cost less than many small ones.
    const int wanted = threads > 0 ? threads : omp_get_max_threads();
    const std::size_t blocks = std::max<std::size_t>(
        1, std::min<std::size_t>(static_cast<std::size_t>(wanted), S));
    parallel_for(S == 0 ? 0 : blocks, static_cast<int>(blocks), g.pool(),
                 [&](std::size_t b, QueryScratch& scratch) {
                   const std::size_t begin = S * b / blocks, end = S * (b + 1) / blocks;
                   const std::vector<double> rows = g.query().matrix(
                       std::span<const SurfacePoint>(s).subspan(begin, end - begin), t, scratch);
                   std::transform(rows.begin(), rows.end(), d + begin * T, nan_if_infinite);
                 });
  }
  return out;
}

std::vector<PathArrays> paths(const Graph& g, const py::handle& sources,
                              const py::handle& targets, bool exact_solver, int threads) {
  const GivenPoints s_given = parse_points(sources, "sources");
  const GivenPoints t_given = parse_points(targets, "targets");
  const std::size_t n = pair_count(s_given.size(), t_given.size());
  std::vector<PathResult> results(n);
  {
    py::gil_scoped_release release;
    const std::vector<SurfacePoint> s = g.resolve(s_given, "sources");
    const std::vector<SurfacePoint> t = g.resolve(t_given, "targets");
    parallel_for(n, threads, g.pool(), [&](std::size_t i, QueryScratch& scratch) {
      const SurfacePoint& a = s[s.size() == 1 ? 0 : i];
      const SurfacePoint& b = t[t.size() == 1 ? 0 : i];
      try {
        results[i] = exact_solver ? g.query().exact_path(a, b, scratch)
                                  : g.query().path(a, b, scratch);
      } catch (const Unreachable&) {
        results[i] = PathResult{};
      }
    });
  }
  std::vector<PathArrays> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    const PathResult& r = results[i];
    PathArrays& p = out[i];
    p.distance = nan_if_infinite(r.distance);
    p.exact = r.exact;
    const auto k = static_cast<py::ssize_t>(r.points.size());
    p.faces = py::array_t<std::int64_t>(k);
    p.bary = py::array_t<double>({k, py::ssize_t{3}});
    p.xyz = py::array_t<double>({k, py::ssize_t{3}});
    auto f = p.faces.mutable_unchecked<1>();
    auto b = p.bary.mutable_unchecked<2>();
    auto x = p.xyz.mutable_unchecked<2>();
    for (py::ssize_t j = 0; j < k; ++j) {
      const PathPoint& point = r.points[static_cast<std::size_t>(j)];
      // As the daemon writes path points: a face holding the point, and its barycentrics there.
      const auto [face, bary] = point.point.in_face(g.mesh());
      f(j) = face;
      for (int c = 0; c < 3; ++c) b(j, c) = bary[static_cast<std::size_t>(c)];
      x(j, 0) = point.position.x;
      x(j, 1) = point.position.y;
      x(j, 2) = point.position.z;
    }
  }
  return out;
}

py::object field(const Graph& g, const py::handle& sources, double cutoff,
                 bool with_nearest, int threads) {
  const GivenPoints given = parse_points(sources, "sources");
  if (!(cutoff > 0)) {
    throw InvalidInput(ErrorCode::BadRadius, "cutoff must be a number > 0 (inf: none)");
  }
  DistanceField result;
  {
    py::gil_scoped_release release;
    const std::vector<SurfacePoint> s = g.resolve(given, "sources");
    DistanceFieldOptions options;
    options.max_distance = cutoff;
    options.threads = threads;
    PooledScratch scratch(g.pool());
    result = g.query().field(s, scratch.get(), options);
  }
  const auto n = static_cast<py::ssize_t>(result.distances.size());
  py::array_t<double> d(n);
  auto dd = d.mutable_unchecked<1>();
  for (py::ssize_t v = 0; v < n; ++v) {
    dd(v) = nan_if_infinite(result.distances[static_cast<std::size_t>(v)]);
  }
  if (!with_nearest) return d;
  py::array_t<std::int64_t> nearest(n);
  auto nn = nearest.mutable_unchecked<1>();
  for (py::ssize_t v = 0; v < n; ++v) {
    const std::int32_t k = result.nearest_source[static_cast<std::size_t>(v)];
    nn(v) = std::isfinite(result.distances[static_cast<std::size_t>(v)]) ? k : -1;
  }
  return py::make_tuple(d, nearest);
}

}  // namespace
}  // namespace geoprox::python

PYBIND11_MODULE(native, m) {
  using namespace geoprox;
  using namespace geoprox::python;
  m.doc() = "geoprox queries in-process on numpy arrays (docs/python.md)";
  define_errors(m);

  m.def(
      "read_mesh",
      [](const py::object& path, bool repair) {
        const std::string name = py::str(py::module_::import("os").attr("fspath")(path));
        std::shared_ptr<MeshData> data;
        {
          py::gil_scoped_release release;
          MeshLoadOptions options;
          options.repair = repair;
          data = MeshData::load(name, {}, options);
        }
        return mesh_arrays(data->mesh);
      },
      py::arg("path"), py::arg("repair") = false,
      "Reads a mesh file (OBJ, OFF, PLY, STL) as geoproxd reads it: returns (V, F), float64 "
      "positions (n, 3) and int64 vertex ids (m, 3), polygons triangulated. repair=True loads "
      "it repaired, as the daemon's \"repair\": true.");

  py::class_<PathArrays>(m, "Path", "A path on the surface from a source to a target.")
      .def_readonly("distance", &PathArrays::distance, "its length (NaN: unreachable)")
      .def_readonly("exact", &PathArrays::exact, "whether it came from an exact solve")
      .def_readonly("faces", &PathArrays::faces, "int64 (k,): a face holding each point")
      .def_readonly("bary", &PathArrays::bary, "float64 (k, 3): barycentrics in that face")
      .def_readonly("xyz", &PathArrays::xyz, "float64 (k, 3): positions")
      .def("__len__", [](const PathArrays& p) { return p.faces.size(); })
      .def("__repr__", [](const PathArrays& p) {
        return "<geoprox.native.Path of " + std::to_string(p.faces.size()) + " points, distance " +
               std::string(py::str(py::float_(p.distance))) + ">";
      });

  py::class_<Graph>(m, "Graph",
                    "A mesh, its proximity graph and the queries over both. Thread-safe: "
                    "queries may run from several Python threads at once.")
      .def_static(
          "build",
          [](const py::handle& V, const py::handle& F, std::uint32_t samples,
             std::uint32_t neighbors, std::uint32_t link_samples,
             std::uint32_t candidate_vertices, double target_error, const std::string& sampling,
             int threads, bool refine) {
            std::shared_ptr<MeshData> data = mesh_from_arrays(V, F);
            ProximityGraphOptions options;
            options.num_samples = samples;
            options.neighbors = neighbors;
            options.link_samples = link_samples;
            options.candidate_vertices = candidate_vertices;
            options.sampling = parse_sampling(sampling);
            options.threads = threads;
            options.refine_long_faces = refine;
            py::gil_scoped_release release;
            return Graph::build(std::move(data), options, target_error);
          },
          py::arg("V"), py::arg("F"), py::kw_only(), py::arg("samples") = 0,
          py::arg("neighbors") = 0, py::arg("link_samples") = 0,
          py::arg("candidate_vertices") = 0, py::arg("target_error") = 0.0,
          py::arg("sampling") = "auto", py::arg("threads") = 0, py::arg("refine") = true,
          "Builds the graph of the mesh (V float (n, 3), F int (m, 3)) with the options and "
          "defaults of `geoprox build` (0: the paper's Table 1 for samples and neighbors).")
      .def_static(
          "open",
          [](const py::object& path, const py::object& mesh, bool repair, bool verify_checksum) {
            std::shared_ptr<MeshData> data = mesh_argument(mesh, repair);
            const std::string name = py::str(py::module_::import("os").attr("fspath")(path));
            py::gil_scoped_release release;
            return Graph::open(name, std::move(data), verify_checksum);
          },
          py::arg("path"), py::arg("mesh"), py::kw_only(), py::arg("repair") = false,
          py::arg("verify_checksum") = true,
          "Maps graph file `path` (as geoproxd does) for `mesh`, a mesh file path or a pair "
          "(V, F); raises FileError (reason MeshMismatch) when it was built for another mesh.")
      .def(
          "save",
          [](const Graph& g, const py::object& path, const std::string& source_mesh) {
            const std::string name = py::str(py::module_::import("os").attr("fspath")(path));
            py::gil_scoped_release release;
            g.save(name, source_mesh);
          },
          py::arg("path"), py::arg("source_mesh") = "",
          "Writes the graph file (to a temporary name, then renamed over `path`); geoproxd and "
          "Graph.open map it. `source_mesh` is recorded as information.")
      .def(
          "distance",
          [](const Graph& g, const py::handle& s, const py::handle& t, bool with_exact,
             int threads) { return distances(g, s, t, false, with_exact, threads); },
          py::arg("sources"), py::arg("targets"), py::kw_only(), py::arg("with_exact") = false,
          py::arg("threads") = 0,
          "Distances of the pairs (sources[i], targets[i]) (a side of one point pairs with all "
          "of the other): float64 (n,), NaN when unreachable; with_exact=True also returns a "
          "bool array, True where the answer came from an exact solve.")
      .def(
          "exact_distance",
          [](const Graph& g, const py::handle& s, const py::handle& t, bool with_exact,
             int threads) { return distances(g, s, t, true, with_exact, threads); },
          py::arg("sources"), py::arg("targets"), py::kw_only(), py::arg("with_exact") = false,
          py::arg("threads") = 0,
          "As distance(), from the exact solver (the daemon's \"exact\": true).")
      .def("matrix", &matrix, py::arg("sources"), py::arg("targets"), py::kw_only(),
           py::arg("threads") = 0,
           "float64 (len(sources), len(targets)) distances, NaN when unreachable.")
      .def(
          "path",
          [](const Graph& g, const py::handle& s, const py::handle& t, bool exact, int threads) {
            return paths(g, s, t, exact, threads);
          },
          py::arg("sources"), py::arg("targets"), py::kw_only(), py::arg("exact") = false,
          py::arg("threads") = 0,
          "A list of Path, one per pair as in distance() (distance NaN and no points when "
          "unreachable); exact=True traces exact geodesics.")
      .def("field", &field, py::arg("sources"), py::kw_only(),
           py::arg("cutoff") = std::numeric_limits<double>::infinity(),
           py::arg("with_nearest") = false, py::arg("threads") = 0,
           "float64 (num_vertices,): distance of every vertex from the nearest source, NaN "
           "where unreachable or beyond cutoff; with_nearest=True also returns the "
           "index of that source per vertex (int64, -1 there).")
      .def_property_readonly("num_vertices",
                             [](const Graph& g) { return g.mesh().num_vertices(); })
      .def_property_readonly("num_faces", [](const Graph& g) { return g.mesh().num_faces(); })
      .def_property_readonly("num_samples", &Graph::num_samples)
      .def_property_readonly("link_radius",
                             [](const Graph& g) { return g.query().link_radius(); },
                             "rho, mesh units")
      .def_property_readonly("path_on_disk", &Graph::path,
                             "the mapped graph file, or None for a graph built in memory")
      .def_property_readonly(
          "V", [](const Graph& g) { return mesh_arrays(g.mesh()).first; }, "positions (n, 3)")
      .def_property_readonly(
          "F", [](const Graph& g) { return mesh_arrays(g.mesh()).second; }, "faces (m, 3)");
}
