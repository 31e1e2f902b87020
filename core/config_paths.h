#pragma once
// Where a config file a user names on the command line is: a path, or a name in a configs/
// folder, the working directory's first and then loom's own.

#include <filesystem>
#include <string>

namespace loom {

// `name` as a path to a file, else `folder`/NAME.yaml under ./configs, else under
// `shipped_configs` (loom's configs/ directory); `name` as given when none exists, so that the
// error that follows names what the user wrote. A directory of that name (a model's, a scan's) is
// not a config file.
std::filesystem::path ResolveConfigPath(const std::string& name, const std::string& folder,
                                        const std::filesystem::path& shipped_configs);

}  // namespace loom
