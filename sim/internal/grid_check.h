#pragma once
// The one check of a map grid that GridOptions, FabricOptions and StackOptions share.

#include <string>
#include <vector>

namespace loom::sim::internal {

inline constexpr int kMaxGridSide = 16384;

// Problems of a grid `width_px` × `height_px` at `pixel_mm` (NaN fails); with `zero_is_default`,
// 0 in any of them stands for "as the material has it".
inline void AddGridProblems(int width_px, int height_px, double pixel_mm, bool zero_is_default,
                            std::vector<std::string>& problems) {
  const int min_side = zero_is_default ? 0 : 1;
  const std::string range = "[" + std::to_string(min_side) + ", " + std::to_string(kMaxGridSide) + "]";
  if (width_px < min_side || width_px > kMaxGridSide) problems.push_back("width_px must be in " + range);
  if (height_px < min_side || height_px > kMaxGridSide) problems.push_back("height_px must be in " + range);
  const bool default_size = zero_is_default && pixel_mm == 0;
  if (!default_size && !(pixel_mm >= 1e-4 && pixel_mm <= 1000)) {
    problems.push_back(std::string("pixel_mm must be in [0.0001, 1000]") + (zero_is_default ? " or 0" : ""));
  }
}

}  // namespace loom::sim::internal
