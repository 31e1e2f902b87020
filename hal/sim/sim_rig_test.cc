#include "hal/sim/sim_rig.h"

#include <gtest/gtest.h>

#include "core/testing/shipped_rig.h"
namespace loom::hal {
namespace {

TEST(SimRigTest, PlacesWhatAPlanStepNeeds) {
  const RigFile file = testing::ShippedRigFile("tac7-mini");
  const Result<SimRig> rig = MakeSimRig(file, *file.Model(), "fabric:5");
  ASSERT_TRUE(rig.ok()) << rig.status().ToString();
  EXPECT_EQ(rig->sample.seed, 5u);
  EXPECT_EQ(rig->world->object(), scan::ScanObject::kSample);
  ASSERT_TRUE(PlaceObject(*rig, scan::ScanObject::kWhiteTileOnSpacer).ok());
  EXPECT_EQ(rig->world->object(), scan::ScanObject::kWhiteTileOnSpacer);
  EXPECT_EQ(rig->world->scene()->material().name, "white tile on its spacer");
  ASSERT_TRUE(PlaceObject(*rig, scan::ScanObject::kSample).ok());
  EXPECT_EQ(rig->world->scene()->material().name.find("fabric"), 0u) << rig->world->scene()->material().name;
}

}  // namespace
}  // namespace loom::hal
