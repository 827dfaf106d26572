#include "protocol/points.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <vector>

#include "protocol/errors.h"
#include "protocol/json_access.h"

namespace geoprox::protocol {

using nlohmann::json;

namespace {

constexpr std::string_view kForms =
    "a point is {\"vertex\": ID}, {\"edge\": ID, \"t\": T}, {\"face\": ID, \"bary\": [B0, B1, "
    "B2]}, {\"sample\": ID}, {\"position\": [X, Y, Z]} or one of \"v:ID\", \"e:ID:T\", "
    "\"f:ID:B0:B1:B2\", \"s:ID\", \"p:X,Y,Z\"";

constexpr std::array<std::string_view, 5> kKindKeys = {"vertex", "edge", "face", "sample",
                                                       "position"};

std::string format_number(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  return json(value).dump();  // shortest text that reads back as the same double
}

ErrorReason out_of_range_reason(WirePoint::Kind kind) {
  switch (kind) {
    case WirePoint::Kind::Edge:
      return ErrorReason::EdgeOutOfRange;
    case WirePoint::Kind::Face:
      return ErrorReason::FaceOutOfRange;
    case WirePoint::Kind::Sample:
      return ErrorReason::SampleOutOfRange;
    case WirePoint::Kind::Vertex:
    case WirePoint::Kind::Position:
      break;
  }
  return ErrorReason::VertexOutOfRange;
}

/// Ids travel as uint32 (the core's id type): anything larger cannot exist in any mesh.
std::uint32_t checked_id(std::uint64_t id, WirePoint::Kind kind, const std::string& where) {
  if (id > std::numeric_limits<std::uint32_t>::max()) {
    throw ProtocolError(out_of_range_reason(kind),
                        where + " " + std::to_string(id) + " is out of range (ids are below 2^32)");
  }
  return static_cast<std::uint32_t>(id);
}

/// The value checks shared by both forms; `where` names the point ("params.source").
void check_values(WirePoint& point, std::string_view where) {
  const std::string at(where);
  switch (point.kind) {
    case WirePoint::Kind::Vertex:
    case WirePoint::Kind::Sample:
      return;
    case WirePoint::Kind::Edge:
      if (!std::isfinite(point.t) || point.t < 0 || point.t > 1) {
        throw ProtocolError(ErrorReason::BadEdgeParameter,
                            at + ": edge parameter t = " + format_number(point.t) +
                                " must be a finite number in [0, 1]");
      }
      return;
    case WirePoint::Kind::Face: {
      double sum = 0;
      for (double b : point.bary) {
        if (!std::isfinite(b) || b < -kBarycentricNegativeTolerance) {
          throw ProtocolError(ErrorReason::BadBarycentric, at + ": barycentric coordinate " +
                                                               format_number(b) +
                                                               " must be finite and non-negative");
        }
        sum += b;
      }
      if (!(std::abs(sum - 1) <= kBarycentricSumTolerance)) {
        throw ProtocolError(ErrorReason::BadBarycentric, at + ": barycentric coordinates sum to " +
                                                             format_number(sum) +
                                                             ", not 1 (tolerance 1e-5)");
      }
      // Sums off by rounding alone are kept as sent, so that a point written back and parsed
      // again is the same point.
      if (std::abs(sum - 1) > kBarycentricRoundingTolerance) {
        for (double& b : point.bary) b /= sum;
      }
      return;
    }
    case WirePoint::Kind::Position:
      for (double x : point.position) {
        if (!std::isfinite(x)) {
          throw ProtocolError(ErrorReason::BadPoint,
                              at + ": position coordinate " + format_number(x) + " is not finite");
        }
      }
      return;
  }
}

// ---- object form ----

std::uint32_t read_id(const detail::ObjectFields& fields, std::string_view key,
                      WirePoint::Kind kind) {
  const json& value = fields.require(key);
  const std::optional<std::uint64_t> id = detail::as_unsigned(value);
  if (!id) {
    fields.fail(key, "must be a non-negative integer id, not " + detail::json_excerpt(value));
  }
  return checked_id(*id, kind, fields.path_of(key));
}

std::array<double, 3> read_triple(const detail::ObjectFields& fields, std::string_view key,
                                  std::string_view what) {
  const json& value = fields.require(key);
  if (!value.is_array() || value.size() != 3) {
    fields.fail(key, "must be an array of 3 numbers (" + std::string(what) + "), not " +
                         detail::json_excerpt(value));
  }
  std::array<double, 3> triple{};
  for (std::size_t i = 0; i < 3; ++i) {
    if (!value[i].is_number()) {
      throw ProtocolError(ErrorReason::BadPoint, fields.path_of(key) + "[" + std::to_string(i) +
                                                     "] must be a number, not " +
                                                     detail::type_of(value[i]));
    }
    triple[i] = value[i].get<double>();
  }
  return triple;
}

WirePoint parse_point_object(const json& value, std::string_view path) {
  const std::string where(path);
  std::vector<std::string_view> kinds;
  for (std::string_view key : kKindKeys) {
    if (value.contains(key)) kinds.push_back(key);
  }
  if (kinds.empty()) {
    throw ProtocolError(ErrorReason::BadPoint,
                        where + " names no point kind: " + std::string(kForms));
  }
  if (kinds.size() > 1) {
    throw ProtocolError(ErrorReason::BadPoint, where + " has both \"" + std::string(kinds[0]) +
                                                   "\" and \"" + std::string(kinds[1]) +
                                                   "\"; a point has exactly one kind");
  }
  const std::string_view kind = kinds[0];
  WirePoint point;
  if (kind == "vertex") {
    const detail::ObjectFields fields(value, where, {"vertex"}, ErrorReason::BadPoint);
    point = WirePoint::vertex(read_id(fields, "vertex", WirePoint::Kind::Vertex));
  } else if (kind == "edge") {
    const detail::ObjectFields fields(value, where, {"edge", "t"}, ErrorReason::BadPoint);
    const std::uint32_t edge = read_id(fields, "edge", WirePoint::Kind::Edge);
    const json& t = fields.require("t");
    if (!t.is_number())
      fields.fail("t", std::string("must be a number, not ") + detail::type_of(t));
    point = WirePoint::edge(edge, t.get<double>());
  } else if (kind == "face") {
    const detail::ObjectFields fields(value, where, {"face", "bary"}, ErrorReason::BadPoint);
    const std::uint32_t face = read_id(fields, "face", WirePoint::Kind::Face);
    point = WirePoint::face(face, read_triple(fields, "bary", "barycentric coordinates"));
  } else if (kind == "sample") {
    const detail::ObjectFields fields(value, where, {"sample"}, ErrorReason::BadPoint);
    point = WirePoint::sample(read_id(fields, "sample", WirePoint::Kind::Sample));
  } else {
    const detail::ObjectFields fields(value, where, {"position"}, ErrorReason::BadPoint);
    point = WirePoint::at_position(read_triple(fields, "position", "x, y, z"));
  }
  check_values(point, path);
  return point;
}

// ---- string form ----

[[noreturn]] void bad_text(std::string_view text, std::string_view path, const std::string& why) {
  throw ProtocolError(ErrorReason::BadPoint, std::string(path) + ": bad point \"" +
                                                 detail::excerpt(text) + "\": " + why + " (" +
                                                 std::string(kForms) + ")");
}

std::vector<std::string_view> split(std::string_view text, char separator) {
  std::vector<std::string_view> parts;
  while (true) {
    const std::size_t at = text.find(separator);
    parts.push_back(text.substr(0, at));
    if (at == std::string_view::npos) return parts;
    text.remove_prefix(at + 1);
  }
}

std::uint32_t parse_text_id(std::string_view field, WirePoint::Kind kind, std::string_view text,
                            std::string_view path) {
  if (field.empty() || field.find_first_not_of("0123456789") != std::string_view::npos) {
    bad_text(text, path, "'" + detail::excerpt(field) + "' is not a non-negative integer id");
  }
  std::uint64_t id = 0;
  const auto [end, error] = std::from_chars(field.data(), field.data() + field.size(), id);
  if (error == std::errc::result_out_of_range) {
    throw ProtocolError(out_of_range_reason(kind), std::string(path) + ": id " +
                                                       detail::excerpt(field) +
                                                       " is out of range (ids are below 2^32)");
  }
  return checked_id(id, kind, std::string(path) + ": id");
}

/// A decimal number. Out of the range of a double, strtod says which way: overflow reads as
/// infinity (for check_values to refuse with the reason of its kind), underflow as 0 or a
/// subnormal, which is a fine coordinate.
double parse_text_number(std::string_view field, std::string_view text, std::string_view path) {
  double value = 0;
  const char* first = field.data();
  const char* last = field.data() + field.size();
  const auto [end, error] = std::from_chars(first, last, value);
  if (field.empty() || end != last ||
      (error != std::errc() && error != std::errc::result_out_of_range)) {
    bad_text(text, path, "'" + detail::excerpt(field) + "' is not a number");
  }
  if (error == std::errc::result_out_of_range)
    value = std::strtod(std::string(field).c_str(), nullptr);
  return value;
}

}  // namespace

WirePoint parse_point_text(std::string_view text, std::string_view path) {
  const std::vector<std::string_view> fields = split(text, ':');
  const std::string_view kind = fields[0];
  const auto want_fields = [&](std::size_t count) {
    if (fields.size() != count) {
      bad_text(text, path,
               "kind '" + std::string(kind) + "' takes " + std::to_string(count - 1) + " field" +
                   (count == 2 ? "" : "s") + " after it, not " + std::to_string(fields.size() - 1));
    }
  };
  WirePoint point;
  if (kind == "v") {
    want_fields(2);
    point = WirePoint::vertex(parse_text_id(fields[1], WirePoint::Kind::Vertex, text, path));
  } else if (kind == "e") {
    want_fields(3);
    const std::uint32_t edge = parse_text_id(fields[1], WirePoint::Kind::Edge, text, path);
    point = WirePoint::edge(edge, parse_text_number(fields[2], text, path));
  } else if (kind == "f") {
    want_fields(5);
    const std::uint32_t face = parse_text_id(fields[1], WirePoint::Kind::Face, text, path);
    point = WirePoint::face(
        face, {parse_text_number(fields[2], text, path), parse_text_number(fields[3], text, path),
               parse_text_number(fields[4], text, path)});
  } else if (kind == "s") {
    want_fields(2);
    point = WirePoint::sample(parse_text_id(fields[1], WirePoint::Kind::Sample, text, path));
  } else if (kind == "p") {
    want_fields(2);
    const std::vector<std::string_view> coordinates = split(fields[1], ',');
    if (coordinates.size() != 3) {
      bad_text(text, path,
               "a position has 3 comma-separated coordinates, not " +
                   std::to_string(coordinates.size()));
    }
    point = WirePoint::at_position({parse_text_number(coordinates[0], text, path),
                                    parse_text_number(coordinates[1], text, path),
                                    parse_text_number(coordinates[2], text, path)});
  } else {
    bad_text(text, path, "unknown kind '" + detail::excerpt(kind) + "'");
  }
  check_values(point, path);
  return point;
}

WirePoint parse_point(const json& value, std::string_view path) {
  if (value.is_string()) return parse_point_text(value.get_ref<const std::string&>(), path);
  if (value.is_object()) return parse_point_object(value, path);
  throw ProtocolError(ErrorReason::BadPoint, std::string(path) + " must be a point, not " +
                                                 detail::type_of(value) + ": " +
                                                 std::string(kForms));
}

void to_json(json& out, const WirePoint& point) {
  switch (point.kind) {
    case WirePoint::Kind::Vertex:
      out = {{"vertex", point.id}};
      return;
    case WirePoint::Kind::Edge:
      out = {{"edge", point.id}, {"t", point.t}};
      return;
    case WirePoint::Kind::Face:
      out = {{"face", point.id}, {"bary", point.bary}};
      return;
    case WirePoint::Kind::Sample:
      out = {{"sample", point.id}};
      return;
    case WirePoint::Kind::Position:
      out = {{"position", point.position}};
      return;
  }
}

std::string to_text(const WirePoint& point) {
  char buffer[160];
  switch (point.kind) {
    case WirePoint::Kind::Vertex:
      std::snprintf(buffer, sizeof buffer, "v:%u", point.id);
      break;
    case WirePoint::Kind::Edge:
      std::snprintf(buffer, sizeof buffer, "e:%u:%.17g", point.id, point.t);
      break;
    case WirePoint::Kind::Face:
      std::snprintf(buffer, sizeof buffer, "f:%u:%.17g:%.17g:%.17g", point.id, point.bary[0],
                    point.bary[1], point.bary[2]);
      break;
    case WirePoint::Kind::Sample:
      std::snprintf(buffer, sizeof buffer, "s:%u", point.id);
      break;
    case WirePoint::Kind::Position:
      std::snprintf(buffer, sizeof buffer, "p:%.17g,%.17g,%.17g", point.position[0],
                    point.position[1], point.position[2]);
      break;
  }
  return buffer;
}

}  // namespace geoprox::protocol
