// From one message (a request line, or a batch array line) to typed calls, or to the error to
// answer: what the server calls for each line the LineFramer yields.
//
//   LineFramer framer(limits.max_line_bytes);
//   framer.feed(bytes);
//   while (auto frame = framer.next()) {
//     if (frame->kind == Frame::Kind::TooLarge) {
//       send(serialize_error(RequestId(), line_too_large_error(limits.max_line_bytes)));
//       continue;
//     }
//     auto decoded = decode_message(frame->line, limits);
//     if (auto* batch = std::get_if<BatchCall>(&decoded)) {
//       // Each element as below; the replies owed go out together as
//       // serialize_batch_reply(replies), nothing when none is owed.
//       continue;
//     }
//     if (auto* rejection = std::get_if<Rejection>(&decoded)) {
//       if (auto line = rejection->reply_line()) send(*line);  // nothing for notifications
//       continue;
//     }
//     Call& call = std::get<Call>(decoded);
//     // std::visit over call.params; unless call.is_notification(), answer with
//     // serialize_result(*call.id, json(result)) (serialize_field_result for fields) or
//     // serialize_error(*call.id, error).
//   }
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "protocol/errors.h"
#include "protocol/json_rpc.h"
#include "protocol/limits.h"
#include "protocol/messages.h"

namespace geoprox::protocol {

struct Call {
  std::optional<RequestId> id;  ///< nullopt: a notification; carry it out, send nothing
  std::string method_name;      ///< as sent
  Params params;
  std::optional<std::int64_t> timeout_ms;  ///< as asked; see Limits::effective_timeout_ms

  Method method() const { return method_of(params); }
  bool is_notification() const { return !id.has_value(); }
};

struct Rejection {
  std::optional<RequestId> id;  ///< nullopt: a refused notification, never answered
  std::string method_name;      ///< as sent, empty if the envelope was unreadable (for logs)
  ProtocolError error;

  /// The error reply line ("\n" included), or nothing for a notification.
  std::optional<std::string> reply_line() const;
};

/// Envelope, method and params of one line, checked against `limits` (nesting depth, points,
/// pairs, batch size). Errors are returned, never thrown.
/// A batch array decodes as a Rejection (InvalidRequest): decode_message() reads those.
std::variant<Call, Rejection> decode_request(std::string_view line, const Limits& limits = {});

/// A JSON-RPC 2.0 batch array, its elements decoded one by one, in order.
struct BatchCall {
  std::vector<std::variant<Call, Rejection>> elements;
};

/// One message (a line, or an HTTP body): a single request or a batch array, parsed once. A
/// single request decodes as decode_request() decodes it. A batch array is refused as a whole,
/// with one Rejection of id null, when it is empty (InvalidRequest), has more than
/// `max_batch_requests` elements or its calls name more than `max_points_per_request` points
/// together (TooLarge); otherwise each element is a Call or its own Rejection.
std::variant<Call, Rejection, BatchCall> decode_message(std::string_view text,
                                                        const Limits& limits = {});

/// "[r1,r2,...]\n" from reply lines (each may end in "\n"); "" when `replies` is empty.
std::string serialize_batch_reply(const std::vector<std::string>& replies);

}  // namespace geoprox::protocol
