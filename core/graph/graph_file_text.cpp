// The paper's text format (graph_file.h): directions between face frames and 3D, export, and
// import onto a mesh.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <istream>
#include <limits>
#include <ostream>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "core/base/errors.h"
#include "core/base/tuning.h"
#include "core/graph/graph_file.h"
#include "core/graph/graph_file_internal.h"

namespace geoprox {

using graph_file_detail::fmt_double;

// ---------------------------------------------------------------------------------------------
// Directions

namespace {

Vec3 normalized_or_zero(const Vec3& v) {
  const double n = norm(v);
  return n > 0 && std::isfinite(n) ? (1.0 / n) * v : Vec3{};
}

/// Orthonormal in-plane frame of face f from the positions (fallback for degenerate layouts).
Vec3 orthonormal_direction(const TriangleMesh& mesh, std::uint32_t f, double x, double y) {
  const Triangle& t = mesh.face(f);
  const Vec3 p0 = mesh.position(t[0]);
  const Vec3 ex = normalized_or_zero(mesh.position(t[1]) - p0);
  const Vec3 w = mesh.position(t[2]) - p0;
  const Vec3 ey = normalized_or_zero(w - dot(w, ex) * ex);
  return normalized_or_zero(x * ex + y * ey);
}

}  // namespace

Vec3 graph_direction_to_3d(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                           const GraphDirection& direction) {
  const std::uint32_t f = direction.face;
  if (f >= mesh.num_faces()) {
    throw InvalidInput(ErrorCode::FaceOutOfRange, "direction in face " + std::to_string(f) +
                                                      " of " + std::to_string(mesh.num_faces()));
  }
  const Vec2 c1 = geometry.face_corner(f, 1), c2 = geometry.face_corner(f, 2);
  const double det = c1.x * c2.y - c2.x * c1.y;
  const double scale = std::hypot(c1.x, c1.y) * std::hypot(c2.x, c2.y);
  const double x = direction.x, y = direction.y;
  if (std::abs(det) > tuning::kDegenerateLayoutSine * scale) {
    // (x, y) = a c1 + b c2  ->  a (P1 - P0) + b (P2 - P0).
    const double a = (x * c2.y - y * c2.x) / det;
    const double b = (c1.x * y - c1.y * x) / det;
    const Triangle& t = mesh.face(f);
    const Vec3 p0 = mesh.position(t[0]);
    const Vec3 d =
        normalized_or_zero(a * (mesh.position(t[1]) - p0) + b * (mesh.position(t[2]) - p0));
    if (norm(d) > 0) return d;
  }
  return orthonormal_direction(mesh, f, x, y);
}

GraphDirection graph_direction_from_3d(const TriangleMesh& mesh, const IntrinsicGeometry& geometry,
                                       std::uint32_t vertex, const Vec3& direction) {
  if (vertex >= mesh.num_vertices()) {
    throw InvalidInput(ErrorCode::VertexOutOfRange, "vertex " + std::to_string(vertex) + " of " +
                                                        std::to_string(mesh.num_vertices()));
  }
  const Vec3 d = normalized_or_zero(direction);
  if (!(norm(d) > 0)) {
    throw InvalidInput(ErrorCode::BadDirection, "direction is zero or not finite");
  }
  const auto halfedges = mesh.outgoing_halfedges(vertex);
  if (halfedges.empty()) {
    throw InvalidInput(ErrorCode::IsolatedVertex,
                       "vertex " + std::to_string(vertex) + " has no face to hold a direction");
  }
  // Best face: the corner wedge at `vertex` contains the direction (both edge coefficients
  // non-negative) and the direction lies in (or closest to) the face's plane.
  double best_score = std::numeric_limits<double>::infinity();
  GraphDirection best{TriangleMesh::face_of(halfedges[0]), 1, 0};
  for (const std::uint32_t h : halfedges) {
    const std::uint32_t f = TriangleMesh::face_of(h);
    const int k = static_cast<int>(h % 3);
    const Triangle& t = mesh.face(f);
    const Vec3 pv = mesh.position(t[k]);
    const Vec3 u = mesh.position(t[(k + 1) % 3]) - pv;
    const Vec3 w = mesh.position(t[(k + 2) % 3]) - pv;
    const double uu = dot(u, u), uw = dot(u, w), ww = dot(w, w);
    const double det = uu * ww - uw * uw;
    if (!(det > tuning::kDegenerateFaceSineSquared * uu * ww)) continue;  // no reliable plane
    const double du = dot(u, d), dw = dot(w, d);
    const double alpha = (ww * du - uw * dw) / det;
    const double beta = (uu * dw - uw * du) / det;
    const Vec3 in_plane = alpha * u + beta * w;
    const double residual = norm(d - in_plane);
    const double outside =
        std::max(0.0, -alpha * std::sqrt(uu)) + std::max(0.0, -beta * std::sqrt(ww));
    const double score = residual + outside;
    if (!(score < best_score)) continue;
    // Same combination of the face's edge vectors in its intrinsic frame.
    const Vec2 cv = geometry.face_corner(f, k);
    const Vec2 ca = geometry.face_corner(f, (k + 1) % 3);
    const Vec2 cb = geometry.face_corner(f, (k + 2) % 3);
    const double x = alpha * (ca.x - cv.x) + beta * (cb.x - cv.x);
    const double y = alpha * (ca.y - cv.y) + beta * (cb.y - cv.y);
    const double n = std::hypot(x, y);
    if (!(n > 0) || !std::isfinite(n)) continue;
    best_score = score;
    best = {f, static_cast<float>(x / n), static_cast<float>(y / n)};
  }
  return best;
}

// ---------------------------------------------------------------------------------------------
// Paper text format

void export_paper_text(std::ostream& out, const TriangleMesh& mesh,
                       const IntrinsicGeometry& geometry, const ProximityGraphView& graph) {
  const std::size_t ns = graph.sample_vertex.size();
  if (graph.edge_offsets.size() != ns + 1) {
    throw InvalidInput(ErrorCode::InvalidGraph,
                       "edge_offsets has " + std::to_string(graph.edge_offsets.size()) +
                           " entries for " + std::to_string(ns) + " samples");
  }
  const std::size_t ne = graph.edge_target.size();
  if (graph.edge_offsets[0] != 0 || graph.edge_offsets[ns] != ne ||
      graph.edge_distance.size() != ne || graph.edge_direction.size() != ne) {
    throw InvalidInput(ErrorCode::InvalidGraph, "edge arrays of inconsistent sizes");
  }
  for (std::size_t i = 0; i < ns; ++i) {
    if (graph.edge_offsets[i + 1] < graph.edge_offsets[i]) {
      throw InvalidInput(ErrorCode::InvalidGraph,
                         "edge_offsets decrease at row " + std::to_string(i));
    }
  }
  std::string text;
  text.reserve(64 * (ns + ne) + 128);
  char line[256];
  text += "# The number of sample points\n";
  text += std::to_string(ns);
  text += "\n# The coordinates of sample points\n";
  for (std::size_t i = 0; i < ns; ++i) {
    const std::uint32_t v = graph.sample_vertex[i];
    if (v >= mesh.num_vertices()) {
      throw InvalidInput(ErrorCode::InvalidGraph, "sample " + std::to_string(i) + " is at vertex " +
                                                      std::to_string(v) + " of " +
                                                      std::to_string(mesh.num_vertices()));
    }
    const Vec3& p = mesh.position(v);
    std::snprintf(line, sizeof line, "%.17g %.17g %.17g\n", p.x, p.y, p.z);
    text += line;
  }
  text += "# ID1    ID2    Distance    End_direction\n";
  for (std::size_t i = 0; i < ns; ++i) {
    for (std::uint32_t k = graph.edge_offsets[i]; k < graph.edge_offsets[i + 1]; ++k) {
      const Vec3 d = graph_direction_to_3d(mesh, geometry, graph.edge_direction[k]);
      std::snprintf(line, sizeof line, "%zu %u %.17g %.17g %.17g %.17g\n", i + 1,
                    graph.edge_target[k] + 1, graph.edge_distance[k], d.x, d.y, d.z);
      text += line;
    }
    if (text.size() > tuning::kTextFlushBytes) {
      out.write(text.data(), static_cast<std::streamsize>(text.size()));
      text.clear();
    }
  }
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (!out) throw FileError(ErrorCode::WriteError, "cannot write the proximity graph text");
}

namespace {

[[noreturn]] void throw_parse_error(std::size_t line, const std::string& what) {
  throw FileError(ErrorCode::ParseError,
                  "proximity graph text, line " + std::to_string(line) + ": " + what);
}

/// Whitespace-separated tokens of a line.
void split(std::string_view line, std::vector<std::string_view>& tokens) {
  tokens.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
}

bool parse_u64(std::string_view s, std::uint64_t& out) {
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size();
}

bool parse_double(std::string_view s, double& out) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size() && std::isfinite(out);
}

/// Finds the mesh vertex at a coordinate: exact match, else the nearest within `tolerance`.
class VertexLocator {
 public:
  explicit VertexLocator(const TriangleMesh& mesh) : mesh_(mesh) {
    const auto& pos = mesh.positions();
    Vec3 lo = pos[0], hi = pos[0];
    for (const Vec3& p : pos) {
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
    lo_ = lo;
    tolerance_ = tuning::kSampleMatchTolerance * norm(hi - lo);
    cell_ = tolerance_ > 0 ? tolerance_ : 1.0;
    cells_.reserve(pos.size());
    for (std::uint32_t v = 0; v < pos.size(); ++v) {
      std::int64_t c[3] = {0, 0, 0};
      cell_of(pos[v], c);
      cells_.emplace(key(c[0], c[1], c[2]), v);
    }
  }

  double tolerance() const { return tolerance_; }

  /// Vertex within tolerance (nearest, lowest id on ties), or -1.
  std::int64_t find(const Vec3& q) const {
    std::int64_t c[3] = {0, 0, 0};
    if (!cell_of(q, c)) return -1;
    std::int64_t best = -1;
    double best_distance = std::numeric_limits<double>::infinity();
    for (std::int64_t dx = -1; dx <= 1; ++dx) {
      for (std::int64_t dy = -1; dy <= 1; ++dy) {
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          const auto range = cells_.equal_range(key(c[0] + dx, c[1] + dy, c[2] + dz));
          for (auto it = range.first; it != range.second; ++it) {
            const std::uint32_t v = it->second;
            const double d = norm(mesh_.position(v) - q);
            if (d > tolerance_) continue;
            if (d < best_distance || (d == best_distance && v < best)) {
              best_distance = d;
              best = v;
            }
          }
        }
      }
    }
    return best;
  }

