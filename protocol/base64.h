// Base64 (RFC 4648, standard alphabet, with padding) and the little-endian array encodings of
// geodesic.field and geodesic.matrix: "f32le-base64" for distances (IEEE-754 binary32; +inf =
// not reached), "f64le-base64" for distances (IEEE-754 binary64, the very doubles of the JSON
// numbers; +inf = not reached) and "u32le-base64" for nearest-source indices (0xFFFFFFFF = not
// reached). Little-endian whatever the host, so a client decodes with
// numpy.frombuffer(base64.b64decode(s), "<f4") (or "<f8").
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace geoprox::protocol {

std::string base64_encode(std::span<const std::uint8_t> bytes);
/// Strict: only the standard alphabet, length a multiple of 4, '=' only as final padding, and
/// unused bits of the last group zero (so every byte string has exactly one encoding). Throws
/// std::invalid_argument naming the offending position.
std::vector<std::uint8_t> base64_decode(std::string_view text);

std::string encode_f32le_base64(std::span<const float> values);
/// Rounds each double to the nearest float (infinities stay infinite).
std::string encode_f32le_base64(std::span<const double> values);
/// Throws std::invalid_argument if not base64 or not a whole number of 4-byte values.
std::vector<float> decode_f32le_base64(std::string_view text);

/// Every double as it is (bit for bit; infinities and NaN too).
std::string encode_f64le_base64(std::span<const double> values);
/// Throws std::invalid_argument if not base64 or not a whole number of 8-byte values.
std::vector<double> decode_f64le_base64(std::string_view text);

std::string encode_u32le_base64(std::span<const std::uint32_t> values);
std::vector<std::uint32_t> decode_u32le_base64(std::string_view text);

}  // namespace geoprox::protocol
