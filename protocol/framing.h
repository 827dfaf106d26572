// Newline-delimited framing of a byte stream (no sockets: the server feeds what it reads).
//
// Each message is one line terminated by "\n"; a "\r" right before the "\n" is dropped too, so
// clients that write "\r\n" (telnet, some libraries) work. Lines that are empty or only spaces and
// tabs are skipped: a client may send blank lines as keep-alives. The line limit counts the bytes
// of the line without its terminator. A line longer than the limit yields one TooLarge frame as
// soon as the limit is passed (the rest of it is never buffered) and the framer discards bytes up
// to the next "\n", so the connection continues with the next line. UTF-8 is not checked here:
// an invalid line reaches the parser, which answers ParseError.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <string_view>

#include "protocol/errors.h"
#include "protocol/limits.h"

namespace geoprox::protocol {

struct Frame {
  enum class Kind : std::uint8_t {
    Line,      ///< a complete line in `line`, without its terminator
    TooLarge,  ///< a line passed the limit; answer line_too_large_error() with id null
  };
  Kind kind = Kind::Line;
  std::string line;
};

class LineFramer {
 public:
  explicit LineFramer(std::size_t max_line_bytes = kDefaultMaxLineBytes)
      : max_line_bytes_(max_line_bytes) {}

  /// Consumes a chunk of any size, split anywhere (even inside "\r\n" or a UTF-8 sequence).
  void feed(std::string_view bytes);
  /// The stream ended: a last line without "\n" becomes a frame (a client may half-close right
  /// after its last request); a partial over-long line was already reported.
  void finish();
  /// The next complete frame, in stream order, or nothing until more bytes are fed.
  std::optional<Frame> next();

  std::size_t pending_frames() const { return frames_.size(); }
  /// Bytes of an unterminated line held back (at most max_line_bytes() + 1).
  std::size_t partial_bytes() const { return partial_.size(); }
  std::size_t max_line_bytes() const { return max_line_bytes_; }

 private:
  void complete_line(std::string_view tail);
  void report_too_large();

  std::size_t max_line_bytes_;
  std::string partial_;      // the current line's bytes so far
  bool discarding_ = false;  // inside an over-long line already reported
  std::deque<Frame> frames_;
};

/// The error to answer a Frame::Kind::TooLarge with (reason TooLarge, id null).
ProtocolError line_too_large_error(std::size_t max_line_bytes);

}  // namespace geoprox::protocol
