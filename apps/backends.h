#pragma once
// Every device backend loom ships, registered under its rig-YAML `backend:` key, and rigs loaded
// with them: the only place that knows them all (style.md: apps picks backends).

#include <string>

#include "acquisition/rig_scan.h"
#include "hal/registry.h"

namespace loom::apps {

using acquisition::LoadedRig;

hal::BackendRegistry AllBackends();

// `rig`: a file, or a name (ResolveRigPath). `object` replaces a simulated rig's `sample:`
// ("fabric:SEED", "white-tile", "chessboard", "colour-chart"); empty keeps it.
Result<LoadedRig> LoadRig(const std::string& rig, const std::string& object = "");

}  // namespace loom::apps
