#pragma once
// What one camera image of a rig shows, in the observation stack's terms: the lights that were
// on (LEDs with their filter-wheel slots, the linear light) and the turntable angle, turned into
// a StackObservation (core/observation_stack.h) from the rig's description — nominal or
// calibrated. The simulator's fast path and reconstruction both describe observations with it,
// so an ideal stack and a reconstructed one of the same plan carry the same table.

#include <map>
#include <utility>
#include <vector>

#include "core/observation_stack.h"
#include "core/rig_model.h"
#include "core/status.h"

namespace loom {

struct LightingState {
  std::vector<std::pair<int, double>> leds;  // LED index in RigModel, current (mA)
  std::map<int, int> filter_slots;           // filter wheel index in RigModel → slot
  double turntable_deg = 0;
  bool linear_light_on = false;
  double linear_light_mm = 0;         // carriage position
  double linear_light_intensity = 1;  // 0..1
};

// The table entry: group (colour if a band-pass filter is in front of a lit LED, linear if the
// strip is on, else monochrome), the camera's centre, colour weights (core/spectra.h's nominal
// response) and the point emitters — one per lit LED, one per strip segment — in the sample
// frame at the turntable angle. Lights of different colour in one image (filtered and
// unfiltered LEDs, or a filtered LED with the strip) have no single colour weight: an error.
Result<StackObservation> DescribeRigObservation(const RigModel& rig, int camera, const LightingState& lighting);

}  // namespace loom
