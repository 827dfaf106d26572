#include "protocol/json_access.h"

#include <cmath>

namespace geoprox::protocol::detail {

using nlohmann::json;

std::string excerpt(std::string_view text, std::size_t max_bytes) {
  std::size_t cut = text.size();
  if (cut > max_bytes) {
    cut = max_bytes;
    // Back off UTF-8 continuation bytes (10xxxxxx) so the cut never splits a character.
    while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;
  }
  // Control bytes are written as \xNN: a NUL would end what() early, and a newline would break
  // a log line.
  std::string out;
  out.reserve(cut + 3);
  for (char c : text.substr(0, cut)) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x20 || byte == 0x7F) {
      constexpr char kHex[] = "0123456789abcdef";
      out += "\\x";
      out += kHex[byte >> 4];
      out += kHex[byte & 15];
    } else {
      out += c;
    }
  }
  if (cut < text.size()) out += "...";
  return out;
}

std::string json_excerpt(const json& value) {
  return excerpt(value.dump(-1, ' ', false, json::error_handler_t::replace));
}

const char* type_of(const json& value) {
  switch (value.type()) {
    case json::value_t::object:
      return "an object";
    case json::value_t::array:
      return "an array";
    case json::value_t::string:
      return "a string";
    case json::value_t::boolean:
      return "a boolean";
    case json::value_t::null:
      return "null";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float:
      return "a number";
    case json::value_t::binary:
    case json::value_t::discarded:
      break;
  }
  return "an unsupported value";
}

std::optional<std::uint64_t> as_unsigned(const json& value) {
  if (value.is_number_unsigned()) return value.get<std::uint64_t>();
  if (value.is_number_integer() && value.get<std::int64_t>() >= 0) {
    return static_cast<std::uint64_t>(value.get<std::int64_t>());
  }
  return std::nullopt;
}

ObjectFields::ObjectFields(const json& object, std::string path,
                           std::initializer_list<std::string_view> allowed, ErrorReason reason)
    : object_(object), path_(std::move(path)), reason_(reason) {
  if (!object_.is_object()) {
    throw ProtocolError(reason_, path_ + " must be an object, not " + type_of(object_));
  }
  for (const auto& [name, value] : object_.items()) {
    bool known = false;
    for (std::string_view member : allowed) known = known || name == member;
    if (known) continue;
    std::string expected;
    for (std::string_view member : allowed) {
      expected += expected.empty() ? "" : ", ";
      expected += member;
    }
    throw ProtocolError(
        reason_, path_ + ": unknown member \"" + excerpt(name) + "\"" +
                     (expected.empty() ? " (takes no members)" : " (expected " + expected + ")"));
  }
}

std::string ObjectFields::path_of(std::string_view member) const {
  return path_ + "." + std::string(member);
}

const json* ObjectFields::find(std::string_view member) const {
  const auto it = object_.find(member);
  return it == object_.end() ? nullptr : &*it;
}

const json& ObjectFields::require(std::string_view member) const {
  const json* value = find(member);
  if (value == nullptr) {
    throw ProtocolError(reason_, path_of(member) + " is missing");
  }
  return *value;
}

void ObjectFields::fail(std::string_view member, const std::string& why) const {
  throw ProtocolError(reason_, path_of(member) + " " + why);
}

std::string ObjectFields::require_string(std::string_view member) const {
  const json& value = require(member);
  if (!value.is_string()) fail(member, std::string("must be a string, not ") + type_of(value));
  return value.get<std::string>();
}

std::optional<std::string> ObjectFields::optional_string(std::string_view member) const {
  if (!has(member)) return std::nullopt;
  return require_string(member);
}

bool ObjectFields::optional_bool(std::string_view member, bool default_value) const {
  const json* value = find(member);
  if (value == nullptr) return default_value;
  if (!value->is_boolean()) {
    fail(member, std::string("must be true or false, not ") + type_of(*value));
  }
  return value->get<bool>();
}

std::optional<std::uint64_t> ObjectFields::optional_positive_integer(std::string_view member,
                                                                     std::uint64_t max) const {
  const json* value = find(member);
  if (value == nullptr) return std::nullopt;
  const std::optional<std::uint64_t> number = as_unsigned(*value);
  if (!number || *number == 0 || *number > max) {
    fail(member,
         "must be an integer from 1 to " + std::to_string(max) + ", not " + json_excerpt(*value));
  }
  return number;
}

std::optional<double> ObjectFields::optional_positive_number(std::string_view member) const {
  const json* value = find(member);
  if (value == nullptr) return std::nullopt;
  if (!value->is_number() || !std::isfinite(value->get<double>()) || value->get<double>() <= 0) {
    fail(member, "must be a finite number > 0, not " + json_excerpt(*value));
  }
  return value->get<double>();
}

}  // namespace geoprox::protocol::detail
