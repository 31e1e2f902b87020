// The observations a material plan makes on the shipped tac7-mini, and a plan that names a
// camera the rig does not have.
#include "sim/plan_observations.h"
#include "core/testing/build_tree.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "core/testing/shipped_rig.h"

namespace loom::sim {
namespace {

TEST(PlanObservationsTest, APresetsMaterialPlanGivesOneObservationPerCameraOfEveryLitStep) {
  const RigModel rig = loom::testing::ShippedRigModel("tac7-mini");
  const Result<scan::Preset> preset = scan::LoadPreset(loom::testing::SourceDir() + "/configs/plans/low.yaml");
  ASSERT_TRUE(preset.ok()) << preset.status().ToString();
  const Result<std::vector<Observation>> observations = PresetObservations(rig, *preset);
  ASSERT_TRUE(observations.ok()) << observations.status().ToString();
  // tac7-mini, low preset: 16 colour, 72 monochrome and 140 linear-light images.
  EXPECT_EQ(observations->size(), 228u);
  const auto strips =
      std::count_if(observations->begin(), observations->end(), [](const Observation& o) { return o.state.linear_light_on; });
  EXPECT_EQ(strips, 140);

  scan::Plan plan = *scan::MakeMaterialPlan(rig, *preset);
  const auto lit = std::find_if(plan.steps.begin(), plan.steps.end(),
                                [](const scan::Step& s) { return s.kind == scan::StepKind::kMonochrome; });
  ASSERT_NE(lit, plan.steps.end());
  lit->cameras = {"cam9"};
  const Result<std::vector<Observation>> unknown = PlanObservations(rig, plan);
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.status().ToString().find("'cam9' is not in the rig geometry"), std::string::npos)
      << unknown.status().ToString();
}

}  // namespace
}  // namespace loom::sim
