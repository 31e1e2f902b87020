#pragma once
// Loads a rig YAML with every backend loom has. A simulated rig (one with a `geometry:`
// section) also gets its virtual world: the scene of the `sample:` on its turntable, shared by
// its `sim` devices.

#include <filesystem>
#include <memory>

#include "core/rig_model.h"
#include "hal/rig.h"
#include "hal/sim/sim_backends.h"
#include "sim/sample.h"

namespace loom::apps {

inline constexpr int kRigSchemaVersion = 1;

struct LoadedRig {
  std::unique_ptr<hal::Rig> rig;
  std::optional<RigModel> model;         // from `geometry:`, when the file has one
  std::shared_ptr<hal::SimWorld> world;  // null for a rig of real devices
  sim::SampleSpec sample;                // what a simulated rig's "sample" is
};

// Puts what a plan step names on a simulated rig's turntable: "sample" (the rig's `sample:` or
// the object asked for), "target" (the geometry's calibration_target), "white tile", "colour
// chart". Another name is an error.
Status PlaceSimObject(const LoadedRig& loaded, const std::string& object);

// `object` replaces a simulated rig's `sample:` ("fabric:SEED", "white-tile", "chessboard",
// "colour-chart"); empty keeps it.
Result<LoadedRig> LoadRig(const std::filesystem::path& path, const std::string& object = "");
// The same from the text of a rig file (a scan's snapshot); `source` names it in messages.
Result<LoadedRig> LoadRigFromText(const std::string& text, const std::string& source, const std::string& object = "");

// A gloss preset by name (configs/plans/NAME.yaml, from here or loom's source tree) or path.
std::filesystem::path ResolvePresetPath(const std::string& preset);
// A rig by name (configs/rig/NAME.yaml, from here or loom's source tree) or path.
std::filesystem::path ResolveRigPath(const std::string& rig);

// Only the rig's description (its `geometry:`), for commands that plan rather than drive.
Result<RigModel> LoadRigModel(const std::filesystem::path& path);
// The same from the text of a rig file (a scan's snapshot); `source` names it in messages.
Result<RigModel> LoadRigModelFromText(const std::string& text, const std::string& source);

}  // namespace loom::apps
