// `loom sim render --stack` as one call: the preset's observations rendered into a stack file of
// the asked size with the truth on its grid beside it; a size the machine cannot hold is refused
// naming --size before anything is rendered or written.
#include "sim/fast_path_stack.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <sstream>

#include "core/observation_stack.h"
#include "core/testing/build_tree.h"
#include "core/testing/shipped_rig.h"
#include "sim/fabric.h"
#include "sim/material.h"
#include "sim/plan_observations.h"

namespace loom::sim {
namespace {

namespace fs = std::filesystem;

TEST(FastPathStackTest, ThePresetsObservationsAreWrittenWithTheTruthOnTheStacksGrid) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("fast_path_stack_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const Scene scene(loom::testing::ShippedRigModel("tac7-mini"),
                    GenerateFabric(3, {.width_px = 40, .height_px = 40, .pixel_mm = 0.2}));
  const Result<scan::Preset> preset = scan::LoadPreset(loom::testing::SourceDir() + "/configs/plans/low.yaml");
  ASSERT_TRUE(preset.ok()) << preset.status().ToString();
  std::ostringstream report;
  FastPathStackRequest request;
  request.size_px = 8;
  request.out = dir / "stack.exr";
  request.truth = dir / "truth.exr";
  ASSERT_TRUE(WriteFastPathStack(scene, *preset, request, report).ok()) << report.str();
  const Result<ObservationStack> stack = ReadObservationStack(dir / "stack.exr");
  ASSERT_TRUE(stack.ok()) << stack.status().ToString();
  EXPECT_EQ(stack->image.width(), 8);
  EXPECT_EQ(stack->observations.size(), PresetObservations(scene.rig(), *preset)->size());
  const Result<Material> truth = ReadMaterial(dir / "truth.exr");
  ASSERT_TRUE(truth.ok()) << truth.status().ToString();
  EXPECT_EQ(truth->width(), 8);
  EXPECT_NE(report.str().find("wrote " + (dir / "stack.exr").string()), std::string::npos) << report.str();

  FastPathStackRequest huge;
  huge.size_px = 1 << 20;
  huge.out = dir / "huge.exr";
  const Status refused = WriteFastPathStack(scene, *preset, huge, report);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.ToString().find("--size"), std::string::npos) << refused.ToString();
  EXPECT_FALSE(fs::exists(dir / "huge.exr"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace loom::sim
