#pragma once
// A rig YAML by path or name, loaded with every backend loom has (acquisition/rig_scan.h).

#include <string>

#include "acquisition/rig_scan.h"

namespace loom::apps {

using acquisition::LoadedRig;

// `rig`: a file, or a name (ResolveRigPath). `object` replaces a simulated rig's `sample:`
// ("fabric:SEED", "white-tile", "chessboard", "colour-chart"); empty keeps it.
Result<LoadedRig> LoadRig(const std::string& rig, const std::string& object = "");

}  // namespace loom::apps
