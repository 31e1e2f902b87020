#pragma once
// What makes a rig file with a `geometry:` a simulated rig: the world its `sim` devices share —
// the `sample:` (or an object asked for) on the turntable of the rig as built — and the objects a
// plan's steps put there.
//
// How the simulated hardware differs from its `geometry:` (`as_built:`): sim/rig_scene.h.

#include <memory>
#include <string>

#include "core/rig_file.h"
#include "hal/sim/sim_backends.h"
#include "scan/plan.h"
#include "sim/rig_scene.h"
#include "sim/sample.h"

namespace loom::hal {

struct SimRig {
  std::shared_ptr<SimWorld> world;
  sim::SampleSpec sample;  // what the rig's "sample" is
};

// The world of `file`'s simulated rig (`model`: its geometry). `object` replaces the `sample:`
// ("fabric:SEED", "white-tile", "chessboard", "colour-chart"); empty keeps it.
Result<SimRig> MakeSimRig(const RigFile& file, const RigModel& model, const std::string& object);

// Puts what a plan step needs on the turntable: the sample is the rig's `sample:` (or the object
// asked for), the calibration objects are the geometry's.
Status PlaceObject(const SimRig& rig, scan::ScanObject object);

}  // namespace loom::hal