 private:
  bool cell_of(const Vec3& p, std::int64_t c[3]) const {
    const double r[3] = {(p.x - lo_.x) / cell_, (p.y - lo_.y) / cell_, (p.z - lo_.z) / cell_};
    for (int k = 0; k < 3; ++k) {
      if (!(std::abs(r[k]) < kMaxCellIndex)) return false;
      c[k] = static_cast<std::int64_t>(std::floor(r[k]));
    }
    return true;
  }
  /// Cell indices stay far inside int64 (a farther point matches no vertex).
  static constexpr double kMaxCellIndex = 0x1p60;

  static std::uint64_t key(std::int64_t x, std::int64_t y, std::int64_t z) {
    using namespace graph_file_detail;
    std::uint64_t h = static_cast<std::uint64_t>(x) * kMulA;
    h = (h ^ static_cast<std::uint64_t>(y)) * kMulC;
    h = (h ^ static_cast<std::uint64_t>(z)) * kMulD;
    return h ^ (h >> 29);
  }

  const TriangleMesh& mesh_;
  Vec3 lo_;
  double tolerance_ = 0, cell_ = 1;
  std::unordered_multimap<std::uint64_t, std::uint32_t> cells_;
};

}  // namespace

namespace {

/// Reads the text format line by line: the sample count, the samples' coordinates, then the
/// edge rows.
class PaperTextParser {
 public:
  PaperTextParser(const TriangleMesh& mesh, const IntrinsicGeometry& geometry)
      : mesh_(mesh),
        geometry_(geometry),
        locator_(mesh),
        sample_of_vertex_(mesh.num_vertices(), -1) {
    graph_.num_vertices = static_cast<std::uint32_t>(mesh.num_vertices());
  }

