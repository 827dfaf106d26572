#include "core/mesh/surface_point.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "core/base/errors.h"

namespace geoprox {

void SurfacePoint::validate(const TriangleMesh& mesh) const {
  switch (kind) {
    case Kind::Vertex:
      if (id >= mesh.num_vertices()) {
        throw InvalidInput(ErrorCode::VertexOutOfRange,
                           "vertex " + std::to_string(id) + " is out of range (mesh has " +
                               std::to_string(mesh.num_vertices()) + " vertices)");
      }
      return;
    case Kind::Edge:
      if (id >= mesh.num_edges()) {
        throw InvalidInput(ErrorCode::EdgeOutOfRange,
                           "edge " + std::to_string(id) + " is out of range (mesh has " +
                               std::to_string(mesh.num_edges()) + " edges)");
      }
      if (!std::isfinite(t) || t < 0 || t > 1) {
        throw InvalidInput(ErrorCode::BadEdgeParameter, "edge parameter " + std::to_string(t) +
                                                            " of edge " + std::to_string(id) +
                                                            " must be a finite number in [0, 1]");
      }
      return;
    case Kind::Face: {
      if (id >= mesh.num_faces()) {
        throw InvalidInput(ErrorCode::FaceOutOfRange,
                           "face " + std::to_string(id) + " is out of range (mesh has " +
                               std::to_string(mesh.num_faces()) + " faces)");
      }
      double sum = 0;
      for (double b : bary) {
        if (!std::isfinite(b) || b < -kBarycentricNegativeTolerance) {
          throw InvalidInput(
              ErrorCode::BadBarycentric,
              "barycentric coordinates of " + to_string() + " must be finite and non-negative");
        }
        sum += b;
      }
      if (!(std::abs(sum - 1) <= kBarycentricSumTolerance)) {
        throw InvalidInput(ErrorCode::BadBarycentric, "barycentric coordinates of " + to_string() +
                                                          " sum to " + std::to_string(sum) +
                                                          ", not 1");
      }
      return;
    }
  }
  throw InvalidInput(ErrorCode::BadPoint, "unknown surface point kind");
}

Vec3 SurfacePoint::position(const TriangleMesh& mesh) const {
  switch (kind) {
    case Kind::Vertex:
      return mesh.position(id);
    case Kind::Edge:
      return (1 - t) * mesh.position(mesh.edge_origin(id)) +
             t * mesh.position(mesh.edge_target(id));
    case Kind::Face:
      return mesh.face_point(id, bary);
  }
  return {};
}

std::pair<std::uint32_t, std::array<double, 3>> SurfacePoint::in_face(
    const TriangleMesh& mesh) const {
  switch (kind) {
    case Kind::Vertex: {
      auto out = mesh.outgoing_halfedges(id);
      if (out.empty()) {
        throw InvalidInput(ErrorCode::IsolatedVertex,
                           "vertex " + std::to_string(id) + " belongs to no face");
      }
      const std::uint32_t h = out[0];
      std::array<double, 3> b{0, 0, 0};
      b[h % 3] = 1;
      return {TriangleMesh::face_of(h), b};
    }
    case Kind::Edge: {
      const std::uint32_t h = mesh.edge_halfedge(id);
      std::array<double, 3> b{0, 0, 0};
      b[h % 3] = 1 - t;
      b[(h % 3 + 1) % 3] = t;
      return {TriangleMesh::face_of(h), b};
    }
    case Kind::Face:
      return {id, bary};
  }
  return {0, {1, 0, 0}};
}

std::string SurfacePoint::to_string() const {
  char buf[128];
  switch (kind) {
    case Kind::Vertex:
      std::snprintf(buf, sizeof buf, "v:%u", id);
      break;
    case Kind::Edge:
      std::snprintf(buf, sizeof buf, "e:%u:%.17g", id, t);
      break;
    case Kind::Face:
      std::snprintf(buf, sizeof buf, "f:%u:%.17g:%.17g:%.17g", id, bary[0], bary[1], bary[2]);
      break;
  }
  return buf;
}

namespace {

[[noreturn]] void bad_syntax(const std::string& text, const std::string& why) {
  throw InvalidInput(ErrorCode::BadPointSyntax, "bad point '" + text + "': " + why +
                                                    " (expected v:ID, e:ID:t or f:ID:b0:b1:b2)");
}

std::uint32_t parse_id(const std::string& text, const std::string& field) {
  if (field.empty() || field.find_first_not_of("0123456789") != std::string::npos) {
    bad_syntax(text, "'" + field + "' is not a non-negative integer id");
  }
  errno = 0;
  const unsigned long long value = std::strtoull(field.c_str(), nullptr, 10);
  if (errno != 0 || value > UINT32_MAX) bad_syntax(text, "id '" + field + "' is too large");
  return static_cast<std::uint32_t>(value);
}

double parse_number(const std::string& text, const std::string& field) {
  if (field.empty()) bad_syntax(text, "empty number");
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(field.c_str(), &end);
  if (end != field.c_str() + field.size() || errno == ERANGE) {
    bad_syntax(text, "'" + field + "' is not a number");
  }
  if (!std::isfinite(value)) bad_syntax(text, "'" + field + "' is not finite");
  return value;
}

}  // namespace

void normalize_barycentrics(std::array<double, 3>& bary) {
  const double off = std::abs(bary[0] + bary[1] + bary[2] - 1);
  if (off <= kBarycentricSumTolerance && off > kBarycentricRoundingTolerance) {
    const double sum = bary[0] + bary[1] + bary[2];
    for (double& b : bary) b /= sum;
  }
}

SurfacePoint parse_surface_point(const std::string& text) {
  std::vector<std::string> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t colon = text.find(':', start);
    fields.push_back(text.substr(start, colon == std::string::npos ? std::string::npos
                                                                     : colon - start));
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  const std::string& kind = fields[0];
  if (kind == "v" && fields.size() == 2) return SurfacePoint::vertex(parse_id(text, fields[1]));
  if (kind == "e" && fields.size() == 3) {
    return SurfacePoint::edge(parse_id(text, fields[1]), parse_number(text, fields[2]));
  }
  if (kind == "f" && fields.size() == 5) {
    SurfacePoint p =
        SurfacePoint::face(parse_id(text, fields[1]), parse_number(text, fields[2]),
                           parse_number(text, fields[3]), parse_number(text, fields[4]));
    normalize_barycentrics(p.bary);
    return p;
  }
  if (kind != "v" && kind != "e" && kind != "f") bad_syntax(text, "unknown kind '" + kind + "'");
  bad_syntax(text, "wrong number of fields for kind '" + kind + "'");
}

}  // namespace geoprox
