#include "scan/dark_level.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace loom::scan {

DarkLevel MeasureDarkLevel(const RawFrame& dark) {
  if (dark.pixels.empty()) return {};
  std::vector<uint16_t> values = dark.pixels;
  const auto middle = values.begin() + values.size() / 2;
  std::nth_element(values.begin(), middle, values.end());
  const double median = *middle;
  std::vector<double> deviations;
  deviations.reserve(values.size());
  for (uint16_t v : values) deviations.push_back(std::abs(v - median));
  const auto mid_deviation = deviations.begin() + deviations.size() / 2;
  std::nth_element(deviations.begin(), mid_deviation, deviations.end());
  // Readings quantise to 1 DN: the spread is never below the quantisation's 1/sqrt(12).
  return {median, std::max(1.4826 * *mid_deviation, 0.29)};
}

}  // namespace loom::scan