  ProximityGraph parse(std::istream& in) {
    std::string line;
    while (std::getline(in, line)) {
      ++line_number_;
      split(line, tokens_);
      if (tokens_.empty() || tokens_[0][0] == '#') continue;
      switch (stage_) {
        case Stage::Count:
          parse_count(line);
          break;
        case Stage::Coordinates:
          parse_coordinates(line);
          break;
        case Stage::Rows:
          parse_row(line);
          break;
      }
    }
    if (in.bad()) throw FileError(ErrorCode::ReadError, "cannot read the proximity graph text");
    if (stage_ == Stage::Count) throw_parse_error(line_number_, "no sample count (empty input)");
    if (stage_ == Stage::Coordinates) {
      throw_parse_error(line_number_, "end of input after " +
                                          std::to_string(graph_.sample_vertex.size()) + " of " +
                                          std::to_string(count_) + " sample coordinates");
    }
    fill_edges();
    graph_.covering_radius = 0;
    graph_.cover_offsets.assign(mesh_.num_vertices() + 1, 0);
    return std::move(graph_);
  }

 private:
  struct Row {
    std::uint32_t from, to;
    double distance;
    GraphDirection direction;
  };
  enum class Stage { Count, Coordinates, Rows };

  void parse_count(const std::string& line) {
    if (tokens_.size() != 1 || !parse_u64(tokens_[0], count_)) {
      throw_parse_error(line_number_, "expected the number of sample points, got '" + line + "'");
    }
    if (count_ > mesh_.num_vertices()) {
      throw_parse_error(line_number_, std::to_string(count_) + " samples but the mesh has only " +
                                          std::to_string(mesh_.num_vertices()) + " vertices");
    }
    graph_.sample_vertex.reserve(count_);
    stage_ = count_ > 0 ? Stage::Coordinates : Stage::Rows;
  }

