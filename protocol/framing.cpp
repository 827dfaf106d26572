#include "protocol/framing.h"

#include <utility>

namespace geoprox::protocol {

namespace {

bool is_blank(std::string_view line) {
  return line.find_first_not_of(" \t") == std::string_view::npos;
}

}  // namespace

void LineFramer::feed(std::string_view bytes) {
  while (!bytes.empty()) {
    const std::size_t newline = bytes.find('\n');
    const std::string_view piece = bytes.substr(0, newline);

    if (discarding_) {
      if (newline == std::string_view::npos) return;
      discarding_ = false;
    } else if (newline != std::string_view::npos) {
      complete_line(piece);
    } else {
      // Unterminated so far. One byte over the limit is allowed only if it is a '\r' that a
      // following '\n' would strip; the decision on it waits for the next byte.
      const std::size_t size = partial_.size() + piece.size();
      const bool may_end_in_cr = size == max_line_bytes_ + 1 && piece.back() == '\r';
      if (size > max_line_bytes_ && !may_end_in_cr) {
        report_too_large();
        discarding_ = true;
        return;
      }
      partial_.append(piece);
      return;
    }
    bytes.remove_prefix(newline + 1);
  }
}

void LineFramer::complete_line(std::string_view tail) {
  std::size_t size = partial_.size() + tail.size();
  const char last = !tail.empty() ? tail.back() : (!partial_.empty() ? partial_.back() : '\0');
  if (last == '\r') --size;
  if (size > max_line_bytes_) {
    report_too_large();
    return;
  }
  partial_.append(tail);
  partial_.resize(size);
  if (!is_blank(partial_)) frames_.push_back({Frame::Kind::Line, std::move(partial_)});
  partial_.clear();
}

void LineFramer::report_too_large() {
  partial_.clear();
  partial_.shrink_to_fit();  // an over-long line must not keep its memory for the connection
  frames_.push_back({Frame::Kind::TooLarge, {}});
}

void LineFramer::finish() {
  if (discarding_) {
    discarding_ = false;
    return;
  }
  if (!partial_.empty()) complete_line({});
}

std::optional<Frame> LineFramer::next() {
  if (frames_.empty()) return std::nullopt;
  Frame frame = std::move(frames_.front());
  frames_.pop_front();
  return frame;
}

ProtocolError line_too_large_error(std::size_t max_line_bytes) {
  return ProtocolError(ErrorReason::TooLarge, "line longer than the limit of " +
                                                  std::to_string(max_line_bytes) +
                                                  " bytes; it was skipped up to the next newline");
}

}  // namespace geoprox::protocol
