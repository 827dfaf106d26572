// LineFramer: lines out of arbitrary chunks, CRLF, blank lines, the line limit and recovery.
#include "protocol/framing.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace geoprox::protocol {
namespace {

/// A frame as text for comparisons: the line itself, or "<TooLarge>".
std::vector<std::string> drain(LineFramer& framer) {
  std::vector<std::string> out;
  while (auto frame = framer.next()) {
    out.push_back(frame->kind == Frame::Kind::TooLarge ? "<TooLarge>" : frame->line);
  }
  return out;
}

std::vector<std::string> frame_in_chunks(std::string_view stream,
                                         const std::vector<std::size_t>& cuts,
                                         std::size_t max_line_bytes) {
  LineFramer framer(max_line_bytes);
  std::size_t start = 0;
  for (std::size_t cut : cuts) {
    framer.feed(stream.substr(start, cut - start));
    start = cut;
  }
  framer.feed(stream.substr(start));
  framer.finish();
  return drain(framer);
}

TEST(LineFramer, SplitsLinesAndDropsTerminators) {
  LineFramer framer;
  framer.feed("{\"a\":1}\n{\"b\":2}\r\n{\"c\"");
  EXPECT_EQ(drain(framer), (std::vector<std::string>{"{\"a\":1}", "{\"b\":2}"}));
  EXPECT_EQ(framer.partial_bytes(), 4u);
  framer.feed(":3}\n");
  EXPECT_EQ(drain(framer), (std::vector<std::string>{"{\"c\":3}"}));
  EXPECT_EQ(framer.partial_bytes(), 0u);
}

TEST(LineFramer, SameFramesWhateverTheChunkBoundaries) {
  // Two CRLF lines, an LF line, a blank CRLF line and a multi-byte UTF-8 character: every single
  // cut position and every pair of cut positions gives the same frames.
  const std::string stream = "{\"id\":1}\r\n{\"m\":\"\xC3\xA9t\xC3\xA9\"}\n\r\n \t\n[2]\r\nlast";
  const std::vector<std::string> expected = {"{\"id\":1}", "{\"m\":\"\xC3\xA9t\xC3\xA9\"}", "[2]",
                                             "last"};
  EXPECT_EQ(frame_in_chunks(stream, {}, 64), expected);
  for (std::size_t cut = 0; cut <= stream.size(); ++cut) {
    EXPECT_EQ(frame_in_chunks(stream, {cut}, 64), expected) << "cut at " << cut;
    for (std::size_t second = cut; second <= stream.size(); ++second) {
      ASSERT_EQ(frame_in_chunks(stream, {cut, second}, 64), expected)
          << "cuts at " << cut << " and " << second;
    }
  }
  // One byte at a time.
  LineFramer framer(64);
  for (char byte : stream) framer.feed(std::string_view(&byte, 1));
  framer.finish();
  EXPECT_EQ(drain(framer), expected);
}

TEST(LineFramer, SkipsBlankLines) {
  LineFramer framer;
  framer.feed("\n\r\n   \n\t\r\n{}\n");
  EXPECT_EQ(drain(framer), (std::vector<std::string>{"{}"}));
}

TEST(LineFramer, KeepsCarriageReturnsInsideALine) {
  LineFramer framer;
  framer.feed("a\rb\r\r\n");
  EXPECT_EQ(drain(framer), (std::vector<std::string>{"a\rb\r"}));
}

TEST(LineFramer, LineOfExactlyTheLimitPassesWithLfOrCrlf) {
  const std::string line(10, 'x');
  for (const std::string terminator : {"\n", "\r\n"}) {
    const std::string stream = line + terminator + "y\n";
    for (std::size_t cut = 0; cut <= stream.size(); ++cut) {
      EXPECT_EQ(frame_in_chunks(stream, {cut}, 10), (std::vector<std::string>{line, "y"}))
          << "terminator size " << terminator.size() << ", cut at " << cut;
    }
  }
}

TEST(LineFramer, OverLongLineYieldsTooLargeOnceAndTheNextLineSurvives) {
  const std::string stream =
      "ok\n" + std::string(11, 'x') + "\r\n" + std::string(1000, 'z') + "\nafter\n";
  const std::vector<std::string> expected = {"ok", "<TooLarge>", "<TooLarge>", "after"};
  for (std::size_t cut = 0; cut <= stream.size(); ++cut) {
    EXPECT_EQ(frame_in_chunks(stream, {cut}, 10), expected) << "cut at " << cut;
  }
  LineFramer framer(10);
  for (char byte : stream) framer.feed(std::string_view(&byte, 1));
  EXPECT_EQ(drain(framer), expected);
}

TEST(LineFramer, CarriageReturnJustPastTheLimitIsAnOverLongLineUnlessLfFollows) {
  // 10 bytes + '\r' + 'x': 12 bytes of content, over the limit of 10.
  EXPECT_EQ(frame_in_chunks(std::string(10, 'a') + "\rx\nb\n", {11}, 10),
            (std::vector<std::string>{"<TooLarge>", "b"}));
  // 10 bytes + '\r' + '\r' + '\n': 11 bytes of content.
  EXPECT_EQ(frame_in_chunks(std::string(10, 'a') + "\r\r\nb\n", {11}, 10),
            (std::vector<std::string>{"<TooLarge>", "b"}));
}

TEST(LineFramer, TooLargeIsReportedBeforeTheLineEndsAndNothingIsBuffered) {
  LineFramer framer(16);
  framer.feed(std::string(100, 'x'));
  EXPECT_EQ(drain(framer), (std::vector<std::string>{"<TooLarge>"}));
  EXPECT_EQ(framer.partial_bytes(), 0u);
  framer.feed(std::string(100000, 'x'));
  EXPECT_TRUE(drain(framer).empty()) << "reported once per line";
  EXPECT_EQ(framer.partial_bytes(), 0u);
  framer.feed("x\n{}\n");
  EXPECT_EQ(drain(framer), (std::vector<std::string>{"{}"}));
}

TEST(LineFramer, FinishTurnsAnUnterminatedLineIntoAFrame) {
  LineFramer framer;
  framer.feed("{\"id\":1}\r");
  EXPECT_TRUE(drain(framer).empty());
  framer.finish();
  EXPECT_EQ(drain(framer), (std::vector<std::string>{"{\"id\":1}"}));
  framer.finish();
  EXPECT_TRUE(drain(framer).empty());

  LineFramer over(4);
  over.feed("abcdefgh");
  over.finish();
  EXPECT_EQ(drain(over), (std::vector<std::string>{"<TooLarge>"})) << "not reported twice";
}

TEST(LineFramer, DefaultLimitIsOneMebibyte) {
  LineFramer framer;
  EXPECT_EQ(framer.max_line_bytes(), 1048576u);
  framer.feed(std::string(1048576, 'a') + "\n" + std::string(1048577, 'b') + "\n");
  auto first = framer.next();
  ASSERT_TRUE(first);
  EXPECT_EQ(first->kind, Frame::Kind::Line);
  EXPECT_EQ(first->line.size(), 1048576u);
  auto second = framer.next();
  ASSERT_TRUE(second);
  EXPECT_EQ(second->kind, Frame::Kind::TooLarge);
  EXPECT_FALSE(framer.next());
}

TEST(LineFramer, TooLargeErrorNamesTheLimit) {
  const ProtocolError error = line_too_large_error(1048576);
  EXPECT_EQ(error.reason(), ErrorReason::TooLarge);
  EXPECT_EQ(error.code(), -32020);
  EXPECT_FALSE(error.retryable());
  EXPECT_NE(std::string(error.what()).find("1048576 bytes"), std::string::npos) << error.what();
}

}  // namespace
}  // namespace geoprox::protocol
