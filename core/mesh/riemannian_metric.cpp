#include "core/mesh/riemannian_metric.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <istream>
#include <sstream>

#include "core/base/errors.h"
#include "core/base/tuning.h"

namespace geoprox {

namespace {

constexpr std::string_view kMagic = "geoprox-metric";
constexpr int kFormatVersion = 1;

std::string number(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

[[noreturn]] void parse_error(const std::string& name, std::size_t line, const std::string& what) {
  throw FileError(ErrorCode::ParseError, name + ":" + std::to_string(line) + ": " + what);
}

/// A full-precision number from one word ("inf" and "nan" parse: validate_metric refuses them
/// with the face id, which says more than a parse error would).
bool parse_double(const std::string& word, double& out) {
  errno = 0;
  char* end = nullptr;
  out = std::strtod(word.c_str(), &end);
  return end != word.c_str() && *end == '\0' && errno != ERANGE;
}

std::string row_name(MetricKind kind, std::size_t row) {
  return (kind == MetricKind::EdgeLengths ? "edge " : "face ") + std::to_string(row);
}

std::string values_text(const double* v, std::size_t n) {
  std::string out;
  for (std::size_t i = 0; i < n; ++i) out += (i ? " " : "") + number(v[i]);
  return out;
}

/// Smallest eigenvalue of [[a, b], [b, c]] relative to its largest diagonal entry.
bool positive_definite_2x2(const double* m, double tolerance, double& smallest) {
  const double a = m[0], b = m[1], c = m[2];
  const double mean = 0.5 * (a + c);
  const double radius = std::hypot(0.5 * (a - c), b);
  smallest = mean - radius;
  const double scale = std::max(std::abs(a), std::abs(c));
  return a > 0 && c > 0 && smallest > tolerance * scale;
}

/// Cholesky of the symmetric 3x3 (xx xy xz yy yz zz); the smallest pivot relative to the
/// largest diagonal entry decides.
bool positive_definite_3x3(const double* m, double tolerance, double& smallest) {
  const double xx = m[0], xy = m[1], xz = m[2], yy = m[3], yz = m[4], zz = m[5];
  const double scale = std::max({std::abs(xx), std::abs(yy), std::abs(zz)});
  const double threshold = tolerance * scale;
  smallest = xx;
  if (!(xx > threshold)) return false;
  const double l10 = xy / std::sqrt(xx), l20 = xz / std::sqrt(xx);
  const double p1 = yy - l10 * l10;
  smallest = std::min(smallest, p1);
  if (!(p1 > threshold)) return false;
  const double l21 = (yz - l20 * l10) / std::sqrt(p1);
  const double p2 = zz - l20 * l20 - l21 * l21;
  smallest = std::min(smallest, p2);
  return p2 > threshold;
}

double quadratic_2d(const double* m, Vec2 d) {
  return m[0] * d.x * d.x + 2 * m[1] * d.x * d.y + m[2] * d.y * d.y;
}

double quadratic_3d(const double* m, const Vec3& d) {
  return m[0] * d.x * d.x + m[3] * d.y * d.y + m[5] * d.z * d.z +
         2 * (m[1] * d.x * d.y + m[2] * d.x * d.z + m[4] * d.y * d.z);
}

/// Throws TriangleInequality for the first face whose three edge lengths break a triangle
/// inequality by more than tuning::kTriangleInequalitySlack of its perimeter (as
/// IntrinsicGeometry does). The message is "face F: <before>A, B, C (edges I, J, K)<after>".
void check_triangle_inequalities(const TriangleMesh& mesh, const std::vector<double>& lengths,
                                 const std::string& before, const std::string& after) {
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
    const std::uint32_t i = mesh.edge_of(3 * f), j = mesh.edge_of(3 * f + 1),
                        k = mesh.edge_of(3 * f + 2);
    const double a = lengths[i], b = lengths[j], c = lengths[k];
    const double slack = tuning::kTriangleInequalitySlack * (a + b + c);
    if (a > b + c + slack || b > a + c + slack || c > a + b + slack) {
      throw InvalidInput(ErrorCode::TriangleInequality,
                         "face " + std::to_string(f) + ": " + before + number(a) + ", " +
                             number(b) + ", " + number(c) + " (edges " + std::to_string(i) + ", " +
                             std::to_string(j) + ", " + std::to_string(k) + ")" + after);
    }
  }
}

}  // namespace

std::string_view metric_kind_name(MetricKind kind) {
  switch (kind) {
    case MetricKind::FaceTensor2D:
      return "face-tensor-2d";
    case MetricKind::FaceTensor3D:
      return "face-tensor-3d";
    case MetricKind::EdgeLengths:
      break;
  }
  return "edge-lengths";
}

std::size_t metric_values_per_row(MetricKind kind) {
  switch (kind) {
    case MetricKind::FaceTensor2D:
      return 3;
    case MetricKind::FaceTensor3D:
      return 6;
    case MetricKind::EdgeLengths:
      break;
  }
  return 1;
}

RiemannianMetric parse_metric(std::istream& in, const std::string& name) {
  RiemannianMetric metric;
  std::string line;
  std::size_t line_number = 0;
  bool have_header = false;
  std::size_t per_row = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const std::size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream words(line);
    std::string word;
    std::vector<std::string> row;
    while (words >> word) row.push_back(word);
    if (row.empty()) continue;
    if (!have_header) {
      if (row[0] != kMagic) {
        parse_error(name, line_number,
                    "expected the header 'geoprox-metric 1 KIND', not '" + row[0] + "'");
      }
      if (row.size() != 3 || row[1] != std::to_string(kFormatVersion)) {
        parse_error(name, line_number,
                    "the header must be 'geoprox-metric 1 KIND' (version 1; KIND one of "
                    "face-tensor-2d, face-tensor-3d, edge-lengths)");
      }
      bool known = false;
      for (MetricKind kind :
           {MetricKind::FaceTensor2D, MetricKind::FaceTensor3D, MetricKind::EdgeLengths}) {
        if (row[2] == metric_kind_name(kind)) {
          metric.kind = kind;
          known = true;
        }
      }
      if (!known) {
        parse_error(name, line_number,
                    "unknown metric kind '" + row[2] +
                        "' (face-tensor-2d, face-tensor-3d or edge-lengths)");
      }
      per_row = metric_values_per_row(metric.kind);
      have_header = true;
      continue;
    }
    if (row.size() != per_row) {
      parse_error(name, line_number,
                  "expected " + std::to_string(per_row) + " number" + (per_row > 1 ? "s" : "") +
                      " for " +
                      row_name(metric.kind, metric.values.size() / per_row) + ", got " +
                      std::to_string(row.size()));
    }
    for (const std::string& w : row) {
      double value = 0;
      if (!parse_double(w, value)) {
        parse_error(name, line_number, "'" + w + "' is not a number");
      }
      metric.values.push_back(value);
    }
  }
  if (in.bad()) throw FileError(ErrorCode::ReadError, name + ": read error");
  if (!have_header) {
    throw FileError(ErrorCode::ParseError,
                    name + ": empty; expected the header 'geoprox-metric 1 KIND'");
  }
  return metric;
}

