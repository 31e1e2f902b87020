#pragma once
// The camera windows that see a crop of the sample: for a scan of a square crop, each camera
// reads only the region of interest (GenICam OffsetX/OffsetY/Width/Height) where the crop can
// appear, at any turntable angle and anywhere up to `relief_mm` above the holder. A tac7 camera
// is 2048 × 1536 px; a 64-pixel crop of the stack is a few hundred of them a side.

#include <map>
#include <string>

#include "core/rig_model.h"
#include "core/status.h"
#include "scan/frame.h"

namespace loom::acquisition {

struct CropOptions {
  double size_mm = 0;    // the square crop's side, centred on the turntable axis
  double relief_mm = 3;  // how high the sample may rise above the holder
  int margin_px = 8;     // around what the geometry says, for calibration error
  int alignment_px = 8;  // offsets and sizes in multiples of this (cameras' GenICam increments)
  Status Check() const;  // every problem, naming the field
};

// Each camera's window, by camera name, clipped to its sensor. A camera that cannot see the crop
// at all is an error naming it.
Result<std::map<std::string, scan::Roi>> CropWindows(const RigModel& rig, const CropOptions& options);

}  // namespace loom::acquisition
