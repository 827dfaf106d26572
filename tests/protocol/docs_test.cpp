// docs/protocol.md stays true: its examples go through the real parser and serializer (batch
// arrays element by element), and its tables list every reason, method and limit with the
// values of the code.
#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "protocol/errors.h"
#include "protocol/limits.h"
#include "protocol/messages.h"
#include "protocol/request.h"

namespace geoprox::protocol {
namespace {

using nlohmann::json;

std::string read_docs() {
  std::ifstream file(std::string(GEOPROX_SOURCE_DIR) + "/docs/protocol.md");
  EXPECT_TRUE(file) << "cannot open docs/protocol.md";
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

struct ExampleLine {
  bool request;  // "→ " (else "← ")
  std::string text;
  int line_number;
};

/// The "→ " and "← " lines inside fenced code blocks, in order.
std::vector<ExampleLine> example_lines(const std::string& docs) {
  std::vector<ExampleLine> lines;
  std::istringstream in(docs);
  std::string line;
  bool in_code = false;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::size_t start = line.find_first_not_of(' ');
    if (start == std::string::npos) continue;
    const std::string_view trimmed = std::string_view(line).substr(start);
    if (trimmed.starts_with("```")) {
      in_code = !in_code;
      continue;
    }
    if (!in_code) continue;
    if (trimmed.starts_with("→ ")) {
      lines.push_back({true, std::string(trimmed.substr(std::string_view("→ ").size())), number});
    } else if (trimmed.starts_with("← ")) {
      lines.push_back({false, std::string(trimmed.substr(std::string_view("← ").size())), number});
    }
  }
  return lines;
}

TEST(ProtocolDocs, EveryExampleGoesThroughTheRealCode) {
  const std::vector<ExampleLine> lines = example_lines(read_docs());
  ASSERT_GT(lines.size(), 40u);
  std::set<Method> methods_shown;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const ExampleLine& line = lines[i];
    SCOPED_TRACE("docs/protocol.md:" + std::to_string(line.line_number));
    if (!line.request) {
      // Every reply parses (each of an array, the reply to a batch array), and errors carry the
      // code and retryability of their reason.
      std::vector<std::string> reply_texts = {line.text};
      if (line.text.starts_with("[")) {
        reply_texts.clear();
        for (const json& element : json::parse(line.text)) reply_texts.push_back(element.dump());
      }
      for (const std::string& text : reply_texts) {
        const Reply reply = parse_reply(text);
        if (reply.error) {
          const std::optional<ErrorReason> reason = reason_from_name(reply.error->reason);
          ASSERT_TRUE(reason) << reply.error->reason;
          EXPECT_EQ(reply.error->code, error_code_of(*reason));
          EXPECT_EQ(reply.error->retryable, is_retryable(*reason));
        }
      }
      continue;
    }
    auto decoded = decode_message(line.text);
    const bool has_reply = i + 1 < lines.size() && !lines[i + 1].request;
    ASSERT_TRUE(has_reply) << "a request without its reply: " << line.text;
    const std::string& reply_text = lines[i + 1].text;
    if (const auto* rejection = std::get_if<Rejection>(&decoded)) {
      // A refused request: the reply shown is exactly the one produced.
      ASSERT_TRUE(rejection->reply_line());
      EXPECT_EQ(*rejection->reply_line(), reply_text + "\n");
      continue;
    }
    if (const auto* batch = std::get_if<BatchCall>(&decoded)) {
      // A batch array: one reply per element owed one, in order; refusals as produced.
      const json replies = json::parse(reply_text);
      ASSERT_TRUE(replies.is_array()) << reply_text;
      std::size_t next = 0;
      for (const auto& element : batch->elements) {
        if (const auto* refused = std::get_if<Rejection>(&element)) {
          if (!refused->reply_line()) continue;
          ASSERT_LT(next, replies.size());
          EXPECT_EQ(json::parse(*refused->reply_line()), replies[next++]);
          continue;
        }
        const Call& call = std::get<Call>(element);
        methods_shown.insert(call.method());
        if (call.is_notification()) continue;
        ASSERT_LT(next, replies.size());
        const Reply reply = parse_reply(replies[next++].dump());
        EXPECT_EQ(reply.id, *call.id);
        EXPECT_TRUE(reply.result) << "an accepted request is shown with its result";
      }
      EXPECT_EQ(next, replies.size()) << "a reply for every element owed one, no more";
      continue;
    }
    const Call& call = std::get<Call>(decoded);
    methods_shown.insert(call.method());
    ASSERT_TRUE(call.id) << "examples have ids";
    const Reply reply = parse_reply(reply_text);
    EXPECT_EQ(reply.id, *call.id);
    EXPECT_TRUE(reply.result) << "an accepted request is shown with its result";
  }
  for (Method method : all_methods()) {
    EXPECT_TRUE(methods_shown.contains(method)) << "no example of " << method_name(method);
  }
}

TEST(ProtocolDocs, EveryMethodHasASection) {
  const std::string docs = read_docs();
  for (Method method : all_methods()) {
    const std::string name(method_name(method));
    EXPECT_TRUE(docs.find("### `" + name + "`\n") != std::string::npos)
        << "no section for " << name;
  }
}

TEST(ProtocolDocs, ReasonTableMatchesTheCode) {
  const std::string docs = read_docs();
  for (const ErrorReasonInfo& info : error_reasons()) {
    const std::string row = "| `" + std::string(info.name) + "` | " + std::to_string(info.code) +
                            " | " + (info.retryable ? "yes" : "no") + " | ";
    EXPECT_NE(docs.find(row), std::string::npos) << "missing or wrong row: " << row;
  }
}

TEST(ProtocolDocs, LimitTableMatchesTheDefaults) {
  const std::string docs = read_docs();
  const json defaults = Limits{};
  for (const auto& [name, value] : defaults.items()) {
    const std::string row = "| `" + name + "` | " + value.dump();
    EXPECT_NE(docs.find(row), std::string::npos) << "missing or wrong row: " << row;
  }
}

}  // namespace
}  // namespace geoprox::protocol
