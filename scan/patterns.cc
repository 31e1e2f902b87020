#include "scan/patterns.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace loom::scan {

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
    const int bit = std::stoi(name.substr(7, 2));
    const bool inverse = name.ends_with("_inv");
    if (bit < 0 || bit >= bits) return InvalidArgumentError("pattern '" + name + "'", "no such Gray-code bit");
    fill([&](int x) {
      const int gray = x ^ (x >> 1);
      const bool on = ((gray >> (bits - 1 - bit)) & 1) != inverse;
      return static_cast<uint8_t>(on ? 255 : 0);
    });
    return pattern;
  }
  if (name.starts_with("phase_x_")) {
    const int k = std::stoi(name.substr(8));
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
