// The drift track on synthetic frames: ratios at one angle, the chain across a turntable move,
// interpolation between references, and a reference with nothing lit to compare.
#include "scan/light_drift.h"

#include <gtest/gtest.h>

namespace loom::scan {
namespace {

// A 16 × 16 Mono12 frame: black 64 DN, a lit square of `signal` DN above black, one saturated pixel.
RawFrame Frame(const std::string& camera, double signal) {
  RawFrame frame;
  frame.width = frame.height = 16;
  frame.pixels.assign(256, 64);
  for (int y = 4; y < 12; ++y) {
    for (int x = 4; x < 12; ++x) frame.pixels[y * 16 + x] = static_cast<uint16_t>(64 + signal);
  }
  frame.pixels[0] = 4095;
  frame.metadata.camera = camera;
  frame.metadata.pixel_format = PixelFormat::kMono12;
  return frame;
}

const std::map<std::string, DarkLevel> kDark = {{"a", {64, 1}}, {"b", {64, 1}}};

TEST(LightDriftTrackTest, RatiosChainAcrossTurntableMovesAndInterpolate) {
  LightDriftTrack track;
  EXPECT_DOUBLE_EQ(track.FactorAt(5), 1);  // no references: no drift
  ASSERT_DOUBLE_EQ(*track.Add(2, 0, {Frame("a", 1000), Frame("b", 2000)}, kDark), 1);
  ASSERT_NEAR(*track.Add(10, 0, {Frame("a", 980), Frame("b", 1960)}, kDark), 0.98, 1e-12);
  // The turntable moves: the next angle's first reference is taken as the last one's output.
  ASSERT_NEAR(*track.Add(11, 90, {Frame("a", 500), Frame("b", 700)}, kDark), 0.98, 1e-12);
  // Cameras are averaged: 0.98 × (0.95 + 0.97) / 2.
  ASSERT_NEAR(*track.Add(21, 90, {Frame("a", 475), Frame("b", 679)}, kDark), 0.98 * 0.96, 1e-12);
  EXPECT_DOUBLE_EQ(track.FactorAt(0), 1);  // before the first: the first's
  EXPECT_NEAR(track.FactorAt(6), 0.99, 1e-12);
  EXPECT_NEAR(track.FactorAt(16), 0.98 * (1 + 0.96) / 2, 1e-12);
  EXPECT_NEAR(track.FactorAt(99), 0.98 * 0.96, 1e-12);
  EXPECT_NEAR(track.MaxDriftPercent(), (1 - 0.98 * 0.96) * 100, 1e-9);
  EXPECT_EQ(track.references().size(), 4u);
}

TEST(LightDriftTrackTest, NothingLitToCompareIsAnErrorNamingTheStepAndCamera) {
  LightDriftTrack track;
  const Result<double> dark = track.Add(7, 0, {Frame("a", 0)}, kDark);
  ASSERT_FALSE(dark.ok());
  EXPECT_NE(dark.status().ToString().find("step 7"), std::string::npos) << dark.status().ToString();
  EXPECT_NE(dark.status().ToString().find("camera 'a'"), std::string::npos) << dark.status().ToString();
}

}  // namespace
}  // namespace loom::scan
