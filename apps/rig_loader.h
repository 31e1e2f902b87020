#pragma once
// Loads a rig YAML (core/rig_file.h) with every backend loom has. A simulated rig (one with a
// `geometry:` section) also gets its virtual world (hal/sim/sim_rig.h), shared by its `sim` devices.

#include <filesystem>
#include <memory>
#include <optional>

#include "acquisition/sequencer.h"
#include "apps/config_paths.h"
#include "core/rig_file.h"
#include "hal/rig.h"
#include "hal/sim/sim_rig.h"
#include "scan/plan.h"

namespace loom::apps {

struct LoadedRig {
  std::unique_ptr<hal::Rig> rig;
  std::optional<RigModel> model;   // from `geometry:`, when the file has one
  std::optional<hal::SimRig> sim;  // with `model`: for the devices whose backend is `sim`
  scan::LightDriftSettings light_drift;
  acquisition::DeviceFaultPolicy device_faults;
};

// `rig`: a file, or a name (ResolveRigPath). `object` replaces a simulated rig's `sample:`
// ("fabric:SEED", "white-tile", "chessboard", "colour-chart"); empty keeps it.
Result<LoadedRig> LoadRig(const std::string& rig, const std::string& object = "");
// The same from the text of a rig file (a scan's snapshot); `source` names it in messages.
Result<LoadedRig> LoadRigFromText(const std::string& text, const std::string& source, const std::string& object = "");

}  // namespace loom::apps
