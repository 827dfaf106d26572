// Limits the protocol enforces while reading requests, advertised by `server.info`.
//
// The parser refuses anything beyond them with reason TooLarge before any work is queued, so one
// client cannot make the server allocate or compute without bound. The server builds one Limits
// from its config (defaults below) and passes it to LineFramer, decode_message() and server.info.
#pragma once

#include <cstddef>
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <optional>

namespace geoprox::protocol {

inline constexpr std::size_t kDefaultMaxLineBytes = std::size_t{1} << 20;  // 1 MiB
inline constexpr std::size_t kDefaultMaxNestingDepth = 64;

struct Limits {
  /// Bytes of one request line, without its "\n" (LineFramer).
  std::size_t max_line_bytes = kDefaultMaxLineBytes;
  /// Nested arrays/objects in one line, the top-level object (or batch array) counting 1.
  /// Well-formed requests need at most 7 (a point inside a batch), one more inside a batch
  /// array; the limit protects the parser and anything that walks the document.
  std::size_t max_nesting_depth = kDefaultMaxNestingDepth;
  /// Points named by one request: sources + targets; a batch (method or array) counts all its
  /// requests together.
  std::size_t max_points_per_request = 10'000;
  /// sources x targets of one geodesic.matrix.
  std::size_t max_matrix_pairs = 1'000'000;
  /// Sources of one geodesic.field.
  std::size_t max_field_sources = 1'000;
  /// Entries of one batch, and elements of one batch array.
  std::size_t max_batch_requests = 1'000;
  /// Bytes of one reply line; the server checks it while serializing (TooLarge).
  std::size_t max_output_bytes = std::size_t{64} << 20;
  /// timeout_ms used when a request gives none, and the most a request may ask for: larger
  /// values are clamped (not refused), so clients need not know the server's setting.
  std::int64_t default_timeout_ms = 10'000;
  std::int64_t max_timeout_ms = 60'000;

  /// The deadline a request runs under: its own timeout_ms, or the default, at most the maximum.
  std::int64_t effective_timeout_ms(std::optional<std::int64_t> requested) const {
    const std::int64_t wanted = requested.value_or(default_timeout_ms);
    return wanted < max_timeout_ms ? wanted : max_timeout_ms;
  }
};

/// {"max_line_bytes": ..., ...}: every field above under its own name.
void to_json(nlohmann::json& out, const Limits& limits);

}  // namespace geoprox::protocol
