// Points on a mesh as they travel on the wire.
//
// Object forms (exactly one kind key per object; no other members):
//   {"vertex": 12}                      a mesh vertex
//   {"edge": 7, "t": 0.25}              the point at t in [0, 1] along edge 7, origin to target
//   {"face": 5, "bary": [0.2, 0.3, 0.5]}  barycentrics in the order of the face's vertices
//   {"sample": 3}                       a sample (node) of the mesh's proximity graph
//   {"position": [x, y, z]}             a point in space; the server snaps it to the surface
// String forms, the command-line syntax: "v:12", "e:7:0.25", "f:5:0.2:0.3:0.5", "s:3",
// "p:x,y,z". Ids and numbers mean the same as in core/mesh/surface_point.h and core/mesh/mesh.h.
//
// Checked here, without a mesh: shape and types (BadPoint), ids are integers in [0, 2^32)
// (larger ones are <Kind>OutOfRange: no mesh has that many), t finite in [0, 1]
// (BadEdgeParameter), barycentrics finite, >= -1e-12 and summing to 1 within 1e-5, then divided by
// their sum (BadBarycentric), positions finite (BadPoint). Ids against the mesh are the server's
// check.
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace geoprox::protocol {

struct WirePoint {
  enum class Kind : std::uint8_t { Vertex, Edge, Face, Sample, Position };

  Kind kind = Kind::Vertex;
  std::uint32_t id = 0;                     ///< vertex, edge, face or sample id
  double t = 0;                             ///< Kind::Edge
  std::array<double, 3> bary{1, 0, 0};      ///< Kind::Face
  std::array<double, 3> position{0, 0, 0};  ///< Kind::Position

  static WirePoint vertex(std::uint32_t v) { return {Kind::Vertex, v, 0, {1, 0, 0}, {}}; }
  static WirePoint edge(std::uint32_t e, double t) { return {Kind::Edge, e, t, {1, 0, 0}, {}}; }
  static WirePoint face(std::uint32_t f, std::array<double, 3> b) {
    return {Kind::Face, f, 0, b, {}};
  }
  static WirePoint sample(std::uint32_t s) { return {Kind::Sample, s, 0, {1, 0, 0}, {}}; }
  static WirePoint at_position(std::array<double, 3> p) {
    return {Kind::Position, 0, 0, {1, 0, 0}, p};
  }

  bool operator==(const WirePoint&) const = default;
};

/// Barycentric tolerances, the same as core/mesh/surface_point.h's. The sum's covers coordinates
/// rounded to six decimals (each off by up to 5e-7); accepted sums are divided out.
inline constexpr double kBarycentricNegativeTolerance = 1e-12;
inline constexpr double kBarycentricSumTolerance = 1e-5;
/// Sums within this of 1 are rounding: such barycentrics are taken as they are.
inline constexpr double kBarycentricRoundingTolerance = 1e-12;

/// Parses an object or string form; `path` names the value in messages ("params.source").
/// Throws ProtocolError (BadPoint, BadBarycentric, BadEdgeParameter, <Kind>OutOfRange).
WirePoint parse_point(const nlohmann::json& value, std::string_view path);
/// The string form alone ("f:5:0.2:0.3:0.5"); same checks and errors.
WirePoint parse_point_text(std::string_view text, std::string_view path = "point");

/// The object form, e.g. {"edge":7,"t":0.25}; numbers round-trip exactly.
void to_json(nlohmann::json& out, const WirePoint& point);
/// The string form at full precision (%.17g), e.g. "e:7:0.25".
std::string to_text(const WirePoint& point);

}  // namespace geoprox::protocol
