#pragma once
// Loads a rig YAML with every backend loom has. A simulated rig (one with a `geometry:`
// section) also gets its virtual world: the scene of the `sample:` on its turntable, shared by
// its `sim` devices.

#include <filesystem>
#include <memory>

#include "core/rig_model.h"
#include "hal/rig.h"
#include "hal/sim/sim_backends.h"

namespace loom::apps {

inline constexpr int kRigSchemaVersion = 1;

struct LoadedRig {
  std::unique_ptr<hal::Rig> rig;
  std::shared_ptr<hal::SimWorld> world;  // null for a rig of real devices
};

Result<LoadedRig> LoadRig(const std::filesystem::path& path);

// Only the rig's description (its `geometry:`), for commands that plan rather than drive.
Result<RigModel> LoadRigModel(const std::filesystem::path& path);

}  // namespace loom::apps
