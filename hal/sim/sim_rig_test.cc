#include "hal/sim/sim_rig.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

namespace loom::hal {
namespace {

std::string ShippedRigText(const std::string& name) {
  std::ifstream file(std::string(LOOM_SOURCE_DIR) + "/configs/rig/" + name + ".yaml");
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

RigFile Parse(const std::string& text) {
  Result<RigFile> file = RigFile::Parse(text, "tac7-mini.yaml");
  EXPECT_TRUE(file.ok()) << file.status().ToString();
  return std::move(*file);
}

TEST(SimRigTest, PlacesWhatAPlanStepNeeds) {
  const RigFile file = Parse(ShippedRigText("tac7-mini"));
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
