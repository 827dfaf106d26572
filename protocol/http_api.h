// The HTTP mapping of the protocol (docs/http.md), without I/O: which resource a request path
// names, the params object of a GET query string, the HTTP status of each error reason, the
// response format an Accept header asks for, and the binary array encodings (raw little-endian
// and numpy's .npy). The server (server/http_handler.h) reads requests and writes responses;
// everything here is a pure function of its arguments, safe from any thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "protocol/errors.h"
#include "protocol/messages.h"

namespace geoprox::protocol {

/// What a request path names.
struct HttpRoute {
  enum class Kind : std::uint8_t {
    Healthz,   ///< /healthz
    Readyz,    ///< /readyz
    Rpc,       ///< /v1/rpc
    MeshList,  ///< /v1/meshes
    MeshInfo,  ///< /v1/meshes/{id}
    Query,     ///< /v1/meshes/{id}/distance|path|field|matrix|expmap|spline
    Geometry,  ///< /v1/meshes/{id}/geometry
    Static,    ///< any other path outside /v1/: a file of the web viewer (static_file_path)
    Unknown,   ///< an unknown path under /v1/
  };
  Kind kind = Kind::Unknown;
  std::string mesh;                 ///< MeshInfo, Query, Geometry
  std::optional<Method> method;     ///< Query: the method it runs
};

/// The route of `path` (the request target without its query string). A mesh id that is not
/// valid (is_valid_mesh_id) makes the path Unknown; a path outside /v1/ (and not a health
/// check) is Static.
HttpRoute route_http_path(std::string_view path);

/// The file that a Static path names, relative to the static directory, '/'-separated and
/// percent-decoded: "/" and any path ending in '/' name their "index.html". Throws
/// ProtocolError(InvalidRequest) for what could reach outside the directory or is not a plain
/// file name: a bad %-escape, an encoded '/' or '\\' (%2F, %5C), a backslash, a NUL or control
/// byte, an empty, "." or ".." segment (encoded ones too), a path not starting with '/'.
/// Throws ProtocolError(NotFound) for a segment starting with '.' (hidden files).
std::string static_file_path(std::string_view path);

/// The Content-Type of a static file, by its extension (.html .js .mjs .css .png .svg .json
/// .wasm .ico .map .txt; anything else application/octet-stream).
std::string_view static_content_type(std::string_view file);

/// The Cache-Control of a static file: under "assets/" (content-hashed names, never changed in
/// place) "public, max-age=31536000, immutable"; anything else (index.html) "no-cache".
std::string_view static_cache_control(std::string_view file);

/// Splits "a=1&b=x%20y" into decoded (name, value) pairs, in order ('+' is a space). Throws
/// ProtocolError(InvalidParams) for a bad %-escape; names may repeat.
std::vector<std::pair<std::string, std::string>> parse_query_string(std::string_view query);

/// The params object of a Query route's GET: one member per query parameter, typed as the
/// methods' params are (points and strings as text; cutoff, radius, samples and timeout_ms as
/// numbers; exact as a boolean; sources, targets and control as arrays of every repetition),
/// plus "mesh". Other names are kept as strings, so that parse_params() refuses them by name.
/// Throws ProtocolError(InvalidParams) for a number or boolean that does not parse, or a
/// repeated single-valued parameter.
nlohmann::json query_params_object(const std::string& mesh,
                                   const std::vector<std::pair<std::string, std::string>>& query);

/// The HTTP status of an error reason. `token_sent`: whether the request carried a token, which
/// tells 401 (none) from 403 (a wrong one) for Unauthorized.
unsigned http_status(ErrorReason reason, bool token_sent = false);

/// Formats a response can take.
enum class HttpFormat : std::uint8_t { Json, OctetStream, Npy };

/// The format to answer in, from an Accept header (q-values honoured; the most specific media
/// range decides each format's q). `binary_allowed`: the resource has an array to send.
/// Nothing acceptable: nullopt (the caller answers 406). An empty header accepts JSON.
std::optional<HttpFormat> negotiate_format(std::string_view accept, bool binary_allowed);

/// Whether an Accept-Encoding header accepts gzip (q > 0).
bool accepts_gzip(std::string_view accept_encoding);

/// Element types of binary arrays.
enum class Dtype : std::uint8_t { Float64, Float32, Uint32 };
std::string_view dtype_name(Dtype dtype);  ///< "float64", "float32", "uint32"
/// "float64" / "float32" (the `dtype` query parameter); nullopt for anything else.
std::optional<Dtype> float_dtype_from_name(std::string_view name);

/// One array of a binary response: little-endian elements in C order, and its shape.
struct BinaryArray {
  Dtype dtype = Dtype::Float64;
  std::vector<std::size_t> shape;
  std::string bytes;
};

/// Doubles as float64 or float32 (+inf, i.e. not reached, and NaN become NaN).
BinaryArray float_array(std::span<const double> values, std::vector<std::size_t> shape,
                        Dtype dtype);
/// Unsigned 32-bit values.
BinaryArray uint32_array(std::span<const std::uint32_t> values, std::vector<std::size_t> shape);

/// "5000" or "3,4": the X-Geoprox-Shape header.
std::string shape_header(const std::vector<std::size_t>& shape);
/// The array as a numpy .npy file (format version 1.0).
std::string encode_npy(const BinaryArray& array);

/// The error body of resource paths: {"error": error_to_json(error)}.
std::string http_error_body(const ProtocolError& error);

}  // namespace geoprox::protocol
