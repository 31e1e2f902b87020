#include "apps/config_paths.h"

namespace loom::apps {

namespace {

// A file by path, or by NAME in configs/<folder>/NAME.yaml, here or in loom's source tree. A
// directory of that name (a model's, a scan's) is not a config file.
std::filesystem::path ResolveConfigPath(const std::string& folder, const std::string& name) {
  namespace fs = std::filesystem;
  if (fs::exists(name) && !fs::is_directory(name)) return name;
  const fs::path local = fs::path("configs") / folder / (name + ".yaml");
  if (fs::exists(local)) return local;
  return fs::path(LOOM_CONFIGS_DIR) / folder / (name + ".yaml");
}

}  // namespace

std::filesystem::path ResolvePresetPath(const std::string& preset) { return ResolveConfigPath("plans", preset); }

std::filesystem::path ResolveRigPath(const std::string& rig) {
  const std::filesystem::path found = ResolveConfigPath("rig", rig);
  return std::filesystem::exists(found) ? found : std::filesystem::path(rig);
}

}  // namespace loom::apps
