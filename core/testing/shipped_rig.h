#pragma once
// Test helpers: a rig YAML shipped in configs/rig/, as its `geometry:` or as a rig file with more
// sections appended. Header-only.

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "core/rig_file.h"
#include "core/testing/build_tree.h"

namespace loom::testing {

inline RigModel ShippedRigModel(const std::string& name) {
  Result<RigModel> rig = LoadRigModel(SourceDir() + "/configs/rig/" + name + ".yaml");
  EXPECT_TRUE(rig.ok()) << rig.status().ToString();
  return rig.ok() ? *rig : RigModel{};
}

// configs/rig/NAME.yaml's text with `more` appended (e.g. an `as_built:` section), parsed.
inline RigFile ShippedRigFile(const std::string& name, const std::string& more = "") {
  std::ifstream file(SourceDir() + "/configs/rig/" + name + ".yaml");
  std::ostringstream text;
  text << file.rdbuf() << more;
  Result<RigFile> rig = RigFile::Parse(text.str(), name + ".yaml");
  EXPECT_TRUE(rig.ok()) << rig.status().ToString();
  return std::move(*rig);
}

}  // namespace loom::testing
