#pragma once
// Test helper: the `geometry:` of a rig YAML shipped in configs/rig/ (LOOM_SOURCE_DIR is defined
// for every test target). Header-only.

#include <gtest/gtest.h>

#include <string>

#include "core/rig_file.h"

namespace loom::testing {

inline RigModel ShippedRigModel(const std::string& name) {
  Result<RigModel> rig = LoadRigModel(std::string(LOOM_SOURCE_DIR) + "/configs/rig/" + name + ".yaml");
  EXPECT_TRUE(rig.ok()) << rig.status().ToString();
  return rig.ok() ? *rig : RigModel{};
}

}  // namespace loom::testing
