#include "server/logging.h"

#include <spdlog/fmt/fmt.h>
#include <spdlog/pattern_formatter.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <ctime>

namespace geoprox::server {

namespace {

using nlohmann::ordered_json;

/// Set by configure_logging, before other threads log.
bool json_lines = false;
/// The fields of the event being logged on this thread. The logger is synchronous: its
/// formatter runs on the logging thread, inside the spdlog::log call of log_fields.
thread_local const ordered_json* current_fields = nullptr;

std::string utc_timestamp(spdlog::log_clock::time_point time) {
  const auto seconds = std::chrono::system_clock::to_time_t(time);
  const auto micros =
      std::chrono::duration_cast<std::chrono::microseconds>(time.time_since_epoch()).count() %
      1000000;
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char stamp[64];
  std::snprintf(stamp, sizeof stamp, "%04d-%02d-%02dT%02d:%02d:%02d.%06lldZ", tm.tm_year + 1900,
                tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec,
                static_cast<long long>(micros));
  return stamp;
}

class JsonFormatter final : public spdlog::formatter {
 public:
  void format(const spdlog::details::log_msg& msg, spdlog::memory_buf_t& dest) override {
    ordered_json line;
    line["time"] = utc_timestamp(msg.time);
    line["level"] = std::string(spdlog::level::to_string_view(msg.level).data(),
                                spdlog::level::to_string_view(msg.level).size());
    line["thread"] = msg.thread_id;
    line["msg"] = std::string(msg.payload.data(), msg.payload.size());
    if (current_fields != nullptr) {
      for (const auto& [key, value] : current_fields->items()) line[key] = value;
    }
    // Invalid UTF-8 becomes U+FFFD: every line stays valid JSON.
    std::string text = line.dump(-1, ' ', false, ordered_json::error_handler_t::replace);
    text += '\n';
    dest.append(text.data(), text.data() + text.size());
  }
  std::unique_ptr<spdlog::formatter> clone() const override {
    return std::make_unique<JsonFormatter>();
  }
};

bool needs_quotes(const std::string& text) {
  for (const char c : text) {
    if (c == ' ' || c == '"' || c == '=' || static_cast<unsigned char>(c) < 0x20) return true;
  }
  return false;
}

std::string text_value(const ordered_json& value) {
  if (value.is_null()) return "-";
  if (value.is_string()) {
    const auto& text = value.get_ref<const std::string&>();
    if (text.empty()) return "-";
    return needs_quotes(text) ? value.dump(-1, ' ', false, ordered_json::error_handler_t::replace)
                              : text;
  }
  if (value.is_number_float()) return fmt::format("{:.3f}", value.get<double>());
  return value.dump(-1, ' ', false, ordered_json::error_handler_t::replace);
}

/// Resets the thread's fields even if logging throws.
struct FieldsScope {
  explicit FieldsScope(const ordered_json& fields) { current_fields = &fields; }
  ~FieldsScope() { current_fields = nullptr; }
  FieldsScope(const FieldsScope&) = delete;
  FieldsScope& operator=(const FieldsScope&) = delete;
};

}  // namespace

void configure_logging(const std::string& level, bool json_output) {
  spdlog::drop("geoproxd");
  auto logger = spdlog::stderr_logger_mt("geoproxd");
  json_lines = json_output;
  if (json_output) {
    logger->set_formatter(std::make_unique<JsonFormatter>());
  } else {
    logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%-5l%$ [%t] %v");
  }
  logger->set_level(spdlog::level::from_str(level));
  logger->flush_on(spdlog::level::warn);
  spdlog::set_default_logger(logger);
}

void log_fields(spdlog::level::level_enum level, std::string_view message,
                const ordered_json& fields) {
  if (!spdlog::should_log(level)) return;
  if (json_lines) {
    const FieldsScope scope(fields);
    spdlog::log(level, "{}", message);
    return;
  }
  std::string text(message);
  for (const auto& [key, value] : fields.items()) {
    text += ' ';
    text += key;
    text += '=';
    text += text_value(value);
  }
  spdlog::log(level, "{}", text);
}

}  // namespace geoprox::server
