// Base64 and the little-endian float/u32 encodings: RFC 4648 vectors, bit-exact round trips of
// every length, strict decoding.
#include "protocol/base64.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace geoprox::protocol {
namespace {

std::vector<std::uint8_t> bytes_of(std::string_view text) { return {text.begin(), text.end()}; }

TEST(Base64, Rfc4648TestVectors) {
  const std::vector<std::pair<std::string, std::string>> vectors = {
      {"", ""},
      {"f", "Zg=="},
      {"fo", "Zm8="},
      {"foo", "Zm9v"},
      {"foob", "Zm9vYg=="},
      {"fooba", "Zm9vYmE="},
      {"foobar", "Zm9vYmFy"},
  };
  for (const auto& [plain, encoded] : vectors) {
    EXPECT_EQ(base64_encode(bytes_of(plain)), encoded) << plain;
    EXPECT_EQ(base64_decode(encoded), bytes_of(plain)) << encoded;
  }
  EXPECT_EQ(base64_encode(std::vector<std::uint8_t>{0xFB, 0xFF, 0xBF}), "+/+/");
}

TEST(Base64, EveryByteValueAndLengthRoundTrips) {
  std::vector<std::uint8_t> bytes;
  for (int length = 0; length < 300; ++length) {
    const std::string text = base64_encode(bytes);
    EXPECT_EQ(text.size(), (bytes.size() + 2) / 3 * 4);
    EXPECT_EQ(base64_decode(text), bytes) << "length " << length;
    bytes.push_back(static_cast<std::uint8_t>((length * 151 + 7) & 0xFF));
  }
}

TEST(Base64, FloatsAreLittleEndianIeee754) {
  // 1.0f is 0x3F800000: bytes 00 00 80 3F.
  EXPECT_EQ(encode_f32le_base64(std::vector<float>{1.0f}), "AACAPw==");
  EXPECT_EQ(base64_decode("AACAPw=="), (std::vector<std::uint8_t>{0x00, 0x00, 0x80, 0x3F}));
  // +inf is 0x7F800000, the "not reached" value of fields.
  EXPECT_EQ(base64_decode(
                encode_f32le_base64(std::vector<float>{std::numeric_limits<float>::infinity()})),
            (std::vector<std::uint8_t>{0x00, 0x00, 0x80, 0x7F}));
  EXPECT_EQ(encode_u32le_base64(std::vector<std::uint32_t>{0x01020304}), "BAMCAQ==");
}

TEST(Base64, FloatArraysRoundTripBitExactAtEveryLength) {
  // 4-byte values: lengths 1, 2, 3 floats leave 1, 2, 0 bytes in the last base64 group.
  std::mt19937 random(12345);
  std::vector<float> specials = {0.0f,
                                 -0.0f,
                                 1.0f,
                                 0.1f,
                                 -3.25e38f,
                                 std::numeric_limits<float>::denorm_min(),
                                 std::numeric_limits<float>::min(),
                                 std::numeric_limits<float>::max(),
                                 std::numeric_limits<float>::infinity(),
                                 -std::numeric_limits<float>::infinity(),
                                 std::bit_cast<float>(0x7FC00001u),  // NaN with a payload
                                 std::bit_cast<float>(0xFF800123u)};
  for (std::size_t length = 0; length < 40; ++length) {
    std::vector<float> values;
    for (std::size_t i = 0; i < length; ++i) {
      values.push_back(i < specials.size()
                           ? specials[(i + length) % specials.size()]
                           : std::bit_cast<float>(static_cast<std::uint32_t>(random())));
    }
    const std::string text = encode_f32le_base64(values);
    EXPECT_EQ(text.size(), (4 * length + 2) / 3 * 4);
    const std::vector<float> decoded = decode_f32le_base64(text);
    ASSERT_EQ(decoded.size(), length);
    for (std::size_t i = 0; i < length; ++i) {
      EXPECT_EQ(std::bit_cast<std::uint32_t>(decoded[i]), std::bit_cast<std::uint32_t>(values[i]))
          << "length " << length << " index " << i;
    }
  }
}

TEST(Base64, DoublesAreLittleEndianIeee754Binary64) {
  // 1.0 is 0x3FF0000000000000: bytes 00 00 00 00 00 00 F0 3F.
  EXPECT_EQ(encode_f64le_base64(std::vector<double>{1.0}), "AAAAAAAA8D8=");
  EXPECT_EQ(base64_decode(encode_f64le_base64(
                std::vector<double>{std::numeric_limits<double>::infinity()})),
            (std::vector<std::uint8_t>{0, 0, 0, 0, 0, 0, 0xF0, 0x7F}));
  EXPECT_EQ(decode_f64le_base64("AAAAAAAA8D8="), std::vector<double>{1.0});
}

TEST(Base64, DoubleArraysRoundTripBitExactAtEveryLength) {
  // 8-byte values: lengths 1, 2, 3 doubles leave 2, 1, 0 bytes in the last base64 group.
  std::mt19937_64 random(12345);
  const std::vector<double> specials = {0.0,
                                        -0.0,
                                        0.1,
                                        1.0 / 3.0,
                                        std::numeric_limits<double>::denorm_min(),
                                        std::numeric_limits<double>::max(),
                                        std::numeric_limits<double>::infinity(),
                                        -std::numeric_limits<double>::infinity(),
                                        std::bit_cast<double>(0x7FF8000000000123ull)};
  for (std::size_t length = 0; length < 40; ++length) {
    std::vector<double> values;
    for (std::size_t i = 0; i < length; ++i) {
      values.push_back(i < specials.size() ? specials[(i + length) % specials.size()]
                                           : std::bit_cast<double>(random()));
    }
    const std::string text = encode_f64le_base64(values);
    EXPECT_EQ(text.size(), (8 * length + 2) / 3 * 4);
    const std::vector<double> decoded = decode_f64le_base64(text);
    ASSERT_EQ(decoded.size(), length);
    for (std::size_t i = 0; i < length; ++i) {
      EXPECT_EQ(std::bit_cast<std::uint64_t>(decoded[i]), std::bit_cast<std::uint64_t>(values[i]))
          << "length " << length << " index " << i;
    }
  }
  try {
    decode_f64le_base64("AAAAAAAA");  // 6 bytes
    FAIL() << "6 bytes decoded as doubles";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("not a whole number of 8-byte values"),
              std::string::npos)
        << e.what();
  }
}

