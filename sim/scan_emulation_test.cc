#include "sim/scan_emulation.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>

#include "core/testing/shipped_rig.h"
#include "sim/sample.h"
#include "sim/stack.h"

namespace loom::sim {
namespace {

// A fabric's fast-path stack on tac7-mini under a few LEDs seen by both cameras.
ObservationStack FabricStack() {
  SampleSpec spec;
  spec.kind = "fabric";
  spec.seed = 7;
  spec.size_px = 48;
  spec.pixel_mm = 0.2;
  Result<Material> material = MakeSample(spec);
  EXPECT_TRUE(material.ok()) << material.status().ToString();
  const Scene scene(testing::ShippedRigModel("tac7-mini"), *std::move(material));
  std::vector<Observation> observations;
  for (int led : {0, 2, 4, 6, 8, 10}) {
    for (int camera : {0, 1}) observations.push_back({camera, {.leds = {{led, 1000}}}});
  }
  return RenderStack(scene, observations, {});
}

ScanEmulation Emulation(double cam1_along, double cam1_across, double noise) {
  return {.footprints = {{"cam0", 0.4, 0.4}, {"cam1", cam1_along, cam1_across}}, .gain_spread = 0, .noise = noise};
}

TEST(ScanEmulationTest, ANullEmulationChangesNothingAndUnseenPixelsStayUnseen) {
  ObservationStack stack = FabricStack();
  const int channel = ObservationStack::ObservationChannel(1);
  stack.image.at(channel, 5, 7) = NAN;
  const ObservationStack before = stack;
  ASSERT_TRUE(EmulateScan(Emulation(0, 0, 0), 3, stack).ok());
  for (int k = 0; k < static_cast<int>(stack.observations.size()); ++k) {
    if (stack.observations[k].camera != "cam1") continue;
    const auto a = stack.image.channel(ObservationStack::ObservationChannel(k));
    const auto b = before.image.channel(ObservationStack::ObservationChannel(k));
    for (size_t i = 0; i < a.size(); ++i) {
      if (std::isnan(b[i])) {
        EXPECT_TRUE(std::isnan(a[i]));
      } else {
        EXPECT_EQ(a[i], b[i]) << "observation " << k << " pixel " << i;
      }
    }
  }
  ASSERT_TRUE(EmulateScan(Emulation(0.8, 0.5, 0.05), 3, stack).ok());
  EXPECT_TRUE(std::isnan(stack.image.at(channel, 5, 7)));
  EXPECT_TRUE(std::isfinite(stack.image.at(channel, 5, 8)));
}

TEST(ScanEmulationTest, TheMatchRecoversTheFootprintsAndNoiseThatMadeAStack) {
  const ObservationStack fast = FabricStack();
  ObservationStack degraded = fast;
  ASSERT_TRUE(EmulateScan(Emulation(1.0, 0.3, 0.03), 11, degraded).ok());
  const Result<ScanEmulationMatch> match = MatchScanEmulation(fast, degraded);
  ASSERT_TRUE(match.ok()) << match.status().ToString();
  ASSERT_EQ(match->emulation.footprints.size(), 2u);
  const CameraFootprint& cam0 = match->emulation.footprints[0];
  const CameraFootprint& cam1 = match->emulation.footprints[1];
  EXPECT_EQ(cam1.camera, "cam1") << match->ToJson().dump(2);
  EXPECT_NEAR(cam0.along_px, 0.4, 0.15);
  EXPECT_NEAR(cam0.across_px, 0.4, 0.15);
  EXPECT_NEAR(cam1.along_px, 1.0, 0.15);  // cam1 is oblique: its footprint is stretched towards it
  EXPECT_NEAR(cam1.across_px, 0.3, 0.15);
  EXPECT_NEAR(match->emulation.noise, 0.03, 0.01);
  EXPECT_LT(match->emulation.gain_spread, 0.02);
  EXPECT_NEAR(match->distance_emulated, 1, 0.2);
  EXPECT_NEAR(match->high_frequency_emulated, 1, 0.3);
  EXPECT_GT(match->high_frequency_fast, 1.5);  // the fast path is sharper than its degradation
}

TEST(ScanEmulationTest, ACameraWithoutAFootprintIsNamedAndTheStackKept) {
  ObservationStack stack = FabricStack();
  const ObservationStack before = stack;
  ScanEmulation emulation = Emulation(0.8, 0.5, 0.05);
  emulation.footprints.pop_back();
  const Status status = EmulateScan(emulation, 1, stack);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.ToString().find("cam1"), std::string::npos) << status.ToString();
  const auto a = stack.image.channel(ObservationStack::ObservationChannel(0));
  const auto b = before.image.channel(ObservationStack::ObservationChannel(0));
  EXPECT_TRUE(std::equal(a.begin(), a.end(), b.begin()));
}

TEST(ScanEmulationTest, TheFileRoundTripsAndABadOneNamesItsKeys) {
  const std::filesystem::path path =
      std::filesystem::path(::testing::TempDir()) / ("scan_emulation_" + std::to_string(::getpid()) + ".yaml");
  const ScanEmulation written = Emulation(0.8, 0.5, 0.25);
  std::ofstream(path) << written.ToYaml();
  const Result<ScanEmulation> read = LoadScanEmulation(path);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->ToJson(), written.ToJson());

  // A file with `footprint` and `rest` is refused with an error naming each of `keys` and the file.
  const auto expect_refused = [&](const std::string& footprint, const std::string& rest, std::vector<std::string> keys) {
    std::ofstream(path) << "schema_version: 1\nfootprints:\n  - {camera: cam0, " << footprint << "}\n" << rest;
    const Result<ScanEmulation> bad = LoadScanEmulation(path);
    ASSERT_FALSE(bad.ok()) << footprint << rest;
    keys.push_back(path.string());
    for (const std::string& key : keys)
      EXPECT_NE(bad.status().ToString().find(key), std::string::npos) << bad.status().ToString();
  };
  expect_refused("along_px: .nan, across_px: 9", "gain_spread: 0.1\nnoize: 0.2\n", {"noize", "noise", "along_px"});
  expect_refused("along_px: -1, across_px: 9", "gain_spread: 0.1\nnoise: 0.2\n",
                 {"footprints[0].along_px", "footprints[0].across_px"});
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace loom::sim
