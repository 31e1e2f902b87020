#include "core/rig_file.h"

#include <gtest/gtest.h>

#include <string>

#include "core/check.h"

namespace loom {
namespace {

constexpr char kRig[] = R"(schema_version: 1
name: bench
seed: 7
geometry:
  cameras: [{name: cam0, resolution: [64, 48], focal_px: [100, 100], position_mm: [0, 0, 500], look_at_mm: [0, 0, 0], up: [0, 1, 0]}]
  leds: [{position_mm: [0, 300, 300]}]
devices: {cameras: [{name: cam0, backend: sim}]}
recalibration: {reprojection_px: 0.25}
)";

bool Contains(const Status& status, const std::string& text) { return status.ToString().find(text) != std::string::npos; }

TEST(RigFileTest, EachPartReadsItsSectionAndLeavesTheOthers) {
  const Result<RigFile> file = RigFile::Parse(kRig, "bench.yaml");
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  EXPECT_EQ(file->name(), "bench");
  EXPECT_EQ(file->Seed(), 7);
  const Result<RigModel> model = file->Model();
  ASSERT_TRUE(model.ok()) << model.status().ToString();
  EXPECT_EQ(model->name, "bench");
  ASSERT_EQ(model->cameras.size(), 1u);
  EXPECT_EQ(model->cameras[0].width, 64);
  // devices: and recalibration: were never read: they belong to other readers.
  EXPECT_TRUE(file->Finish().ok()) << file->Finish().ToString();
  EXPECT_TRUE(file->Has("devices"));
  EXPECT_FALSE(file->Has("as_built"));
  // A key that is no section is a bug in the caller, the scalar seed: included.
  EXPECT_THROW(file->Section("seed"), CheckError);
  EXPECT_THROW(file->Has("geometri"), CheckError);
}

TEST(RigFileTest, AnUnknownTopLevelKeyIsAnErrorWhateverWasRead) {
  const Result<RigFile> file = RigFile::Parse(std::string(kRig) + "devics: {}\n", "bench.yaml");
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  ASSERT_TRUE(file->Model().ok());
  const Status finished = file->Finish();
  EXPECT_FALSE(finished.ok());
  EXPECT_TRUE(Contains(finished, "bench.yaml")) << finished.ToString();
  EXPECT_TRUE(Contains(finished, "devics")) << finished.ToString();
}

TEST(RigFileTest, ATypoInsideASectionThatWasReadIsAnError) {
  std::string text = kRig;
  text.replace(text.find("focal_px"), 8, "focal_pz");
  const Result<RigModel> model = RigModelFromText(text, "bench.yaml");
  ASSERT_FALSE(model.ok());
  EXPECT_TRUE(Contains(model.status(), "geometry.cameras[0].focal_pz")) << model.status().ToString();
}

TEST(RigFileTest, AnLedRingOfImpossibleSizeIsAnErrorNotAnAllocation) {
  for (const char* ring :
       {"{radius_mm: 650, elevation_deg: 45, count: 2000000000}", "{radius_mm: 0, elevation_deg: 45, count: 0}"}) {
    std::string text = kRig;
    text.replace(text.find("  leds:"), 0, std::string("  led_rings: [") + ring + "]\n");
    const Result<RigModel> model = RigModelFromText(text, "bench.yaml");
    ASSERT_FALSE(model.ok()) << ring;
    EXPECT_TRUE(Contains(model.status(), "geometry.led_rings[0].count")) << model.status().ToString();
  }
}

// A linear light's profile along its strip: read, interpolated between its points, and refused
// naming the key when it cannot be one.
TEST(RigFileTest, TheLinearLightsProfileIsReadAndABadOneIsNamed) {
  const std::string strip =
      "  linear_light: {arm_radius_mm: 450, strip_length_mm: 300, start_deg: -70, end_deg: 70, travel_mm: 400, profile: ";
  std::string text = kRig;
  text.replace(text.find("  leds:"), 0, strip + "[0.8, 1.0, 1.1]}\n");
  const Result<RigModel> model = RigModelFromText(text, "bench.yaml");
  ASSERT_TRUE(model.ok()) << model.status().ToString();
  const LinearLightModel& light = *model->linear_light;
  EXPECT_DOUBLE_EQ(light.ProfileAt(-150), 0.8);
  EXPECT_DOUBLE_EQ(light.ProfileAt(-75), 0.9);
  EXPECT_DOUBLE_EQ(light.ProfileAt(0), 1.0);
  EXPECT_DOUBLE_EQ(light.ProfileAt(200), 1.1);  // beyond the strip: its end's
  EXPECT_DOUBLE_EQ(LinearLightModel{}.ProfileAt(10), 1.0);
  for (const char* bad : {"[1]", "[1, 0]", "[1, .nan]", "[1, 11]"}) {
    std::string bad_text = kRig;
    bad_text.replace(bad_text.find("  leds:"), 0, strip + bad + "}\n");
    const Result<RigModel> refused = RigModelFromText(bad_text, "bench.yaml");
    ASSERT_FALSE(refused.ok()) << bad;
    EXPECT_TRUE(Contains(refused.status(), "geometry.linear_light.profile")) << refused.status().ToString();
  }
}

TEST(RigFileTest, ARigWithoutGeometryHasNoModelAndSaysWhichFile) {
  const Result<RigModel> model = RigModelFromText("schema_version: 1\nname: real\ndevices: {}\n", "real.yaml");
  ASSERT_FALSE(model.ok());
  EXPECT_TRUE(Contains(model.status(), "real.yaml")) << model.status().ToString();
  EXPECT_TRUE(Contains(model.status(), "geometry")) << model.status().ToString();
}

TEST(RigFileTest, ANameAndASupportedSchemaAreRequired) {
  const Result<RigFile> unnamed = RigFile::Parse("schema_version: 1\ndevices: {}\n", "unnamed.yaml");
  ASSERT_TRUE(unnamed.ok());
  EXPECT_TRUE(Contains(unnamed->Finish(), "'name'")) << unnamed->Finish().ToString();
  EXPECT_FALSE(RigFile::Parse("schema_version: 2\nname: x\n", "future.yaml").ok());
}

}  // namespace
}  // namespace loom
