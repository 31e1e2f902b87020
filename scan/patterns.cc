#include "scan/patterns.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string_view>

namespace loom::scan {
namespace {

// `digits` as a number when it is one and nothing else ("07", not "7x" or "").
std::optional<int> WholeNumber(std::string_view digits) {
  int value = 0;
  const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (digits.empty() || error != std::errc() || end != digits.data() + digits.size()) return std::nullopt;
  return value;
}

}  // namespace

int GrayCodeBits(int projector_width) { return static_cast<int>(std::ceil(std::log2(std::max(2, projector_width)))); }

std::string GrayPatternName(int bit, bool inverse) {
  return "gray_x_" + std::string(bit < 10 ? "0" : "") + std::to_string(bit) + (inverse ? "_inv" : "");
}

Result<Pattern> MakePattern(const std::string& name, int width, int height, int phase_steps) {
  Pattern pattern{name, width, height, std::vector<uint8_t>(static_cast<size_t>(width) * height)};
  const auto fill = [&](auto column_value) {
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) pattern.pixels[static_cast<size_t>(y) * width + x] = column_value(x);
    }
  };
  if (name == "white" || name == "black") {
    fill([&](int) { return static_cast<uint8_t>(name == "white" ? 255 : 0); });
    return pattern;
  }
  if (name.starts_with("gray_x_")) {
    const int bits = GrayCodeBits(width);
    const bool inverse = name.ends_with("_inv");
    const std::optional<int> parsed = WholeNumber(std::string_view(name).substr(7, name.size() - 7 - (inverse ? 4 : 0)));
    if (!parsed) return InvalidArgumentError("pattern '" + name + "'", "not gray_x_NN or gray_x_NN_inv");
    const int bit = *parsed;
    if (bit < 0 || bit >= bits) return InvalidArgumentError("pattern '" + name + "'", "no such Gray-code bit");
    fill([&](int x) {
      const int gray = x ^ (x >> 1);
      const bool on = ((gray >> (bits - 1 - bit)) & 1) != inverse;
      return static_cast<uint8_t>(on ? 255 : 0);
    });
    return pattern;
  }
  if (name.starts_with("phase_x_")) {
    const std::optional<int> step = WholeNumber(std::string_view(name).substr(8));
    if (!step || *step < 0 || *step >= phase_steps) {
      return InvalidArgumentError("pattern '" + name + "'",
                                  "not phase_x_K with K below the " + std::to_string(phase_steps) + " phase steps");
    }
    const int k = *step;
    fill([&](int x) {
      const double phase =
          2 * 3.14159265358979323846 * (static_cast<double>(x) / kPhasePeriodColumns + static_cast<double>(k) / phase_steps);
      return static_cast<uint8_t>(std::lround(127.5 + 127.5 * std::cos(phase)));
    });
    return pattern;
  }
  return InvalidArgumentError("pattern '" + name + "'", "unknown (white, black, gray_x_NN[_inv], phase_x_K)");
}

}  // namespace loom::scan