  void parse_coordinates(const std::string& line) {
    const std::string sample = "sample " + std::to_string(graph_.sample_vertex.size() + 1);
    Vec3 p;
    if (tokens_.size() != 3 || !parse_double(tokens_[0], p.x) || !parse_double(tokens_[1], p.y) ||
        !parse_double(tokens_[2], p.z)) {
      throw_parse_error(line_number_,
                        "expected three finite coordinates of " + sample + ", got '" + line + "'");
    }
    const std::int64_t v = locator_.find(p);
    if (v < 0) {
      throw_parse_error(line_number_, sample + " at (" + fmt_double(p.x) + ", " + fmt_double(p.y) +
                                          ", " + fmt_double(p.z) +
                                          ") is not at a mesh vertex (tolerance " +
                                          fmt_double(locator_.tolerance()) + ")");
    }
    if (sample_of_vertex_[v] >= 0) {
      throw_parse_error(line_number_, sample + " is at vertex " + std::to_string(v) +
                                          ", like sample " +
                                          std::to_string(sample_of_vertex_[v] + 1));
    }
    sample_of_vertex_[v] = static_cast<std::int64_t>(graph_.sample_vertex.size());
    graph_.sample_vertex.push_back(static_cast<std::uint32_t>(v));
    if (graph_.sample_vertex.size() == count_) stage_ = Stage::Rows;
  }

