#pragma once
// loom's version, written next to every output (scan.yaml, calibration YAML, EXR headers).

#include <string>
#include <string_view>
#include <vector>

namespace loom {

// "0.1.0" (the CMake project version).
std::string_view Version();
// "0.1.0 (git 1a2b3c4)" when built from a git checkout, else Version().
std::string_view VersionWithCommit();

// A third-party library linked into loom and its version as that library reports it at run
// time where it can (so `loom version` shows what is really loaded, not what was compiled).
struct LinkedLibrary {
  std::string name;
  std::string version;
};

// The libraries core links that report a version: OpenEXR and Eigen (both as compiled).
std::vector<LinkedLibrary> CoreLibraries();

}  // namespace loom
