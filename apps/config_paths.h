#pragma once
// Where a config named on the command line is: a path, or a name in configs/ (here, or in loom's
// source tree).

#include <filesystem>
#include <string>

namespace loom::apps {

// A gloss preset by name (configs/plans/NAME.yaml, from here or loom's source tree) or path.
std::filesystem::path ResolvePresetPath(const std::string& preset);
// A rig by path or name (configs/rig/NAME.yaml, from here or loom's source tree); as given when
// neither exists, so that the error names what the user wrote.
std::filesystem::path ResolveRigPath(const std::string& rig);

}  // namespace loom::apps
