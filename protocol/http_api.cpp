#include "protocol/http_api.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "protocol/json_access.h"

namespace geoprox::protocol {

using nlohmann::json;

namespace {

constexpr std::string_view kMeshesPrefix = "/v1/meshes";

struct QueryOperation {
  std::string_view segment;
  Method method;
};
constexpr std::array kQueryOperations = {
    QueryOperation{"distance", Method::GeodesicDistance},
    QueryOperation{"path", Method::GeodesicPath},
    QueryOperation{"field", Method::GeodesicField},
    QueryOperation{"matrix", Method::GeodesicMatrix},
    QueryOperation{"expmap", Method::GeodesicExpmap},
    QueryOperation{"spline", Method::GeodesicSpline},
};

// The members of the query methods' params by JSON type (protocol/params.h).
constexpr std::array<std::string_view, 3> kListMembers = {"sources", "targets", "control"};
constexpr std::array<std::string_view, 4> kNumberMembers = {"cutoff", "radius", "samples",
                                                            "timeout_ms"};
constexpr std::array<std::string_view, 1> kBooleanMembers = {"exact"};

template <std::size_t N>
bool is_one_of(const std::array<std::string_view, N>& names, std::string_view name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

/// `text` in double quotes, clipped: client text in error messages stays short.
std::string in_quotes(std::string_view text) {
  std::string out(1, '"');
  out += detail::excerpt(text);
  out += '"';
  return out;
}

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::string percent_decode(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '+') {
      out += ' ';
    } else if (c == '%') {
      const int h = i + 1 < text.size() ? hex_value(text[i + 1]) : -1;
      const int l = i + 2 < text.size() ? hex_value(text[i + 2]) : -1;
      if (h < 0 || l < 0) {
        throw ProtocolError(ErrorReason::InvalidParams,
                            "query string: \"%\" must be followed by two hex digits");
      }
      out += static_cast<char>(h * 16 + l);
      i += 2;
    } else {
      out += c;
    }
  }
  return out;
}

/// Lower-cased copy (HTTP tokens and media types are case-insensitive).
std::string lower(std::string_view text) {
  std::string out(text);
  for (char& c : out) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return out;
}

std::string_view trim(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t')) text.remove_suffix(1);
  return text;
}

/// One element of an Accept or Accept-Encoding list: its value and its q (1 when absent; 0 for
/// an unreadable q, which refuses it).
struct Weighted {
  std::string value;
  double q = 1;
};

std::vector<Weighted> weighted_list(std::string_view header) {
  std::vector<Weighted> out;
  while (!header.empty()) {
    const std::size_t comma = header.find(',');
    std::string_view item = header.substr(0, comma);
    header = comma == std::string_view::npos ? std::string_view() : header.substr(comma + 1);
    Weighted w;
    const std::size_t semicolon = item.find(';');
    w.value = lower(trim(item.substr(0, semicolon)));
    std::string_view parameters =
        semicolon == std::string_view::npos ? std::string_view() : item.substr(semicolon + 1);
    while (!parameters.empty()) {
      const std::size_t next = parameters.find(';');
      const std::string_view parameter = trim(parameters.substr(0, next));
      parameters =
          next == std::string_view::npos ? std::string_view() : parameters.substr(next + 1);
      if (parameter.size() >= 2 && (parameter[0] == 'q' || parameter[0] == 'Q') &&
          parameter[1] == '=') {
        const std::string q(trim(parameter.substr(2)));
        char* end = nullptr;
        const double value = std::strtod(q.c_str(), &end);
        w.q = end != q.c_str() && *end == '\0' && value >= 0 && value <= 1 ? value : 0;
      }
    }
    if (!w.value.empty()) out.push_back(std::move(w));
  }
  return out;
}

/// q of `type` ("application/json") under `ranges`: that of the most specific range matching
/// it (exact, then "application/*", then "*/*"), 0 when none does.
double media_q(const std::vector<Weighted>& ranges, std::string_view type) {
  const std::string_view major = type.substr(0, type.find('/'));
  int best_specificity = -1;
  double q = 0;
  for (const Weighted& range : ranges) {
    int specificity = -1;
    if (range.value == type) {
      specificity = 2;
    } else if (range.value.size() == major.size() + 2 && range.value.starts_with(major) &&
               range.value.ends_with("/*")) {
      specificity = 1;
    } else if (range.value == "*/*") {
      specificity = 0;
    }
    if (specificity > best_specificity) {
      best_specificity = specificity;
      q = range.q;
    }
  }
  return q;
}

void append_le(std::string& out, std::uint32_t bits) {
  for (int k = 0; k < 4; ++k) out += static_cast<char>((bits >> (8 * k)) & 0xFF);
}

void append_le(std::string& out, std::uint64_t bits) {
  for (int k = 0; k < 8; ++k) out += static_cast<char>((bits >> (8 * k)) & 0xFF);
}

}  // namespace

