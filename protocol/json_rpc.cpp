#include "protocol/json_rpc.h"

#include <array>
#include <map>
#include <utility>
#include <vector>

#include "protocol/json_access.h"

namespace geoprox::protocol {

using nlohmann::json;

struct RequestIdAccess {
  static RequestId from_text(std::string text) { return RequestId(std::move(text)); }
};

RequestId RequestId::string(std::string_view value) {
  return RequestId(dump_one_line(json(std::string(value))));
}

std::optional<RequestId> RequestId::from_json(const json& value) {
  if (value.is_null() || value.is_string() || value.is_number()) {
    return RequestId(dump_one_line(value));
  }
  return std::nullopt;
}

namespace {

/// Builds the document like nlohmann's own DOM parser, and in addition: stops at the nesting
/// limit before going deeper, refuses duplicate keys, and keeps the text of a request's "id"
/// that is a non-integer number (nlohmann would turn it into a double and print it differently):
/// the "id" of the top-level object, or of each object element of a top-level array.
class BoundedDomBuilder final : public json::json_sax_t {
 public:
  BoundedDomBuilder(json& root, std::size_t max_depth) : root_(root), max_depth_(max_depth) {}

  bool null() override { return store(nullptr); }
  bool boolean(bool value) override { return store(value); }
  bool number_integer(number_integer_t value) override { return store(value); }
  bool number_unsigned(number_unsigned_t value) override { return store(value); }
  bool number_float(number_float_t value, const string_t& text) override {
    if (at_top_level_id()) float_id_text_ = text;
    if (at_element_id()) element_float_id_texts_[open_containers_.front()->size() - 1] = text;
    return store(value);
  }
  bool string(string_t& value) override { return store(std::move(value)); }
  bool binary(binary_t& value) override { return store(std::move(value)); }

  bool start_object(std::size_t /*elements*/) override { return open(json::object()); }
  bool start_array(std::size_t /*elements*/) override { return open(json::array()); }
  bool end_object() override { return close(); }
  bool end_array() override { return close(); }

  bool key(string_t& name) override {
    json& object = *open_containers_.back();
    if (object.contains(name)) {
      duplicate_key_ = name;
      return false;
    }
    pending_key_ = std::move(name);
    return true;
  }

  bool parse_error(std::size_t position, const std::string& /*last_token*/,
                   const json::exception& error) override {
    parse_error_position_ = position;
    parse_error_message_ = error.what();
    return false;
  }

  bool too_deep() const { return too_deep_; }
  const std::optional<std::string>& duplicate_key() const { return duplicate_key_; }
  const std::optional<std::string>& parse_error_message() const { return parse_error_message_; }
  std::size_t parse_error_position() const { return parse_error_position_; }
  const std::optional<std::string>& float_id_text() const { return float_id_text_; }
  /// By index of the element of a top-level array.
  std::map<std::size_t, std::string>& element_float_id_texts() { return element_float_id_texts_; }

 private:
  bool at_top_level_id() const {
    return open_containers_.size() == 1 && open_containers_.front()->is_object() &&
           pending_key_ == "id";
  }
  bool at_element_id() const {
    return open_containers_.size() == 2 && open_containers_.front()->is_array() &&
           open_containers_.back()->is_object() && pending_key_ == "id";
  }

  template <typename Value>
  bool store(Value&& value) {
    add(std::forward<Value>(value));
    return true;
  }

  /// Puts `value` where the document is being built and returns where it went.
  template <typename Value>
  json* add(Value&& value) {
    if (open_containers_.empty()) {
      root_ = json(std::forward<Value>(value));
      return &root_;
    }
    json& parent = *open_containers_.back();
    if (parent.is_array()) {
      parent.emplace_back(std::forward<Value>(value));
      return &parent.back();
    }
    json& slot = parent[pending_key_];
    slot = json(std::forward<Value>(value));
    return &slot;
  }

  bool open(json empty_container) {
    if (open_containers_.size() >= max_depth_) {
      too_deep_ = true;
      return false;
    }
    json* container = add(std::move(empty_container));
    open_containers_.push_back(container);
    return true;
  }

  bool close() {
    open_containers_.pop_back();
    return true;
  }

