#include "apps/config_paths.h"

#include "core/config_paths.h"

namespace loom::apps {

std::filesystem::path ResolvePresetPath(const std::string& preset) {
  return ResolveConfigPath(preset, "plans", LOOM_CONFIGS_DIR);
}

std::filesystem::path ResolveRigPath(const std::string& rig) { return ResolveConfigPath(rig, "rig", LOOM_CONFIGS_DIR); }

}  // namespace loom::apps