  void parse_row(const std::string& line) {
    std::uint64_t id1 = 0, id2 = 0;
    double values[4];
    if (tokens_.size() != 6 || !parse_u64(tokens_[0], id1) || !parse_u64(tokens_[1], id2) ||
        !parse_double(tokens_[2], values[0]) || !parse_double(tokens_[3], values[1]) ||
        !parse_double(tokens_[4], values[2]) || !parse_double(tokens_[5], values[3])) {
      throw_parse_error(line_number_,
                        "expected 'ID1 ID2 Distance dx dy dz' (two sample ids and four finite "
                        "numbers), got '" +
                            line + "'");
    }
    if (id1 < 1 || id1 > count_ || id2 < 1 || id2 > count_) {
      throw_parse_error(line_number_, "sample id out of range 1.." + std::to_string(count_));
    }
    if (id1 == id2) throw_parse_error(line_number_, "edge from a sample to itself");
    if (values[0] < 0) throw_parse_error(line_number_, "negative distance");
    const auto from = static_cast<std::uint32_t>(id1 - 1);
    Row row{from, static_cast<std::uint32_t>(id2 - 1), values[0], {}};
    try {
      row.direction = graph_direction_from_3d(mesh_, geometry_, graph_.sample_vertex[from],
                                              Vec3{values[1], values[2], values[3]});
    } catch (const InvalidInput& e) {
      throw_parse_error(line_number_, std::string("bad end direction: ") + e.what());
    }
    rows_.push_back(row);
  }

  /// CSR, rows grouped by ID1 in file order (counting sort, stable); m_P is the shortest
  /// non-empty row.
  void fill_edges() {
    ProximityGraph& graph = graph_;
    const std::size_t ns = graph.sample_vertex.size();
    graph.edge_offsets.assign(ns + 1, 0);
    for (const Row& r : rows_) ++graph.edge_offsets[r.from + 1];
    for (std::size_t i = 0; i < ns; ++i) graph.edge_offsets[i + 1] += graph.edge_offsets[i];
    if (rows_.size() > std::numeric_limits<std::uint32_t>::max()) {
      throw_parse_error(line_number_, "more than 2^32 graph edges");
    }
    graph.edge_target.resize(rows_.size());
    graph.edge_distance.resize(rows_.size());
    graph.edge_direction.resize(rows_.size());
    std::vector<std::uint32_t> cursor(graph.edge_offsets.begin(), graph.edge_offsets.end() - 1);
    for (const Row& r : rows_) {
      const std::uint32_t k = cursor[r.from]++;
      graph.edge_target[k] = r.to;
      graph.edge_distance[k] = r.distance;
      graph.edge_direction[k] = r.direction;
      graph.longest_edge = std::max(graph.longest_edge, r.distance);
    }
    std::uint32_t min_row = 0;
    for (std::size_t i = 0; i < ns; ++i) {
      const std::uint32_t len = graph.edge_offsets[i + 1] - graph.edge_offsets[i];
      if (len > 0 && (min_row == 0 || len < min_row)) min_row = len;
    }
    graph.neighbors = min_row;
  }

  const TriangleMesh& mesh_;
  const IntrinsicGeometry& geometry_;
  const VertexLocator locator_;
  ProximityGraph graph_;
  std::vector<Row> rows_;
  std::vector<std::int64_t> sample_of_vertex_;
  Stage stage_ = Stage::Count;
  std::uint64_t count_ = 0;
  std::vector<std::string_view> tokens_;
  std::size_t line_number_ = 0;
};

}  // namespace

ProximityGraph import_paper_text(std::istream& in, const TriangleMesh& mesh,
                                 const IntrinsicGeometry& geometry) {
  return PaperTextParser(mesh, geometry).parse(in);
}

}  // namespace geoprox
