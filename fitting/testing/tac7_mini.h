#pragma once
// Test helpers: tac7-mini's geometry (configs/rig/tac7-mini.yaml) and the observations its low
// preset makes — every LED at 3 turntable angles, the filtered LEDs through their filters, and
// the strip at evenly spaced positions — as the simulator's fast path renders them.
// Header-only, for the fitting tests.

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/testing/shipped_rig.h"
#include "sim/stack.h"

namespace loom::fitting::testing {

inline RigModel TacMiniGeometry() { return loom::testing::ShippedRigModel("tac7-mini"); }

// `strip_positions` ≥ 2 positions from 0 to the strip's travel, every camera at each.
inline std::vector<sim::Observation> TacMiniObservations(const RigModel& rig, int strip_positions) {
  std::vector<sim::Observation> observations = sim::DefaultObservations(rig, {0, 120, 240});
  for (int k = 0; k < strip_positions; ++k) {
    const double position_mm = rig.linear_light->travel_mm * k / (strip_positions - 1);
    for (int camera = 0; camera < static_cast<int>(rig.cameras.size()); ++camera) {
      observations.push_back({camera, {.linear_light_on = true, .linear_light_mm = position_mm}});
    }
  }
  return observations;
}

}  // namespace loom::fitting::testing
