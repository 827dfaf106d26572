// Timings and summary statistics shared by the query commands (`distance`, `field`, `path`,
// `eval`).
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

namespace geoprox::cli {

/// Milliseconds elapsed since `start`.
inline double ms_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

/// The p-quantile (0..1) of `values` by nearest rank; 0 for none.
inline double quantile(std::vector<double> values, double p) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(values.size())));
  return values[std::min(values.size() - 1, rank == 0 ? 0 : rank - 1)];
}

/// The mean of `values`; 0 for none.
inline double mean(const std::vector<double>& values) {
  double sum = 0;
  for (double v : values) sum += v;
  return values.empty() ? 0 : sum / static_cast<double>(values.size());
}

}  // namespace geoprox::cli
