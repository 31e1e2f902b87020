#include "core/config_paths.h"

namespace loom {

namespace fs = std::filesystem;

fs::path ResolveConfigPath(const std::string& name, const std::string& folder, const fs::path& shipped_configs) {
  if (fs::exists(name) && !fs::is_directory(name)) return name;
  for (const fs::path& configs : {fs::path("configs"), shipped_configs}) {
    const fs::path file = configs / folder / (name + ".yaml");
    if (fs::exists(file)) return file;
  }
  return name;
}

}  // namespace loom