  json& root_;
  std::size_t max_depth_;
  std::vector<json*> open_containers_;
  std::string pending_key_;
  bool too_deep_ = false;
  std::optional<std::string> duplicate_key_;
  std::optional<std::string> parse_error_message_;
  std::size_t parse_error_position_ = 0;
  std::optional<std::string> float_id_text_;
  std::map<std::size_t, std::string> element_float_id_texts_;
};

/// Byte offset of the first byte that is not part of well-formed UTF-8 (RFC 3629: no overlong
/// forms, no surrogates, nothing above U+10FFFF), or nullopt.
std::optional<std::size_t> first_invalid_utf8(std::string_view text) {
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(text[i]); };
  std::size_t i = 0;
  while (i < text.size()) {
    const unsigned char lead = byte(i);
    if (lead < 0x80) {
      ++i;
      continue;
    }
    std::size_t length = 0;
    unsigned char low = 0x80, high = 0xBF;  // allowed range of the second byte
    if (lead >= 0xC2 && lead <= 0xDF) {
      length = 2;
    } else if (lead >= 0xE0 && lead <= 0xEF) {
      length = 3;
      if (lead == 0xE0) low = 0xA0;   // overlong
      if (lead == 0xED) high = 0x9F;  // surrogates
    } else if (lead >= 0xF0 && lead <= 0xF4) {
      length = 4;
      if (lead == 0xF0) low = 0x90;   // overlong
      if (lead == 0xF4) high = 0x8F;  // above U+10FFFF
    } else {
      return i;
    }
    if (i + length > text.size()) return i;
    if (byte(i + 1) < low || byte(i + 1) > high) return i;
    for (std::size_t k = 2; k < length; ++k) {
      if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return i;
    }
    i += length;
  }
  return std::nullopt;
}

/// "parse error at line 1, column 7: syntax error while parsing value - invalid literal; ..."
/// without nlohmann's "[json.exception.parse_error.101] " tag and line/column (always line 1).
std::string strip_nlohmann_prefix(std::string message) {
  if (message.starts_with("[json.exception.")) {
    const std::size_t end = message.find("] ");
    if (end != std::string::npos) message.erase(0, end + 2);
  }
  if (message.starts_with("parse error at line")) {
    const std::size_t end = message.find(": ");
    if (end != std::string::npos) message.erase(0, end + 2);
  }
  return message;
}

struct ParsedDocument {
  json root;
  std::optional<std::string> float_id_text;
  std::map<std::size_t, std::string> element_float_id_texts;  ///< when `root` is an array
  std::optional<ProtocolError> error;
};

ParsedDocument parse_document(std::string_view line, std::size_t max_depth) {
  ParsedDocument document;
  BoundedDomBuilder builder(document.root, max_depth);
  const bool complete =
      json::sax_parse(line.begin(), line.end(), &builder, json::input_format_t::json,
                      /*strict=*/true, /*ignore_comments=*/false);
  document.float_id_text = builder.float_id_text();
  document.element_float_id_texts = std::move(builder.element_float_id_texts());
  if (complete) return document;

  if (builder.too_deep()) {
    document.error =
        ProtocolError(ErrorReason::TooLarge, "JSON nested deeper than the limit of " +
                                                 std::to_string(max_depth) + " levels");
  } else if (builder.duplicate_key()) {
    document.error = ProtocolError(
        ErrorReason::InvalidRequest,
        "duplicate key \"" + detail::excerpt(*builder.duplicate_key()) + "\" in an object");
  } else if (const auto bad_byte = first_invalid_utf8(line)) {
    document.error = ProtocolError(ErrorReason::ParseError, "line is not valid UTF-8 (byte " +
                                                                std::to_string(*bad_byte) + ")");
  } else {
    document.error = ProtocolError(
        ErrorReason::ParseError,
        "invalid JSON at byte " + std::to_string(builder.parse_error_position()) + ": " +
            strip_nlohmann_prefix(builder.parse_error_message().value_or("unknown error")));
  }
  return document;
}

/// The id of a (possibly partial) request object, if present and of a valid type;
/// `float_id_text` is the text of its id when that is a non-integer number.
std::optional<RequestId> read_id(const json& request,
                                 const std::optional<std::string>& float_id_text) {
  if (!request.is_object()) return std::nullopt;
  const auto member = request.find("id");
  if (member == request.end()) return std::nullopt;
  if (member->is_number_float() && float_id_text) {
    return RequestIdAccess::from_text(*float_id_text);
  }
  return RequestId::from_json(*member);
}

std::optional<RequestId> read_id(const ParsedDocument& document) {
  return read_id(document.root, document.float_id_text);
}

/// The id of element `index` of a top-level array.
std::optional<RequestId> read_element_id(const ParsedDocument& document, std::size_t index) {
  const auto text = document.element_float_id_texts.find(index);
  return read_id(document.root[index], text == document.element_float_id_texts.end()
                                           ? std::nullopt
                                           : std::optional<std::string>(text->second));
}

constexpr std::array<std::string_view, 4> kEnvelopeMembers = {"jsonrpc", "id", "method", "params"};

EnvelopeError invalid_request(RequestId id, const std::string& message) {
  return {std::move(id), ProtocolError(ErrorReason::InvalidRequest, message)};
}

/// Checks one request object (the whole message, or an element of a batch array) whose id,
/// read beforehand, is `id`; moves its params out of `root`.
std::variant<Envelope, EnvelopeError> check_envelope(json& root,
                                                     const std::optional<RequestId>& id) {
  if (!root.is_object()) {
    return invalid_request(
        {}, std::string("a request must be a JSON object, not ") + detail::type_of(root));
  }
  const bool has_id = root.contains("id");
  if (has_id && !id) {
    return invalid_request({}, std::string("member \"id\" must be a number, a string or null, "
                                           "not ") +
                                   detail::type_of(root["id"]));
  }
  const RequestId reply_id = id.value_or(RequestId());

  for (const auto& [name, value] : root.items()) {
    bool known = false;
    for (std::string_view member : kEnvelopeMembers) known = known || name == member;
    if (!known) {
      return invalid_request(reply_id, "unknown member \"" + detail::excerpt(name) +
                                           "\" (a request has jsonrpc, id, method, params)");
    }
  }
  const auto jsonrpc = root.find("jsonrpc");
  if (jsonrpc == root.end()) {
    return invalid_request(reply_id, "missing member \"jsonrpc\" (must be \"2.0\")");
  }
  if (*jsonrpc != "2.0") {
    return invalid_request(reply_id, "member \"jsonrpc\" must be \"2.0\", not " +
                                         detail::excerpt(dump_one_line(*jsonrpc)));
  }
  const auto method = root.find("method");
  if (method == root.end()) return invalid_request(reply_id, "missing member \"method\"");
  if (!method->is_string()) {
    return invalid_request(reply_id, std::string("member \"method\" must be a string, not ") +
                                         detail::type_of(*method));
  }
  if (method->get_ref<const std::string&>().empty()) {
    return invalid_request(reply_id, "member \"method\" must not be empty");
  }
  Envelope envelope;
  envelope.id = id;
  envelope.method = method->get<std::string>();
  if (const auto params = root.find("params"); params != root.end()) {
    if (!params->is_object()) {
      return invalid_request(reply_id, std::string("member \"params\" must be an object (named "
                                                   "parameters), not ") +
                                           detail::type_of(*params));
    }
    envelope.params = std::move(*params);
  }
  return envelope;
}

}  // namespace

