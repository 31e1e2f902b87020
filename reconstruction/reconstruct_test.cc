// ReconstructOptions are checked before a reconstruction starts: sizes and pixel sizes that would
// make it run for hours or divide by nothing are refused, each field named.
#include "reconstruction/reconstruct.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace loom::reconstruction {
namespace {

TEST(ReconstructOptionsTest, EveryBadValueIsRefusedNamingItsField) {
  EXPECT_TRUE(ReconstructOptions{}.Check().ok());
  ReconstructOptions bad;
  bad.width_px = 0;
  bad.pixel_mm = 1e-300;  // once a crash in the heightmap's blur (issue #24)
  bad.normal_blur_mm = std::nan("");
  bad.min_height_mm = 5;
  bad.max_height_mm = -5;
  bad.threads = -1;
  const Status status = bad.Check();
  ASSERT_FALSE(status.ok());
  for (const char* field : {"width_px", "pixel_mm", "normal_blur_mm", "min_height_mm", "threads"}) {
    EXPECT_NE(status.message().find(field), std::string::npos) << field << " in " << status.message();
  }
  ReconstructOptions huge;
  huge.width_px = kMaxStackSide + 1;
  EXPECT_FALSE(huge.Check().ok());
  ReconstructOptions nan_pixel;
  nan_pixel.pixel_mm = std::nan("");
  EXPECT_FALSE(nan_pixel.Check().ok());
}

// An 8 × 8 camera image, 0 but for one bright pixel at (3, 3).
Image Impulse() {
  Image image(8, 8, {"L"});
  image.at(0, 3, 3) = 1;
  return image;
}

TEST(SampleCameraTest, ACoarseCameraIsInterpolatedBicubicallyAFineOneBilinearly) {
  const Image image = Impulse();
  // Halfway between the bright pixel and its right-hand neighbour, and at its centre.
  const std::vector<Eigen::Vector2f> at = {{3.5f, 3}, {3, 3}};
  const std::vector<float> fine = SampleCamera(image, at, kFineSampling);
  const std::vector<float> coarse = SampleCamera(image, at, kFineSampling / 2);
  EXPECT_FLOAT_EQ(fine[0], 0.5f);  // the tent
  // Keys' cubic with OpenCV's a = −0.75: 0.59375 halfway; bilinear's tent would blur the peak
  // to 0.5 there.
  EXPECT_NEAR(coarse[0], 0.59375f, 1e-5);
  EXPECT_FLOAT_EQ(fine[1], 1.0f);
  EXPECT_FLOAT_EQ(coarse[1], 1.0f);
}

TEST(SampleCameraTest, ALinearRampComesBackToTheSubpixelResolutionAndTheCubicsPhaseError) {
  Image ramp(16, 16, {"L"});
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x) ramp.at(0, y, x) = static_cast<float>(2 * x + y);
  }
  // A stack-sized list of points (as a 630² stack asks for), all inside the image's interior.
  std::vector<Eigen::Vector2f> at(630 * 630);
  for (size_t i = 0; i < at.size(); ++i) at[i] = {3 + 9 * (i % 997) / 997.0f, 3 + 9 * (i % 991) / 991.0f};
  // Positions resolve to 1/32 px: at most 1/64 px off. The bilinear tent reproduces a ramp;
  // OpenCV's cubic (a = −0.75, not Keys' −0.5) moves it by up to 0.0481 px (at a quarter pixel),
  // a sixth of the cameras' calibration RMS (~0.3 px).
  const struct {
    double sampling;
    double phase_px;
  } cases[] = {{kFineSampling, 0}, {kFineSampling / 2, 0.0482}};
  for (const auto& c : cases) {
    const std::vector<float> values = SampleCamera(ramp, at, c.sampling);
    ASSERT_EQ(values.size(), at.size());
    double worst = 0;
    for (size_t i = 0; i < at.size(); ++i) worst = std::max(worst, std::abs(values[i] - (2.0 * at[i].x() + at[i].y())));
    EXPECT_LT(worst, 3 * (c.phase_px + 1.0 / 64) + 1e-4) << c.sampling;  // slopes 2 and 1
  }
}

TEST(SampleCameraTest, OffTheImageHiddenOrNextToAnUnreadPixelIsNaN) {
  Image image = Impulse();
  image.at(0, 5, 5) = std::nanf("");
  const std::vector<Eigen::Vector2f> at = {{-3, 2}, {20, 2}, {std::nanf(""), 2}, {5.5f, 5}, {1, 1}};
  for (double sampling : {kFineSampling, kFineSampling / 2}) {
    const std::vector<float> values = SampleCamera(image, at, sampling);
    for (size_t i = 0; i < 4; ++i) EXPECT_TRUE(std::isnan(values[i])) << i << " at " << sampling;
    EXPECT_FLOAT_EQ(values[4], 0.0f) << sampling;
  }
}
}  // namespace
}  // namespace loom::reconstruction
