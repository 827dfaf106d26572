#include "core/errors.h"

namespace geoprox {

void throw_internal_error(const char* condition, const char* file, int line,
                          const std::string& detail) {
  std::string message = std::string("internal error: ") + condition + " failed at " + file + ":" +
                        std::to_string(line);
  if (!detail.empty()) message += ": " + detail;
  throw InternalError(message);
}

}  // namespace geoprox
