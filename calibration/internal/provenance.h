#pragma once
// What every calibration file records of where it came from.

#include <yaml-cpp/yaml.h>

#include <ctime>
#include <string>

#include "core/version.h"

namespace loom::calibration::internal {

inline std::string NowUtc() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

// The `source:` mapping's loom_version and created keys (the caller adds what it came from).
inline void EmitVersionAndTime(YAML::Emitter& out) {
  out << YAML::Key << "loom_version" << YAML::Value << std::string(VersionWithCommit());
  out << YAML::Key << "created" << YAML::Value << NowUtc();
}

}  // namespace loom::calibration::internal
