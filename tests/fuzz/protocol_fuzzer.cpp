// libFuzzer target: the protocol reader as the server runs it on bytes from a socket (framing
// in protocol/framing.h, then decode_message and decode_request in protocol/request.h: JSON-RPC
// envelope or batch array, method, params validation), and the replies that follow.
//
// Input: two control bytes, then the byte stream of a connection.
//  - byte 0: bit 7 set: the server's default Limits; else small limits (line of 64 bytes and
//    more by the low bits, 4 points, 4 matrix pairs, 2 field sources, 3 batch entries, depth 8),
//    so that every TooLarge path is reachable with short inputs;
//  - byte 1: size of the chunks the stream is fed in (1 to 64 bytes: reads split anywhere).
// scripts/fuzz prefixes the seeds (the request lines of docs/protocol.md) with both bytes.
//
// Findings: any crash, sanitizer report or hang, any exception out of decode_request or
// decode_message (they return their errors), and broken promises:
//  - the framer yields the same frames whatever the chunking, lines within the limit, without
//    "\n", never blank, and holds at most limit + 1 bytes back;
//  - every rejection's reply is one line that parse_reply reads back with its reason and id;
//  - every accepted call's params survive to_json -> parse_params -> to_json unchanged, and a
//    result reply with that id reads back as the same JSON;
//  - decode_message decodes a line that is no array as decode_request does, and a batch array
//    into 1 to max_batch_requests elements naming at most max_points_per_request points, each
//    keeping the promises above, whose replies make one array line.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "protocol/framing.h"
#include "protocol/json_rpc.h"
#include "protocol/limits.h"
#include "protocol/messages.h"
#include "protocol/request.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

using geoprox::protocol::Frame;
using geoprox::protocol::LineFramer;
using nlohmann::json;

std::vector<Frame> frames_of(std::string_view stream, std::size_t max_line_bytes,
                             std::size_t chunk) {
  LineFramer framer(max_line_bytes);
  std::vector<Frame> frames;
  for (std::size_t at = 0; at < stream.size(); at += chunk) {
    framer.feed(stream.substr(at, chunk));
    GEOPROX_FUZZ_CHECK(framer.partial_bytes() <= max_line_bytes + 1, "bounded partial line");
    while (std::optional<Frame> frame = framer.next()) frames.push_back(std::move(*frame));
  }
  framer.finish();
  while (std::optional<Frame> frame = framer.next()) frames.push_back(std::move(*frame));
  return frames;
}

bool same_frames(const std::vector<Frame>& a, const std::vector<Frame>& b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](const Frame& x, const Frame& y) {
    return x.kind == y.kind && x.line == y.line;
  });
}

bool has_failed_entry(const geoprox::protocol::Params& params) {
  const auto* batch = std::get_if<geoprox::protocol::BatchParams>(&params);
  return batch != nullptr &&
         std::any_of(batch->requests.begin(), batch->requests.end(),
                     [](const geoprox::protocol::BatchEntry& entry) { return !entry.params; });
}

void check_rejection(const geoprox::protocol::Rejection& rejection) {
  const std::optional<std::string> line = rejection.reply_line();
  GEOPROX_FUZZ_CHECK(line.has_value() == rejection.id.has_value(), "notifications get no reply");
  if (!line) return;
  GEOPROX_FUZZ_CHECK(!line->empty() && line->back() == '\n' &&
                         line->find('\n') == line->size() - 1,
                     "a reply is one line");
  const geoprox::protocol::Reply reply =
      geoprox::protocol::parse_reply(std::string_view(*line).substr(0, line->size() - 1));
  GEOPROX_FUZZ_CHECK(reply.error.has_value() && !reply.result, "an error reply");
  GEOPROX_FUZZ_CHECK(reply.id == *rejection.id, "the id is echoed: " + *line);
  GEOPROX_FUZZ_CHECK(reply.error->reason == rejection.error.reason_name(), "reason: " + *line);
  GEOPROX_FUZZ_CHECK(reply.error->code == rejection.error.code(), "code: " + *line);
}

void check_call(const geoprox::protocol::Call& call, const geoprox::protocol::Limits& limits) {
  const json sent = call.params;
  geoprox::protocol::Params reparsed;
  try {
    reparsed = geoprox::protocol::parse_params(call.method(), sent, limits);
  } catch (const geoprox::protocol::ProtocolError& e) {
    GEOPROX_FUZZ_CHECK(false, "to_json(params) does not parse back: " + std::string(e.what()) +
                                  " in " + sent.dump());
  }
  // A batch entry that failed is written back without its params: not comparable.
  if (!has_failed_entry(call.params)) {
    const json again = reparsed;
    GEOPROX_FUZZ_CHECK(again == sent, sent.dump() + " came back as " + again.dump());
  }
  if (call.is_notification()) return;
  const std::string line = geoprox::protocol::serialize_result(*call.id, sent);
  const geoprox::protocol::Reply reply =
      geoprox::protocol::parse_reply(std::string_view(line).substr(0, line.size() - 1));
  GEOPROX_FUZZ_CHECK(reply.id == *call.id && reply.result && *reply.result == sent,
                     "result reply round trip: " + line);
}

/// JSON's whitespace before the first value of a line.
bool starts_an_array(std::string_view line) {
  const std::size_t first = line.find_first_not_of(" \t\r\n");
  return first != std::string_view::npos && line[first] == '[';
}