std::variant<Envelope, EnvelopeError> parse_envelope(std::string_view line,
                                                     std::size_t max_nesting_depth) {
  ParsedDocument document = parse_document(line, max_nesting_depth);
  const std::optional<RequestId> id = read_id(document);
  if (document.error) return EnvelopeError{id.value_or(RequestId()), *document.error};
  if (document.root.is_array()) {
    return invalid_request({}, "expected one request object, not a batch array");
  }
  return check_envelope(document.root, id);
}

std::variant<Envelope, EnvelopeError, EnvelopeBatch> parse_message(
    std::string_view text, std::size_t max_nesting_depth) {
  ParsedDocument document = parse_document(text, max_nesting_depth);
  const std::optional<RequestId> id = read_id(document);
  if (document.error) return EnvelopeError{id.value_or(RequestId()), *document.error};
  json& root = document.root;
  if (!root.is_array()) {
    std::variant<Envelope, EnvelopeError> single = check_envelope(root, id);
    if (auto* envelope = std::get_if<Envelope>(&single)) return std::move(*envelope);
    return std::get<EnvelopeError>(std::move(single));
  }
  if (root.empty()) {
    return invalid_request({}, "empty batch array: a batch array needs at least one request");
  }
  EnvelopeBatch batch;
  batch.elements.reserve(root.size());
  for (std::size_t i = 0; i < root.size(); ++i) {
    batch.elements.push_back(check_envelope(root[i], read_element_id(document, i)));
  }
  return batch;
}

