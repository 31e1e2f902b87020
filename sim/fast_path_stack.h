#pragma once
// What `loom sim render --stack` does with files, for the command and the main job alike: the
// fast-path stack (stack.h) of the observations a material plan with a preset makes, its memory
// checked first, degraded as a scan where asked (scan_emulation.h), written with the ground truth
// on its grid beside it where asked.

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>

#include "core/status.h"
#include "scan/plan.h"
#include "sim/renderer.h"

namespace loom::sim {

struct FastPathStackRequest {
  int size_px = 0;  // square; 0: the whole sample
  std::filesystem::path out;
  std::filesystem::path truth;           // empty: not written
  std::filesystem::path scan_emulation;  // empty: the stack as rendered
  uint64_t seed = 1;                     // the scan emulation's noise
};

// Says what it wrote, a line per file, on `report`.
Status WriteFastPathStack(const Scene& scene, const scan::Preset& preset, const FastPathStackRequest& request,
                          std::ostream& report);

}  // namespace loom::sim