void check_same_decoding(const std::variant<geoprox::protocol::Call, geoprox::protocol::Rejection>&
                             single,
                         const std::variant<geoprox::protocol::Call, geoprox::protocol::Rejection,
                                            geoprox::protocol::BatchCall>& message) {
  using geoprox::protocol::Call;
  using geoprox::protocol::Rejection;
  if (const auto* rejection = std::get_if<Rejection>(&single)) {
    const auto* same = std::get_if<Rejection>(&message);
    GEOPROX_FUZZ_CHECK(same != nullptr && same->reply_line() == rejection->reply_line(),
                       "decode_message refuses a single request as decode_request does");
    return;
  }
  const Call& call = std::get<Call>(single);
  const auto* same = std::get_if<Call>(&message);
  GEOPROX_FUZZ_CHECK(same != nullptr && same->id == call.id &&
                         same->method_name == call.method_name &&
                         same->timeout_ms == call.timeout_ms,
                     "decode_message accepts a single request as decode_request does");
  GEOPROX_FUZZ_CHECK(json(same->params) == json(call.params), "the same params");
}

void check_batch(const geoprox::protocol::BatchCall& batch,
                 const geoprox::protocol::Limits& limits) {
  GEOPROX_FUZZ_CHECK(!batch.elements.empty() && batch.elements.size() <= limits.max_batch_requests,
                     "1 to max_batch_requests elements");
  std::size_t points = 0;
  std::vector<std::string> replies;
  std::vector<std::string> ids;
  for (const auto& element : batch.elements) {
    if (const auto* rejection = std::get_if<geoprox::protocol::Rejection>(&element)) {
      check_rejection(*rejection);
      if (auto line = rejection->reply_line()) {
        replies.push_back(std::move(*line));
        ids.push_back(rejection->id->json_text());
      }
      continue;
    }
    const auto& call = std::get<geoprox::protocol::Call>(element);
    check_call(call, limits);
    points += geoprox::protocol::point_count(call.params);
    if (!call.is_notification()) {
      replies.push_back(geoprox::protocol::serialize_result(*call.id, json::object()));
      ids.push_back(call.id->json_text());
    }
  }
  GEOPROX_FUZZ_CHECK(points <= limits.max_points_per_request, "the points of all elements");
  const std::string line = geoprox::protocol::serialize_batch_reply(replies);
  if (replies.empty()) {
    GEOPROX_FUZZ_CHECK(line.empty(), "nothing owed, nothing sent");
    return;
  }
  GEOPROX_FUZZ_CHECK(line.back() == '\n' && line.find('\n') == line.size() - 1,
                     "the reply to an array is one line");
  const json array = json::parse(line.substr(0, line.size() - 1));
  GEOPROX_FUZZ_CHECK(array.is_array() && array.size() == replies.size(), "one reply per element");
  for (std::size_t i = 0; i < replies.size(); ++i) {
    const geoprox::protocol::Reply reply = geoprox::protocol::parse_reply(array[i].dump());
    GEOPROX_FUZZ_CHECK(reply.id.json_text() == ids[i] ||
                           json::parse(reply.id.json_text()) == json::parse(ids[i]),
                       "ids echoed in the array: " + line);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  geoprox::protocol::Limits limits;
  if ((data[0] & 0x80) == 0) {
    limits.max_line_bytes = 64 + 16 * (data[0] & 0x7f);
    limits.max_nesting_depth = 8;
    limits.max_points_per_request = 4;
    limits.max_matrix_pairs = 4;
    limits.max_field_sources = 2;
    limits.max_batch_requests = 3;
  }
  const std::size_t chunk = 1 + data[1] % 64;
  const std::string_view stream(reinterpret_cast<const char*>(data) + 2, size - 2);

  const std::vector<Frame> frames = frames_of(stream, limits.max_line_bytes, chunk);
  GEOPROX_FUZZ_CHECK(same_frames(frames, frames_of(stream, limits.max_line_bytes, stream.size() + 1)),
                     "frames do not depend on how the stream is split");
  for (const Frame& frame : frames) {
    if (frame.kind == Frame::Kind::TooLarge) continue;
    GEOPROX_FUZZ_CHECK(frame.line.size() <= limits.max_line_bytes, "line within the limit");
    GEOPROX_FUZZ_CHECK(frame.line.find('\n') == std::string::npos, "no newline in a line");
    GEOPROX_FUZZ_CHECK(frame.line.find_first_not_of(" \t") != std::string::npos, "not blank");
    auto decoded = geoprox::protocol::decode_request(frame.line, limits);
    if (const auto* rejection = std::get_if<geoprox::protocol::Rejection>(&decoded)) {
      check_rejection(*rejection);
    } else {
      check_call(std::get<geoprox::protocol::Call>(decoded), limits);
    }
    const auto message = geoprox::protocol::decode_message(frame.line, limits);
    if (const auto* batch = std::get_if<geoprox::protocol::BatchCall>(&message)) {
      GEOPROX_FUZZ_CHECK(starts_an_array(frame.line), "only arrays are batch arrays");
      check_batch(*batch, limits);
    } else if (const auto* rejection = std::get_if<geoprox::protocol::Rejection>(&message)) {
      check_rejection(*rejection);
    }
    if (!starts_an_array(frame.line)) check_same_decoding(decoded, message);
  }
  return 0;
}
