#include "protocol/request.h"

#include "protocol/json_access.h"

namespace geoprox::protocol {

namespace {

Rejection refused_envelope(EnvelopeError failure) {
  // An unreadable envelope is answered even without an id: the sender cannot have meant a
  // notification it could not write (JSON-RPC 2.0, section 5).
  return Rejection{std::move(failure.id), {}, std::move(failure.error)};
}

std::variant<Call, Rejection> decode_envelope(Envelope envelope, const Limits& limits) {
  const std::optional<Method> method = method_from_name(envelope.method);
  if (!method) {
    return Rejection{envelope.id, envelope.method,
                     ProtocolError(ErrorReason::UnknownMethod,
                                   "unknown method \"" + detail::excerpt(envelope.method) +
                                       "\" (server.info lists the methods)")};
  }
  try {
    std::optional<std::int64_t> timeout_ms;
    Params params = parse_params(*method, envelope.params, limits, &timeout_ms);
    return Call{envelope.id, std::move(envelope.method), std::move(params), timeout_ms};
  } catch (const ProtocolError& error) {
    return Rejection{envelope.id, std::move(envelope.method), error};
  }
}

std::variant<Call, Rejection> decode_element(std::variant<Envelope, EnvelopeError> element,
                                             const Limits& limits) {
  if (auto* failure = std::get_if<EnvelopeError>(&element)) {
    return refused_envelope(std::move(*failure));
  }
  return decode_envelope(std::get<Envelope>(std::move(element)), limits);
}

/// The refusal of a whole batch array: one error object, id null.
Rejection refused_batch(ErrorReason reason, const std::string& message) {
  return Rejection{RequestId(), {}, ProtocolError(reason, message)};
}

std::variant<Call, Rejection, BatchCall> decode_batch(EnvelopeBatch batch,
                                                      const Limits& limits) {
  // Checked before any params are parsed, like the `batch` method's entries.
  if (batch.elements.size() > limits.max_batch_requests) {
    return refused_batch(ErrorReason::TooLarge,
                         "batch array: " + std::to_string(batch.elements.size()) +
                             " requests exceed max_batch_requests = " +
                             std::to_string(limits.max_batch_requests));
  }
  BatchCall decoded;
  decoded.elements.reserve(batch.elements.size());
  std::size_t total_points = 0;
  for (auto& element : batch.elements) {
    decoded.elements.push_back(decode_element(std::move(element), limits));
    if (const auto* call = std::get_if<Call>(&decoded.elements.back())) {
      total_points += point_count(call->params);
    }
  }
  if (total_points > limits.max_points_per_request) {
    return refused_batch(ErrorReason::TooLarge,
                         "batch array: " + std::to_string(total_points) +
                             " points exceed the limit of " +
                             std::to_string(limits.max_points_per_request) +
                             " points per request (a batch array counts all its requests)");
  }
  return decoded;
}

}  // namespace

std::optional<std::string> Rejection::reply_line() const {
  if (!id) return std::nullopt;
  return serialize_error(*id, error);
}

std::variant<Call, Rejection> decode_request(std::string_view line, const Limits& limits) {
  return decode_element(parse_envelope(line, limits.max_nesting_depth), limits);
}

std::variant<Call, Rejection, BatchCall> decode_message(std::string_view text,
                                                        const Limits& limits) {
  std::variant<Envelope, EnvelopeError, EnvelopeBatch> parsed =
      parse_message(text, limits.max_nesting_depth);
  if (auto* batch = std::get_if<EnvelopeBatch>(&parsed)) {
    return decode_batch(std::move(*batch), limits);
  }
  if (auto* failure = std::get_if<EnvelopeError>(&parsed)) {
    return refused_envelope(std::move(*failure));
  }
  std::variant<Call, Rejection> single =
      decode_envelope(std::get<Envelope>(std::move(parsed)), limits);
  if (auto* call = std::get_if<Call>(&single)) return std::move(*call);
  return std::get<Rejection>(std::move(single));
}

std::string serialize_batch_reply(const std::vector<std::string>& replies) {
  if (replies.empty()) return {};
  std::size_t bytes = 2 + replies.size();
  for (const std::string& reply : replies) bytes += reply.size();
  std::string line;
  line.reserve(bytes);
  line += '[';
  for (std::size_t i = 0; i < replies.size(); ++i) {
    std::string_view reply = replies[i];
    if (reply.ends_with('\n')) reply.remove_suffix(1);
    if (i > 0) line += ',';
    line += reply;
  }
  line += "]\n";
  return line;
}

}  // namespace geoprox::protocol
