#include "protocol/base64.h"

#include <array>
#include <bit>
#include <cstring>
#include <stdexcept>
#include <type_traits>

namespace geoprox::protocol {

namespace {

constexpr std::string_view kAlphabet =
    "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

constexpr std::array<std::int8_t, 256> make_decode_table() {
  std::array<std::int8_t, 256> table{};
  table.fill(-1);
  for (std::size_t i = 0; i < kAlphabet.size(); ++i) {
    table[static_cast<unsigned char>(kAlphabet[i])] = static_cast<std::int8_t>(i);
  }
  return table;
}
constexpr std::array<std::int8_t, 256> kDecodeTable = make_decode_table();

[[noreturn]] void bad_base64(const std::string& why) {
  throw std::invalid_argument("invalid base64: " + why);
}

/// 4-byte words as bytes in little-endian order, whatever the host's.
template <typename Word>
std::vector<std::uint8_t> words_to_le_bytes(std::span<const Word> words) {
  static_assert(sizeof(Word) == 4 || sizeof(Word) == 8);
  using Bits = std::conditional_t<sizeof(Word) == 4, std::uint32_t, std::uint64_t>;
  std::vector<std::uint8_t> bytes(words.size() * sizeof(Word));
  if constexpr (std::endian::native == std::endian::little) {
    if (!words.empty()) std::memcpy(bytes.data(), words.data(), bytes.size());
  } else {
    for (std::size_t i = 0; i < words.size(); ++i) {
      const auto word = std::bit_cast<Bits>(words[i]);
      for (std::size_t k = 0; k < sizeof(Word); ++k) {
        bytes[sizeof(Word) * i + k] = static_cast<std::uint8_t>(word >> (8 * k));
      }
    }
  }
  return bytes;
}

std::vector<std::uint32_t> le_bytes_to_words(const std::vector<std::uint8_t>& bytes) {
  if (bytes.size() % 4 != 0) {
    throw std::invalid_argument("decoded " + std::to_string(bytes.size()) +
                                " bytes, not a whole number of 4-byte values");
  }
  std::vector<std::uint32_t> words(bytes.size() / 4);
  for (std::size_t i = 0; i < words.size(); ++i) {
    std::uint32_t word = 0;
    for (std::size_t k = 0; k < 4; ++k) word |= std::uint32_t{bytes[4 * i + k]} << (8 * k);
    words[i] = word;
  }
  return words;
}

}  // namespace

std::string base64_encode(std::span<const std::uint8_t> bytes) {
  // Written through a pointer into a pre-sized string: fields of 100k values are encoded on
  // every request, and appending a character at a time costs several times more.
  std::string text((bytes.size() + 2) / 3 * 4, '=');
  char* out = text.data();
  const std::uint8_t* in = bytes.data();
  const std::uint8_t* const whole_groups_end = in + bytes.size() / 3 * 3;
  for (; in != whole_groups_end; in += 3) {
    const std::uint32_t group = (std::uint32_t{in[0]} << 16) | (std::uint32_t{in[1]} << 8) | in[2];
    out[0] = kAlphabet[(group >> 18) & 63];
    out[1] = kAlphabet[(group >> 12) & 63];
    out[2] = kAlphabet[(group >> 6) & 63];
    out[3] = kAlphabet[group & 63];
    out += 4;
  }
  const std::size_t rest = bytes.size() % 3;
  if (rest > 0) {
    std::uint32_t group = std::uint32_t{in[0]} << 16;
    if (rest == 2) group |= std::uint32_t{in[1]} << 8;
    out[0] = kAlphabet[(group >> 18) & 63];
    out[1] = kAlphabet[(group >> 12) & 63];
    if (rest == 2) out[2] = kAlphabet[(group >> 6) & 63];  // else '=' stays
  }
  return text;
}

std::vector<std::uint8_t> base64_decode(std::string_view text) {
  if (text.size() % 4 != 0) {
    bad_base64("length " + std::to_string(text.size()) + " is not a multiple of 4");
  }
  std::vector<std::uint8_t> bytes;
  bytes.reserve(text.size() / 4 * 3);
  for (std::size_t i = 0; i < text.size(); i += 4) {
    const bool last_group = i + 4 == text.size();
    std::size_t padding = 0;
    if (last_group && text[i + 3] == '=') padding = text[i + 2] == '=' ? 2 : 1;
    std::uint32_t group = 0;
    for (std::size_t k = 0; k < 4; ++k) {
      const std::size_t at = i + k;
      if (k >= 4 - padding) {
        group <<= 6;
        continue;
      }
      const std::int8_t sextet = kDecodeTable[static_cast<unsigned char>(text[at])];
      if (sextet < 0) {
        bad_base64("character " + std::to_string(static_cast<unsigned char>(text[at])) +
                   " at offset " + std::to_string(at) + " is not in the alphabet");
      }
      group = (group << 6) | static_cast<std::uint32_t>(sextet);
    }
    const std::size_t produced = 3 - padding;
    // Non-canonical encodings (set bits under the padding) would decode the same bytes from
    // different texts; refuse them so encode(decode(s)) == s.
    if ((padding == 1 && (group & 0xFF) != 0) || (padding == 2 && (group & 0xFFFF) != 0)) {
      bad_base64("non-zero bits under the padding at offset " + std::to_string(i));
    }
    bytes.push_back(static_cast<std::uint8_t>(group >> 16));
    if (produced > 1) bytes.push_back(static_cast<std::uint8_t>(group >> 8));
    if (produced > 2) bytes.push_back(static_cast<std::uint8_t>(group));
  }
  return bytes;
}

std::string encode_f32le_base64(std::span<const float> values) {
  return base64_encode(words_to_le_bytes(values));
}

std::string encode_f32le_base64(std::span<const double> values) {
  std::vector<float> narrowed(values.begin(), values.end());
  return encode_f32le_base64(std::span<const float>(narrowed));
}

std::vector<float> decode_f32le_base64(std::string_view text) {
  const std::vector<std::uint32_t> words = le_bytes_to_words(base64_decode(text));
  std::vector<float> values(words.size());
  for (std::size_t i = 0; i < words.size(); ++i) values[i] = std::bit_cast<float>(words[i]);
  return values;
}

std::string encode_f64le_base64(std::span<const double> values) {
  return base64_encode(words_to_le_bytes(values));
}

std::vector<double> decode_f64le_base64(std::string_view text) {
  const std::vector<std::uint8_t> bytes = base64_decode(text);
  if (bytes.size() % 8 != 0) {
    throw std::invalid_argument("decoded " + std::to_string(bytes.size()) +
                                " bytes, not a whole number of 8-byte values");
  }
  std::vector<double> values(bytes.size() / 8);
  for (std::size_t i = 0; i < values.size(); ++i) {
    std::uint64_t word = 0;
    for (std::size_t k = 0; k < 8; ++k) word |= std::uint64_t{bytes[8 * i + k]} << (8 * k);
    values[i] = std::bit_cast<double>(word);
  }
  return values;
}

std::string encode_u32le_base64(std::span<const std::uint32_t> values) {
  return base64_encode(words_to_le_bytes(values));
}

std::vector<std::uint32_t> decode_u32le_base64(std::string_view text) {
  return le_bytes_to_words(base64_decode(text));
}

}  // namespace geoprox::protocol