RiemannianMetric read_metric_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw FileError(ErrorCode::FileNotFound, path + ": is a directory, not a metric file");
  }
  std::ifstream in(path);
  if (!in) throw FileError(ErrorCode::FileNotFound, path + ": cannot be opened for reading");
  return parse_metric(in, path);
}

std::string format_metric(const RiemannianMetric& metric) {
  const std::size_t per_row = metric_values_per_row(metric.kind);
  std::string out = std::string(kMagic) + " " + std::to_string(kFormatVersion) + " " +
                    std::string(metric_kind_name(metric.kind)) + "\n";
  out.reserve(out.size() + metric.values.size() * 24);
  for (std::size_t i = 0; i < metric.values.size(); ++i) {
    out += number(metric.values[i]);
    out += (i + 1) % per_row == 0 ? '\n' : ' ';
  }
  return out;
}

void validate_metric(const TriangleMesh& mesh, const RiemannianMetric& metric,
                     const RiemannianMetricOptions& options) {
  const std::size_t per_row = metric_values_per_row(metric.kind);
  const bool per_edge = metric.kind == MetricKind::EdgeLengths;
  const std::size_t rows = per_edge ? mesh.num_edges() : mesh.num_faces();
  if (metric.values.size() != rows * per_row) {
    throw InvalidInput(ErrorCode::BadMetric,
                       std::string(metric_kind_name(metric.kind)) + " metric has " +
                           std::to_string(metric.values.size() / per_row) + " rows (" +
                           std::to_string(metric.values.size()) + " values) for a mesh with " +
                           std::to_string(rows) + (per_edge ? " edges" : " faces") +
                           "; it needs one row per " + (per_edge ? "edge" : "face"));
  }
  if (!(options.definiteness_tolerance >= 0) || !std::isfinite(options.definiteness_tolerance)) {
    throw InvalidInput(ErrorCode::BadTolerance,
                       "definiteness_tolerance must be finite and >= 0, not " +
                           number(options.definiteness_tolerance));
  }
  for (std::size_t row = 0; row < rows; ++row) {
    const double* v = metric.values.data() + row * per_row;
    for (std::size_t i = 0; i < per_row; ++i) {
      if (!std::isfinite(v[i])) {
        throw InvalidInput(ErrorCode::BadMetric, row_name(metric.kind, row) + ": value " +
                                                     std::to_string(i + 1) + " of '" +
                                                     values_text(v, per_row) + "' is not finite");
      }
    }
    double smallest = 0;
    switch (metric.kind) {
      case MetricKind::EdgeLengths:
        if (v[0] < 0) {
          throw InvalidInput(ErrorCode::BadMetric, "edge " + std::to_string(row) +
                                                       " has the negative length " + number(v[0]));
        }
        break;
      case MetricKind::FaceTensor2D:
        if (!positive_definite_2x2(v, options.definiteness_tolerance, smallest)) {
          throw InvalidInput(ErrorCode::NotPositiveDefinite,
                             "face " + std::to_string(row) + ": the 2x2 tensor (m11 m12 m22) " +
                                 values_text(v, 3) +
                                 " is not positive definite (smallest eigenvalue " +
                                 number(smallest) + ")");
        }
        break;
      case MetricKind::FaceTensor3D:
        if (!positive_definite_3x3(v, options.definiteness_tolerance, smallest)) {
          throw InvalidInput(ErrorCode::NotPositiveDefinite,
                             "face " + std::to_string(row) +
                                 ": the 3x3 tensor (m_xx m_xy m_xz m_yy m_yz m_zz) " +
                                 values_text(v, 6) + " is not positive definite (Cholesky pivot " +
                                 number(smallest) + ")");
        }
        break;
    }
  }
}

