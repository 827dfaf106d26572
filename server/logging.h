// spdlog setup for geoproxd: one logger to standard error, plain lines or one JSON object per
// line ({"time", "level", "msg"}), level from the config or GEOPROX_LOG_LEVEL.
#pragma once

#include <string>

namespace geoprox::server {

/// Installs the default logger. `level` must be valid (see is_valid_log_level).
void configure_logging(const std::string& level, bool json);

/// JSON string escaping of `text` (quotes, backslashes, control characters; invalid UTF-8 bytes
/// become U+FFFD so every line stays valid JSON).
std::string json_escape(std::string_view text);

}  // namespace geoprox::server
