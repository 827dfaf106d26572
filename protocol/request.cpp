#include "protocol/request.h"

#include "protocol/json_access.h"

namespace geoprox::protocol {

std::optional<std::string> Rejection::reply_line() const {
  if (!id) return std::nullopt;
  return serialize_error(*id, error);
}

std::variant<Call, Rejection> decode_request(std::string_view line, const Limits& limits) {
  std::variant<Envelope, EnvelopeError> parsed = parse_envelope(line, limits.max_nesting_depth);
  if (auto* failure = std::get_if<EnvelopeError>(&parsed)) {
    // An unreadable envelope is answered even without an id: the sender cannot have meant a
    // notification it could not write (JSON-RPC 2.0, section 5).
    return Rejection{failure->id, {}, failure->error};
  }
  Envelope& envelope = std::get<Envelope>(parsed);
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

}  // namespace geoprox::protocol
