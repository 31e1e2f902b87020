#pragma once
// A rig or gloss preset named on the command line: a path, or a name in configs/ here or in
// loom's source tree (core/config_paths.h).

#include <filesystem>
#include <string>

namespace loom::apps {

std::filesystem::path ResolvePresetPath(const std::string& preset);  // configs/plans/NAME.yaml
std::filesystem::path ResolveRigPath(const std::string& rig);        // configs/rig/NAME.yaml

}  // namespace loom::apps
