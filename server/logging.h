// spdlog setup for geoproxd: one logger to standard error, plain lines for terminals or one JSON
// object per line ({"time", "level", "thread", "msg"} and the event's fields), level from the
// config or GEOPROX_LOG_LEVEL.
#pragma once

#include <spdlog/common.h>

#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace geoprox::server {

/// Installs the default logger. `level` must be valid (see is_valid_log_level). Call it before
/// other threads log.
void configure_logging(const std::string& level, bool json_output);

/// Logs an event with fields. A JSON line carries them as members after "msg", in their order
/// and with their types (null for a field that does not apply); a text line is `message` then
/// ` key=value` for each field (null and empty strings as "-", strings with spaces or quotes
/// quoted, other numbers with 3 decimals). `fields` must be an object.
void log_fields(spdlog::level::level_enum level, std::string_view message,
                const nlohmann::ordered_json& fields);

}  // namespace geoprox::server