std::vector<double> metric_edge_lengths(const TriangleMesh& mesh, const RiemannianMetric& metric,
                                        const RiemannianMetricOptions& options) {
  validate_metric(mesh, metric, options);
  if (metric.kind == MetricKind::EdgeLengths) {
    check_triangle_inequalities(mesh, metric.values, "the edge lengths ",
                                " break the triangle inequality");
    return metric.values;
  }

  // Per-face lengths, then the mean over the (one or two) faces of each edge.
  std::vector<double> sum(mesh.num_edges(), 0.0);
  std::vector<std::uint8_t> count(mesh.num_edges(), 0);
  const IntrinsicGeometry embedded(mesh);  // the 2D tensors' face frames
  for (std::uint32_t f = 0; f < mesh.num_faces(); ++f) {
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t h = 3 * f + static_cast<std::uint32_t>(i);
      double squared = 0;
      if (metric.kind == MetricKind::FaceTensor2D) {
        const Vec2 a = embedded.face_corner(f, i), b = embedded.face_corner(f, (i + 1) % 3);
        squared = quadratic_2d(metric.values.data() + 3 * f, Vec2{b.x - a.x, b.y - a.y});
      } else {
        const Vec3 d = mesh.position(mesh.target(h)) - mesh.position(mesh.origin(h));
        squared = quadratic_3d(metric.values.data() + 6 * f, d);
      }
      const std::uint32_t e = mesh.edge_of(h);
      sum[e] += std::sqrt(std::max(0.0, squared));
      ++count[e];
    }
  }
  std::vector<double> lengths(mesh.num_edges(), 0.0);
  for (std::uint32_t e = 0; e < mesh.num_edges(); ++e) {
    GEOPROX_ASSERT(count[e] == 1 || count[e] == 2, "every edge has one or two faces");
    lengths[e] = count[e] == 1 ? sum[e] : 0.5 * sum[e];
  }
  check_triangle_inequalities(mesh, lengths,
                              "averaging the lengths of shared edges with the neighbouring faces "
                              "gives ",
                              ", which break the triangle inequality: the tensors of neighbouring "
                              "faces differ too much");
  return lengths;
}

IntrinsicGeometry make_metric_geometry(const TriangleMesh& mesh, const RiemannianMetric& metric,
                                       const RiemannianMetricOptions& options) {
  return IntrinsicGeometry(mesh, metric_edge_lengths(mesh, metric, options), options.geometry);
}

IntrinsicGeometry load_geometry(const TriangleMesh& mesh, const std::string& metric_path,
                                const RiemannianMetricOptions& options) {
  if (metric_path.empty()) return IntrinsicGeometry(mesh, options.geometry);
  const RiemannianMetric metric = read_metric_file(metric_path);
  try {
    return make_metric_geometry(mesh, metric, options);
  } catch (const InvalidInput& e) {
    throw InvalidInput(e.code(), metric_path + ": " + e.what());
  }
}

}  // namespace geoprox
