// Riemannian metrics on triangle meshes: "Lightweight preprocessing and fast query of geodesic
// distance via proximity graph", §5.4 (a transformation per face resets the edge lengths; the
// intrinsic solvers then run unchanged, since they read only edge lengths).
//
// A metric is given in one of three forms (docs/metrics.md documents the side-file format):
//  - FaceTensor2D: per face a symmetric 2x2 tensor M = [[m11, m12], [m12, m22]] in the face's
//    frame (origin at corner 0, x along corner 0 -> corner 1, y in the face's plane towards
//    corner 2, orthonormal in the embedding: the frame of IntrinsicGeometry for the mesh's own
//    lengths). An edge with frame vector d gets the length sqrt(d^T M d) in that face.
//  - FaceTensor3D: per face a symmetric 3x3 tensor M applied to the embedded edge vectors
//    d = p_target - p_origin: length sqrt(d^T M d) in that face.
//  - EdgeLengths: the intrinsic length of every edge, in edge-id order (core/mesh/mesh.h).
// An interior edge gets a length from each of its two faces; it keeps their arithmetic mean.
// A face's own three lengths always satisfy the triangle inequality (they are the sides of a
// Euclidean triangle), but the means need not, so they are checked afterwards.
//
// Validation (InvalidInput; every message names the face or edge id and the values):
//   BadMetric: wrong number of values for the mesh, or a non-finite value, or a negative length;
//   NotPositiveDefinite: a face tensor that is not positive definite (smallest eigenvalue, or
//     Cholesky pivot for 3x3, at most definiteness_tolerance times the largest diagonal entry);
//   TriangleInequality: the resulting lengths of a face break a triangle inequality (beyond
//     1e-12 of the perimeter, the tolerance of IntrinsicGeometry).
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

#include "core/mesh/intrinsic_geometry.h"
#include "core/mesh/mesh.h"

namespace geoprox {

enum class MetricKind : std::uint8_t {
  FaceTensor2D = 0,  ///< 3 values per face: m11 m12 m22 (face frame)
  FaceTensor3D = 1,  ///< 6 values per face: m_xx m_xy m_xz m_yy m_yz m_zz (embedding axes)
  EdgeLengths = 2,   ///< 1 value per edge: its length
};

/// "face-tensor-2d", "face-tensor-3d", "edge-lengths" (the side file's header words).
std::string_view metric_kind_name(MetricKind kind);
/// Values per row (per face or per edge): 3, 6 or 1.
std::size_t metric_values_per_row(MetricKind kind);

struct RiemannianMetric {
  MetricKind kind = MetricKind::EdgeLengths;
  /// Row-major: metric_values_per_row(kind) numbers per face (tensors) or per edge (lengths).
  std::vector<double> values;
};

struct RiemannianMetricOptions {
  /// A tensor counts as positive definite when its smallest eigenvalue (2x2) or smallest
  /// Cholesky pivot (3x3) exceeds this fraction of its largest diagonal entry (dimensionless).
  double definiteness_tolerance = 1e-12;
  /// Passed on to the IntrinsicGeometry that make_metric_geometry builds.
  IntrinsicGeometryOptions geometry;
};

/// Parses the side-file format (docs/metrics.md). `name` labels messages. Throws FileError
/// ("ParseError") naming name:line for a bad header, a short or long row, or a word that is
/// not a number. Sizes are checked against a mesh later (validate_metric).
RiemannianMetric parse_metric(std::istream& in, const std::string& name);
/// Reads `path` with parse_metric; FileError ("FileNotFound") if it cannot be opened.
RiemannianMetric read_metric_file(const std::string& path);
/// The side-file text of `metric` (%.17g: parse_metric reads it back bit for bit).
std::string format_metric(const RiemannianMetric& metric);

/// Checks sizes, finiteness and definiteness against `mesh` (see the file comment).
void validate_metric(const TriangleMesh& mesh, const RiemannianMetric& metric,
                     const RiemannianMetricOptions& options = {});

/// The intrinsic edge lengths of `mesh` under `metric` (validated, triangle inequalities
/// checked), in edge-id order.
std::vector<double> metric_edge_lengths(const TriangleMesh& mesh, const RiemannianMetric& metric,
                                        const RiemannianMetricOptions& options = {});

/// One-shot: the IntrinsicGeometry every solver takes, with the metric's lengths. `mesh` must
/// outlive the result.
IntrinsicGeometry make_metric_geometry(const TriangleMesh& mesh, const RiemannianMetric& metric,
                                       const RiemannianMetricOptions& options = {});

/// The geometry for `mesh` with the metric of side file `metric_path`, or with the mesh's own
/// lengths when `metric_path` is empty (what the CLI and the daemon call).
IntrinsicGeometry load_geometry(const TriangleMesh& mesh, const std::string& metric_path,
                                const RiemannianMetricOptions& options = {});

}  // namespace geoprox
