#pragma once
// The camera windows that see a crop of the sample: for a scan of a square crop, each camera
// reads only the region of interest (GenICam OffsetX/OffsetY/Width/Height) where the crop can
// appear, at any turntable angle and anywhere up to `relief_mm` above the holder. A tac7 camera
// is 2048 × 1536 px; a 64-pixel crop of the stack is a few hundred of them a side. The same for
// the calibration objects of a calibration scan.

#include <map>
#include <string>

#include "core/rig_model.h"
#include "core/status.h"
#include "scan/frame.h"
#include "scan/plan.h"

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

// A calibration scan read through windows: each step whose object is the calibration target, the
// chrome sphere or the colour chart reads, from every camera, only the window around where that
// object lies at the step's turntable angle (Step::windows). On a paper-size rig those objects
// fill a fifth of a 2048 × 1536 sensor or less. The white tile's steps read whole frames: it
// fills the field, and the flat field is fitted across it. Dark steps read whole frames too.
struct ObjectWindowOptions {
  double placement_mm = 3;  // how far from the turntable's centre an operator may place an object
  int margin_px = 8;
  int alignment_px = 8;
  Status Check() const;  // every problem, naming the field
};

// `plan` with its calibration objects' windows set. A step whose object the rig does not describe
// (no calibration_target:, light_probe: or colour_chart:) is an error naming it.
Result<scan::Plan> WithObjectWindows(scan::Plan plan, const RigModel& rig, const ObjectWindowOptions& options);

}  // namespace loom::acquisition
