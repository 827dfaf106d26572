// Internal to protocol/: reading members of JSON objects with errors that name the field.
//
// Every refusal names the full path of the offending value as the client wrote it
// ("params.sources[2].bary"), so a message alone tells the client what to fix.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "protocol/errors.h"

namespace geoprox::protocol::detail {

/// At most `max_bytes` of `text`, cut on a UTF-8 boundary, with "..." when cut, control bytes
/// written as \xNN: keeps messages short and on one line when a client sends a megabyte (or a
/// NUL) where a word was expected.
std::string excerpt(std::string_view text, std::size_t max_bytes = 64);
/// excerpt() of the compact JSON text of `value`.
std::string json_excerpt(const nlohmann::json& value);
/// "an object", "an array", "a string", "a number", "a boolean", "null".
const char* type_of(const nlohmann::json& value);

/// Non-negative integer value (not 3.0: ids and counts must be written as integers).
std::optional<std::uint64_t> as_unsigned(const nlohmann::json& value);

/// The members of one JSON object, read by name. Construction refuses a non-object and any
/// member not in `allowed` (a misspelt optional parameter must not be silently ignored).
class ObjectFields {
 public:
  ObjectFields(const nlohmann::json& object, std::string path,
               std::initializer_list<std::string_view> allowed,
               ErrorReason reason = ErrorReason::InvalidParams);

  const std::string& path() const { return path_; }
  /// "params.mesh" for member "mesh" of "params".
  std::string path_of(std::string_view member) const;
  const nlohmann::json* find(std::string_view member) const;
  const nlohmann::json& require(std::string_view member) const;
  bool has(std::string_view member) const { return find(member) != nullptr; }

  std::string require_string(std::string_view member) const;
  std::optional<std::string> optional_string(std::string_view member) const;
  bool optional_bool(std::string_view member, bool default_value) const;
  /// An integer in [1, max].
  std::optional<std::uint64_t> optional_positive_integer(std::string_view member,
                                                         std::uint64_t max) const;
  /// A finite number > 0.
  std::optional<double> optional_positive_number(std::string_view member) const;

  [[noreturn]] void fail(std::string_view member, const std::string& why) const;

 private:
  const nlohmann::json& object_;
  std::string path_;
  ErrorReason reason_;
};

}  // namespace geoprox::protocol::detail
