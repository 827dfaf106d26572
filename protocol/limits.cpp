#include "protocol/limits.h"

#include <nlohmann/json.hpp>

namespace geoprox::protocol {

void to_json(nlohmann::json& out, const Limits& limits) {
  out = {
      {"max_line_bytes", limits.max_line_bytes},
      {"max_nesting_depth", limits.max_nesting_depth},
      {"max_points_per_request", limits.max_points_per_request},
      {"max_matrix_pairs", limits.max_matrix_pairs},
      {"max_field_sources", limits.max_field_sources},
      {"max_batch_requests", limits.max_batch_requests},
      {"max_output_bytes", limits.max_output_bytes},
      {"default_timeout_ms", limits.default_timeout_ms},
      {"max_timeout_ms", limits.max_timeout_ms},
  };
}

}  // namespace geoprox::protocol