HttpRoute route_http_path(std::string_view path) {
  HttpRoute route;
  if (path == "/healthz") {
    route.kind = HttpRoute::Kind::Healthz;
  } else if (path == "/readyz") {
    route.kind = HttpRoute::Kind::Readyz;
  } else if (path == "/v1/rpc") {
    route.kind = HttpRoute::Kind::Rpc;
  } else if (path == kMeshesPrefix) {
    route.kind = HttpRoute::Kind::MeshList;
  } else if (path.starts_with(kMeshesPrefix) && path.size() > kMeshesPrefix.size() + 1 &&
             path[kMeshesPrefix.size()] == '/') {
    const std::string_view rest = path.substr(kMeshesPrefix.size() + 1);
    const std::size_t slash = rest.find('/');
    const std::string_view mesh = rest.substr(0, slash);
    if (!is_valid_mesh_id(mesh)) return route;
    if (slash == std::string_view::npos) {
      route.kind = HttpRoute::Kind::MeshInfo;
    } else {
      const std::string_view operation = rest.substr(slash + 1);
      if (operation == "geometry") {
        route.kind = HttpRoute::Kind::Geometry;
      } else {
        for (const QueryOperation& q : kQueryOperations) {
          if (q.segment == operation) {
            route.kind = HttpRoute::Kind::Query;
            route.method = q.method;
          }
        }
        if (route.kind != HttpRoute::Kind::Query) return route;
      }
    }
    route.mesh = std::string(mesh);
  } else if (path != "/v1" && !path.starts_with("/v1/")) {
    route.kind = HttpRoute::Kind::Static;
  }
  return route;
}

std::string static_file_path(std::string_view path) {
  const auto refuse = [&](const std::string& why) {
    return ProtocolError(ErrorReason::InvalidRequest,
                         "path " + in_quotes(path) + ": " + why + " (not a file of the viewer)");
  };
  if (!path.starts_with('/')) throw refuse("it must start with \"/\"");
  std::string decoded;
  decoded.reserve(path.size());
  for (std::size_t i = 0; i < path.size(); ++i) {
    char c = path[i];
    if (c == '%') {
      const int h = i + 1 < path.size() ? hex_value(path[i + 1]) : -1;
      const int l = i + 2 < path.size() ? hex_value(path[i + 2]) : -1;
      if (h < 0 || l < 0) throw refuse("\"%\" must be followed by two hex digits");
      c = static_cast<char>(h * 16 + l);
      if (c == '/' || c == '\\') throw refuse("an encoded \"/\" or \"\\\"");
      i += 2;
    }
    if (c == '\\') throw refuse("a backslash");
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7F) throw refuse("a control byte");
    decoded += c;
  }
  std::string_view rest = std::string_view(decoded).substr(1);
  std::string file;
  while (!rest.empty()) {
    const std::size_t slash = rest.find('/');
    const std::string_view segment = rest.substr(0, slash);
    if (segment.empty()) throw refuse("an empty segment (\"//\")");
    if (segment == "." || segment == "..") throw refuse("a \".\" or \"..\" segment");
    if (segment.front() == '.') {
      throw ProtocolError(ErrorReason::NotFound, "no file at " + in_quotes(path));
    }
    if (!file.empty()) file += '/';
    file += segment;
    rest = slash == std::string_view::npos ? std::string_view() : rest.substr(slash + 1);
  }
  if (decoded.ends_with('/')) file += file.empty() ? "index.html" : "/index.html";
  return file;
}

