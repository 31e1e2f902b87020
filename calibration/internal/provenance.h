#pragma once
// What every calibration file writes and reads alike: its header, where it came from, and 3 × 3
// matrices.

#include <yaml-cpp/yaml.h>

#include <ctime>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/config.h"
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

// The closing `source: {from, loom_version, created}` mapping of a file.
inline void EmitSource(YAML::Emitter& out, const std::string& from) {
  out << YAML::Key << "source" << YAML::Value << YAML::BeginMap << YAML::Key << "from" << YAML::Value << from;
  EmitVersionAndTime(out);
  out << YAML::EndMap;
}

// The opening `device`, `name` and `model` keys: device and model must be these, and the name
// too when one is given; a mismatch is an error on the key.
inline void ReadHeader(const ConfigNode& root, const std::string& device, const std::string& model,
                       const std::string& name = "") {
  std::string found_device, found_name, found_model;
  root.Required("device", &found_device);
  root.Required("name", &found_name);
  root.Required("model", &found_model);
  if (found_device != device) root.AddError("device", "is '" + found_device + "', expected " + device);
  if (!name.empty() && found_name != name) root.AddError("name", "is '" + found_name + "', expected " + name);
  if (found_model != model) root.AddError("model", "unknown model '" + found_model + "'");
}

// The closing `source:` mapping: required, and for people (nothing in it is applied).
inline void ReadSource(const ConfigNode& root) {
  const ConfigNode source = root.Child("source");
  std::string from;
  source.Required("from", &from);
  source.Ignore("loom_version");
  source.Ignore("created");
}

// Three rows of three.
inline void EmitMatrix(YAML::Emitter& out, const Eigen::Matrix3d& m) {
  out << YAML::BeginSeq;
  for (int r = 0; r < 3; ++r) out << YAML::Flow << std::vector<double>{m(r, 0), m(r, 1), m(r, 2)};
  out << YAML::EndSeq;
}

}  // namespace loom::calibration::internal
