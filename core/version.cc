#include "core/version.h"

#include <string>

#include <OpenEXR/OpenEXRConfig.h>
#include <Eigen/Core>

#include "loom_git_commit.h"  // generated at build time (cmake/LoomGitCommit.cmake)

namespace loom {

std::string_view Version() { return LOOM_VERSION; }

std::string_view VersionWithCommit() {
  static const std::string full = std::string(LOOM_GIT_COMMIT).empty()
                                      ? std::string(LOOM_VERSION)
                                      : std::string(LOOM_VERSION) + " (git " + LOOM_GIT_COMMIT + ")";
  return full;
}

std::vector<LinkedLibrary> CoreLibraries() {
  return {{"OpenEXR", OPENEXR_VERSION_STRING},
          {"Eigen", std::to_string(EIGEN_WORLD_VERSION) + "." + std::to_string(EIGEN_MAJOR_VERSION) + "." +
                        std::to_string(EIGEN_MINOR_VERSION)}};
}

}  // namespace loom
