#pragma once
// Test helper: the `geometry:` of a rig YAML shipped in configs/rig/ (LOOM_SOURCE_DIR is defined
// for every test target). Header-only.

#include <gtest/gtest.h>

#include <string>

#include "core/config.h"
#include "core/rig_model.h"

namespace loom::testing {

inline RigModel ShippedRigModel(const std::string& name) {
  auto doc = ConfigDocument::LoadFile(std::string(LOOM_SOURCE_DIR) + "/configs/rig/" + name + ".yaml", 1);
  EXPECT_TRUE(doc.ok()) << doc.status().ToString();
  if (!doc.ok()) return {};
  RigModel rig = ReadRigModel(doc->root().Child("geometry"));
  rig.name = name;
  return rig;
}

}  // namespace loom::testing
