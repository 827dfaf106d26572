#include "core/base/errors.h"

#include <array>

namespace geoprox {

const std::string& error_code_name(ErrorCode code) {
  static const std::array kNames = {
#define GEOPROX_ERROR_CODE_NAME(name) std::string(#name),
      GEOPROX_ERROR_CODES(GEOPROX_ERROR_CODE_NAME)
#undef GEOPROX_ERROR_CODE_NAME
  };
  return kNames.at(static_cast<std::size_t>(code));
}

void throw_internal_error(const char* condition, const char* file, int line,
                          const std::string& detail) {
  std::string message = std::string("internal error: ") + condition + " failed at " + file + ":" +
                        std::to_string(line);
  if (!detail.empty()) message += ": " + detail;
  throw InternalError(message);
}

}  // namespace geoprox
