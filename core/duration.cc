#include "core/duration.h"

#include <cmath>

namespace loom {

std::string FormatDuration(double seconds) {
  const int total = static_cast<int>(std::lround(seconds));
  std::string out;
  if (total >= 3600) out += std::to_string(total / 3600) + " h ";
  return out + std::to_string((total % 3600) / 60) + " min " + std::to_string(total % 60) + " s";
}

}  // namespace loom