std::string_view static_content_type(std::string_view file) {
  struct Type {
    std::string_view extension;
    std::string_view type;
  };
  constexpr std::array kTypes = {
      Type{".html", "text/html; charset=utf-8"},
      Type{".js", "text/javascript; charset=utf-8"},
      Type{".mjs", "text/javascript; charset=utf-8"},
      Type{".css", "text/css; charset=utf-8"},
      Type{".png", "image/png"},
      Type{".svg", "image/svg+xml"},
      Type{".json", "application/json"},
      Type{".map", "application/json"},
      Type{".wasm", "application/wasm"},
      Type{".ico", "image/x-icon"},
      Type{".txt", "text/plain; charset=utf-8"},
  };
  const std::size_t slash = file.rfind('/');
  const std::string_view name = slash == std::string_view::npos ? file : file.substr(slash + 1);
  const std::size_t dot = name.rfind('.');
  if (dot != std::string_view::npos) {
    const std::string extension = lower(name.substr(dot));
    for (const Type& t : kTypes) {
      if (t.extension == extension) return t.type;
    }
  }
  return "application/octet-stream";
}

std::string_view static_cache_control(std::string_view file) {
  return file.starts_with("assets/") ? "public, max-age=31536000, immutable" : "no-cache";
}

std::vector<std::pair<std::string, std::string>> parse_query_string(std::string_view query) {
  std::vector<std::pair<std::string, std::string>> out;
  while (!query.empty()) {
    const std::size_t amp = query.find('&');
    const std::string_view item = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view() : query.substr(amp + 1);
    if (item.empty()) continue;
    const std::size_t eq = item.find('=');
    std::string name = percent_decode(item.substr(0, eq));
    std::string value =
        eq == std::string_view::npos ? std::string() : percent_decode(item.substr(eq + 1));
    out.emplace_back(std::move(name), std::move(value));
  }
  return out;
}

json query_params_object(const std::string& mesh,
                         const std::vector<std::pair<std::string, std::string>>& query) {
  json params = json::object();
  for (const auto& [name, value] : query) {
    const std::string where = "query parameter " + in_quotes(name);
    if (is_one_of(kListMembers, name)) {
      json& list = params[name];
      if (list.is_null()) list = json::array();
      list.push_back(value);
      continue;
    }
    if (params.contains(name)) {
      throw ProtocolError(ErrorReason::InvalidParams, where + " is given more than once");
    }
    if (is_one_of(kNumberMembers, name)) {
      json number = json::parse(value, nullptr, /*allow_exceptions=*/false);
      if (!number.is_number()) {
        throw ProtocolError(ErrorReason::InvalidParams,
                            where + ": expected a number, got " + in_quotes(value));
      }
      params[name] = std::move(number);
    } else if (is_one_of(kBooleanMembers, name)) {
      if (value != "true" && value != "false") {
        throw ProtocolError(ErrorReason::InvalidParams,
                            where + ": expected true or false, got " + in_quotes(value));
      }
      params[name] = value == "true";
    } else {
      params[name] = value;
    }
  }
  if (params.contains("mesh")) {
    throw ProtocolError(ErrorReason::InvalidParams,
                        "query parameter \"mesh\": the mesh is named by the path");
  }
  params["mesh"] = mesh;
  return params;
}

unsigned http_status(ErrorReason reason, bool token_sent) {
  switch (reason) {
    case ErrorReason::ParseError:
    case ErrorReason::InvalidRequest:
    case ErrorReason::InvalidParams:
    case ErrorReason::BadPoint:
    case ErrorReason::BadBarycentric:
    case ErrorReason::BadEdgeParameter:
    case ErrorReason::VertexOutOfRange:
    case ErrorReason::EdgeOutOfRange:
    case ErrorReason::FaceOutOfRange:
    case ErrorReason::SampleOutOfRange:
    case ErrorReason::IsolatedVertex:
    case ErrorReason::PathNotAllowed:
    case ErrorReason::BadMeshFile:
      return 400;
    case ErrorReason::Unauthorized:
      return token_sent ? 403 : 401;
    case ErrorReason::UnknownMethod:
    case ErrorReason::UnknownMesh:
    case ErrorReason::NotFound:
      return 404;
    case ErrorReason::MeshExists:
      return 409;
    case ErrorReason::TooLarge:
      return 413;
    case ErrorReason::Unreachable:
      return 422;
    case ErrorReason::Overloaded:
      return 429;
    case ErrorReason::MeshNotReady:
    case ErrorReason::MeshBuildFailed:
    case ErrorReason::ShuttingDown:
    case ErrorReason::ResourceExhausted:
      return 503;
    case ErrorReason::DeadlineExceeded:
      return 504;
    case ErrorReason::Internal:
      break;
  }
  return 500;
}

