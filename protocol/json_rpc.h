// JSON-RPC 2.0 envelope: one message (a line) in, one reply line out.
//
// A message is a single request object `{"jsonrpc": "2.0", "id": ..., "method": "...",
// "params": {...}}` or a batch array of them (JSON-RPC 2.0, section 6).
// - `id` is a number, a string or null, and is echoed back: numbers byte for byte (the text as
//   sent, e.g. 1.50 or 123456789012345678901234; only -0 comes back as 0), strings as the same
//   JSON string. Without `id` the request is a notification: it is carried out, but never
//   answered, not even with an error, as JSON-RPC 2.0 requires.
// - `params` is an object (named parameters) or absent; positional (array) params are refused.
// - Unknown members and duplicate keys anywhere are refused (InvalidRequest): a typo must not be
//   silently ignored, and with duplicate keys two parsers could read different requests.
// - A batch array `[request, ...]` (parse_message) is answered by one line holding the array of
//   the replies of its elements that are owed one, nothing if all are notifications. Each element
//   is checked on its own: one that is not a request gets its own error (id null) in that array.
//   An empty array is one InvalidRequest (not an array). The array counts as a nesting level.
// When the line cannot be read, the error reply carries the id if it was read before the failure
// (so a pipelining client can still match it), else null.
//
// Replies are one line each, members in this order, ending in "\n":
//   {"jsonrpc":"2.0","id":ID,"result":{...}}
//   {"jsonrpc":"2.0","id":ID,"error":{"code":-32602,"message":"...","data":{"reason":"BadPoint","retryable":false}}}
#pragma once

#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "protocol/errors.h"
#include "protocol/limits.h"

namespace geoprox::protocol {

/// The id of a request as the JSON text to echo: null, a number or a string.
class RequestId {
 public:
  RequestId() = default;  ///< null
  static RequestId number(std::int64_t value) { return RequestId(std::to_string(value)); }
  static RequestId string(std::string_view value);
  /// A JSON number, string or null value; nullopt for any other type.
  static std::optional<RequestId> from_json(const nlohmann::json& value);

  /// The JSON text of the id, as written into replies ("null", "17", "\"a\"").
  const std::string& json_text() const { return text_; }
  bool is_null() const { return text_ == "null"; }
  nlohmann::json value() const { return nlohmann::json::parse(text_); }

  bool operator==(const RequestId&) const = default;

 private:
  explicit RequestId(std::string text) : text_(std::move(text)) {}
  friend struct RequestIdAccess;  // json_rpc.cpp: ids from the raw text of numbers
  std::string text_ = "null";
};

/// A well-formed request envelope; `params` is not interpreted yet (protocol/messages.h).
struct Envelope {
  std::optional<RequestId> id;  ///< nullopt: a notification, never answered
  std::string method;
  nlohmann::json params = nlohmann::json::object();  ///< always an object

  bool is_notification() const { return !id.has_value(); }
};

/// A line that is not a well-formed request: always answered (with `id`, null if unknown).
struct EnvelopeError {
  RequestId id;
  ProtocolError error;
};

/// Parses one line (without its "\n") that must be a single request object. ParseError for bad
/// JSON or UTF-8, TooLarge beyond `max_nesting_depth`, InvalidRequest for a JSON value that is
/// not a request (a batch array included: parse_message reads those).
std::variant<Envelope, EnvelopeError> parse_envelope(
    std::string_view line, std::size_t max_nesting_depth = kDefaultMaxNestingDepth);

/// The elements of a batch array, each a request envelope or the error answering it, in order.
struct EnvelopeBatch {
  std::vector<std::variant<Envelope, EnvelopeError>> elements;  ///< never empty
};

/// Parses one message, a request object or a batch array, once. A message that is not JSON, too
/// deep or an empty array is one EnvelopeError; in a non-empty array each element is checked as
/// parse_envelope() checks a request object.
std::variant<Envelope, EnvelopeError, EnvelopeBatch> parse_message(
    std::string_view text, std::size_t max_nesting_depth = kDefaultMaxNestingDepth);

/// Any JSON document (an HTTP request body), read with the same checks as a request line: throws
/// ProtocolError ParseError for bad JSON or UTF-8, InvalidRequest for a duplicate key, TooLarge
/// beyond `max_nesting_depth`.
nlohmann::json parse_json_text(std::string_view text,
                               std::size_t max_nesting_depth = kDefaultMaxNestingDepth);

/// `{"code": ..., "message": ..., "data": {"reason": ..., "retryable": ...[, "retry_after_ms"]}}`.
nlohmann::json error_to_json(const ProtocolError& error);

/// A complete reply line, "\n" included. Invalid UTF-8 in strings (never produced by the parser,
/// but possible in server-made messages) is replaced by U+FFFD rather than failing.
std::string serialize_result(const RequestId& id, const nlohmann::json& result);
std::string serialize_error(const RequestId& id, const ProtocolError& error);

/// Compact JSON text of `value` on one line, tolerant of invalid UTF-8 (see above).
std::string dump_one_line(const nlohmann::json& value);

// ---- Client side: what the C++ client and the tests use. ----

/// A request line, "\n" included; no id makes a notification. `params` must be an object.
std::string serialize_request(const std::optional<RequestId>& id, std::string_view method,
                              const nlohmann::json& params = nlohmann::json::object());

struct ReplyError {
  int code = 0;
  std::string message;
  std::string reason;  ///< data.reason ("" if the server sent none)
  bool retryable = false;
  std::optional<std::int64_t> retry_after_ms;
};

struct Reply {
  RequestId id;
  std::optional<nlohmann::json> result;  ///< exactly one of result and error is set
  std::optional<ReplyError> error;
};

/// Parses a reply line; throws ProtocolError (ParseError, InvalidRequest) if it is not one.
Reply parse_reply(std::string_view line, std::size_t max_nesting_depth = kDefaultMaxNestingDepth);

}  // namespace geoprox::protocol
