#pragma once
// A camera's black level and noise floor, from the dark frame a plan's dark step captures: the
// sequencer measures it during a scan, calibration from the stored frame afterwards.

#include "scan/frame.h"

namespace loom::scan {

// A camera's dark frame, summarised.
struct DarkLevel {
  double black_dn = 0;  // median
  double noise_dn = 0;  // 1.4826 × median absolute deviation: hot pixels do not count
};
DarkLevel MeasureDarkLevel(const RawFrame& dark);

}  // namespace loom::scan