std::optional<HttpFormat> negotiate_format(std::string_view accept, bool binary_allowed) {
  if (trim(accept).empty()) return HttpFormat::Json;
  const std::vector<Weighted> ranges = weighted_list(accept);
  struct Candidate {
    HttpFormat format;
    std::string_view type;
  };
  constexpr std::array<Candidate, 3> kCandidates = {
      Candidate{HttpFormat::Json, "application/json"},
      Candidate{HttpFormat::OctetStream, "application/octet-stream"},
      Candidate{HttpFormat::Npy, "application/x-npy"},
  };
  std::optional<HttpFormat> best;
  double best_q = 0;
  for (const Candidate& c : kCandidates) {
    if (c.format != HttpFormat::Json && !binary_allowed) continue;
    const double q = media_q(ranges, c.type);
    // A wildcard gives every format the same q: JSON, first, wins the tie.
    if (q > best_q) {
      best_q = q;
      best = c.format;
    }
  }
  return best;
}

bool accepts_gzip(std::string_view accept_encoding) {
  for (const Weighted& w : weighted_list(accept_encoding)) {
    if ((w.value == "gzip" || w.value == "x-gzip") && w.q > 0) return true;
  }
  return false;
}

std::string_view dtype_name(Dtype dtype) {
  switch (dtype) {
    case Dtype::Float64:
      return "float64";
    case Dtype::Float32:
      return "float32";
    case Dtype::Uint32:
      return "uint32";
  }
  return "?";
}

std::optional<Dtype> float_dtype_from_name(std::string_view name) {
  if (name == "float64") return Dtype::Float64;
  if (name == "float32") return Dtype::Float32;
  return std::nullopt;
}

BinaryArray float_array(std::span<const double> values, std::vector<std::size_t> shape,
                        Dtype dtype) {
  BinaryArray array;
  array.dtype = dtype;
  array.shape = std::move(shape);
  const bool wide = dtype == Dtype::Float64;
  array.bytes.reserve(values.size() * (wide ? 8 : 4));
  for (double value : values) {
    if (!std::isfinite(value)) value = std::numeric_limits<double>::quiet_NaN();
    if (wide) {
      append_le(array.bytes, std::bit_cast<std::uint64_t>(value));
    } else {
      append_le(array.bytes, std::bit_cast<std::uint32_t>(static_cast<float>(value)));
    }
  }
  return array;
}

BinaryArray uint32_array(std::span<const std::uint32_t> values, std::vector<std::size_t> shape) {
  BinaryArray array;
  array.dtype = Dtype::Uint32;
  array.shape = std::move(shape);
  array.bytes.reserve(values.size() * 4);
  for (const std::uint32_t value : values) append_le(array.bytes, value);
  return array;
}

std::string shape_header(const std::vector<std::size_t>& shape) {
  std::string out;
  for (std::size_t i = 0; i < shape.size(); ++i) {
    if (i > 0) out += ',';
    out += std::to_string(shape[i]);
  }
  return out;
}

std::string encode_npy(const BinaryArray& array) {
  // Format 1.0: magic, version, a little-endian u16 header length, then a Python dict literal
  // padded with spaces to a multiple of 64 bytes (header included) and ended by "\n".
  std::string dict = "{'descr': '";
  dict += array.dtype == Dtype::Float64 ? "<f8" : array.dtype == Dtype::Float32 ? "<f4" : "<u4";
  dict += "', 'fortran_order': False, 'shape': (";
  for (std::size_t i = 0; i < array.shape.size(); ++i) {
    if (i > 0) dict += ", ";
    dict += std::to_string(array.shape[i]);
  }
  if (array.shape.size() == 1) dict += ',';  // a Python 1-tuple: (5000,)
  dict += ')';
  dict += ", }";
  constexpr std::size_t kPreamble = 10;  // magic (6) + version (2) + header length (2)
  constexpr std::size_t kAlignment = 64;
  std::size_t header = dict.size() + 1;
  header += (kAlignment - (kPreamble + header) % kAlignment) % kAlignment;
  dict.append(header - dict.size() - 1, ' ');
  dict += '\n';
  std::string out("\x93NUMPY\x01\x00", 8);
  out += static_cast<char>(header & 0xFF);
  out += static_cast<char>((header >> 8) & 0xFF);
  out += dict;
  out += array.bytes;
  return out;
}

std::string http_error_body(const ProtocolError& error) {
  json body = json::object();
  body["error"] = error_to_json(error);
  return dump_one_line(body);
}

}  // namespace geoprox::protocol