TEST(Base64, DoublesAreRoundedToTheNearestFloat) {
  const std::vector<double> values = {0.1, 1.0 / 3.0, std::numeric_limits<double>::infinity(),
                                      1e-50, 2.5};
  const std::vector<float> decoded = decode_f32le_base64(encode_f32le_base64(values));
  ASSERT_EQ(decoded.size(), values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    EXPECT_EQ(std::bit_cast<std::uint32_t>(decoded[i]),
              std::bit_cast<std::uint32_t>(static_cast<float>(values[i])));
  }
  EXPECT_TRUE(std::isinf(decoded[2]));
  EXPECT_EQ(decoded[3], 0.0f);
}

TEST(Base64, U32ArraysRoundTrip) {
  for (std::size_t length = 0; length < 10; ++length) {
    std::vector<std::uint32_t> values;
    for (std::size_t i = 0; i < length; ++i) {
      values.push_back(static_cast<std::uint32_t>(0xFFFFFFFFu - 977 * i * i));
    }
    EXPECT_EQ(decode_u32le_base64(encode_u32le_base64(values)), values);
  }
}

TEST(Base64, StrictDecoding) {
  const auto refused = [](std::string_view text, std::string_view fragment) {
    try {
      base64_decode(text);
      ADD_FAILURE() << "accepted '" << text << "'";
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find(fragment), std::string::npos)
          << "'" << text << "': " << error.what();
    }
  };
  refused("Zg=", "length 3 is not a multiple of 4");
  refused("Zg", "not a multiple of 4");
  refused("Zm9v\n", "not a multiple of 4");
  refused("Zm9 ", "character 32 at offset 3 is not in the alphabet");
  refused("Zm-v", "character 45 at offset 2");
  refused("Zm_v", "character 95");
  refused("Zg==Zm9v", "character 61 at offset 2");  // padding only at the very end
  refused("=m9v", "character 61 at offset 0");
  refused("Z===", "character 61 at offset 1");
  refused("Zh==", "non-zero bits under the padding");
  refused("Zm9=", "non-zero bits under the padding");
}

TEST(Base64, ArrayDecodersNeedWholeValues) {
  EXPECT_EQ(decode_u32le_base64("AAAAAA==").size(), 1u);  // 4 bytes
  try {
    decode_f32le_base64("AAAA");  // 3 bytes
    FAIL() << "accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_STREQ(error.what(), "decoded 3 bytes, not a whole number of 4-byte values");
  }
  EXPECT_THROW(decode_u32le_base64("AAAAAAA="), std::invalid_argument);  // 5 bytes
  EXPECT_THROW(decode_f32le_base64("AAAA!AAA"), std::invalid_argument);
}

}  // namespace
}  // namespace geoprox::protocol
