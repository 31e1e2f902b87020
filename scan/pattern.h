#pragma once
// An image for the structured-light projector (patterns.h makes the ones a plan names).

#include <cstdint>
#include <string>
#include <vector>

namespace loom::scan {

struct Pattern {
  std::string name;  // e.g. "gray_x_03", recorded with each frame
  int width = 0;
  int height = 0;
  std::vector<uint8_t> pixels;  // row-major grey levels
};

}  // namespace loom::scan