json parse_json_text(std::string_view text, std::size_t max_nesting_depth) {
  ParsedDocument document = parse_document(text, max_nesting_depth);
  if (document.error) throw *document.error;
  return std::move(document.root);
}

json error_to_json(const ProtocolError& error) {
  json data = {{"reason", error.reason_name()}, {"retryable", error.retryable()}};
  if (error.retry_after_ms()) data["retry_after_ms"] = *error.retry_after_ms();
  return {{"code", error.code()}, {"message", error.what()}, {"data", std::move(data)}};
}

std::string dump_one_line(const json& value) {
  return value.dump(-1, ' ', /*ensure_ascii=*/false, json::error_handler_t::replace);
}

namespace {

std::string reply_line(const RequestId& id, std::string_view member, const json& payload) {
  std::string line = R"({"jsonrpc":"2.0","id":)";
  line += id.json_text();
  line += ",\"";
  line += member;
  line += "\":";
  line += dump_one_line(payload);
  line += "}\n";
  return line;
}

}  // namespace

std::string serialize_result(const RequestId& id, const json& result) {
  return reply_line(id, "result", result);
}

std::string serialize_error(const RequestId& id, const ProtocolError& error) {
  return reply_line(id, "error", error_to_json(error));
}

std::string serialize_request(const std::optional<RequestId>& id, std::string_view method,
                              const json& params) {
  std::string line = R"({"jsonrpc":"2.0",)";
  if (id) line += "\"id\":" + id->json_text() + ",";
  line += "\"method\":" + dump_one_line(json(std::string(method)));
  line += ",\"params\":" + dump_one_line(params) + "}\n";
  return line;
}

Reply parse_reply(std::string_view line, std::size_t max_nesting_depth) {
  ParsedDocument document = parse_document(line, max_nesting_depth);
  if (document.error) throw *document.error;
  const json& root = document.root;
  const auto bad_reply = [](const std::string& why) {
    return ProtocolError(ErrorReason::InvalidRequest, "not a JSON-RPC 2.0 reply: " + why);
  };
  if (!root.is_object()) throw bad_reply("not an object");
  if (root.value("jsonrpc", json()) != "2.0") throw bad_reply("\"jsonrpc\" is not \"2.0\"");
  if (!root.contains("id")) throw bad_reply("no \"id\"");
  std::optional<RequestId> id = read_id(document);
  if (!id) throw bad_reply("\"id\" is not a number, a string or null");

  Reply reply;
  reply.id = *id;
  const bool has_result = root.contains("result");
  const bool has_error = root.contains("error");
  if (has_result == has_error) throw bad_reply("needs exactly one of \"result\" and \"error\"");
  if (has_result) {
    reply.result = root["result"];
    return reply;
  }
  const json& error = root["error"];
  if (!error.is_object() || !error.contains("code") || !error["code"].is_number_integer() ||
      !error.contains("message") || !error["message"].is_string()) {
    throw bad_reply("\"error\" needs an integer \"code\" and a string \"message\"");
  }
  ReplyError parsed;
  parsed.code = error["code"].get<int>();
  parsed.message = error["message"].get<std::string>();
  if (const auto data = error.find("data"); data != error.end() && data->is_object()) {
    if (const auto reason = data->find("reason"); reason != data->end() && reason->is_string()) {
      parsed.reason = reason->get<std::string>();
    }
    if (const auto retryable = data->find("retryable");
        retryable != data->end() && retryable->is_boolean()) {
      parsed.retryable = retryable->get<bool>();
    }
    if (const auto after = data->find("retry_after_ms");
        after != data->end() && after->is_number_integer()) {
      parsed.retry_after_ms = after->get<std::int64_t>();
    }
  }
  reply.error = std::move(parsed);
  return reply;
}

}  // namespace geoprox::protocol
