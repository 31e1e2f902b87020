#include "core/config_paths.h"

#include <gtest/gtest.h>

#include <fstream>

namespace loom {
namespace {

namespace fs = std::filesystem;

TEST(ConfigPathsTest, AFileByPathThenByNameHereThenShippedElseAsGiven) {
  const fs::path root = fs::path(::testing::TempDir()) / "config-paths";
  fs::remove_all(root);
  fs::create_directories(root / "shipped" / "rig");
  fs::create_directories(root / "here" / "configs" / "rig");
  std::ofstream(root / "shipped" / "rig" / "mini.yaml") << "shipped\n";
  std::ofstream(root / "shipped" / "rig" / "both.yaml") << "shipped\n";
  std::ofstream(root / "here" / "configs" / "rig" / "both.yaml") << "here\n";
  std::ofstream(root / "here" / "mine.yaml") << "mine\n";
  fs::create_directories(root / "here" / "mini");  // a directory named like the config
  const fs::path before = fs::current_path();
  fs::current_path(root / "here");
  const fs::path shipped = root / "shipped";
  EXPECT_EQ(ResolveConfigPath("mine.yaml", "rig", shipped), fs::path("mine.yaml"));
  EXPECT_EQ(ResolveConfigPath("both", "rig", shipped), fs::path("configs/rig/both.yaml"));
  EXPECT_EQ(ResolveConfigPath("mini", "rig", shipped), shipped / "rig" / "mini.yaml");
  EXPECT_EQ(ResolveConfigPath("missing", "rig", shipped), fs::path("missing"));
  fs::current_path(before);
}

}  // namespace
}  // namespace loom
