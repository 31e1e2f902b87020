#include "sim/object_capture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace loom::sim {
namespace {

// A Lambertian sphere's pixel (i, j) under `light` (x right, y up, z towards the camera), channel
// R, integrated over its footprint on a fine grid: a_d(u, v)/π · max(0, n·l), 0 off the sphere.
// Also the share of the footprint the sphere covers.
struct Footprint {
  double radiance = 0, coverage = 0;
};
Footprint IntegrateLambertianSpherePixel(const ObjectCaptureOptions& options, int i, int j, const Eigen::Vector3d& light) {
  constexpr int kSteps = 128;
  const int n = options.size_px;
  const double radius_px = 0.45 * n;
  Footprint sum;
  for (int b = 0; b < kSteps; ++b) {
    for (int a = 0; a < kSteps; ++a) {
      const double u = (i + (a + 0.5) / kSteps - n / 2.0) / radius_px, v = -(j + (b + 0.5) / kSteps - n / 2.0) / radius_px;
      const double r2 = u * u + v * v;
      if (r2 >= 1) continue;
      const Eigen::Vector3d normal(u, v, std::sqrt(1 - r2));
      const double a_d = options.material.a_d[0] * (0.8 + 0.2 * std::sin(6 * u + 3 * v));
      sum.radiance += a_d / std::numbers::pi * std::max(0.0, normal.dot(light));
      sum.coverage += 1;
    }
  }
  sum.radiance /= kSteps * kSteps;
  sum.coverage /= kSteps * kSteps;
  return sum;
}

// With subpixels a pixel is the mean over its footprint, the background counting 0: on the
// silhouette, where a centre sample is far off, and inside, where the normal turns across it.
TEST(ObjectCaptureTest, SubpixelsMakeEachPixelTheMeanOverItsFootprint) {
  ObjectCaptureOptions options;
  options.size_px = 32;
  options.lights = 3;
  options.material.a_s = Eigen::Vector3d::Zero();
  ObjectCaptureOptions centres = options;
  options.subpixels = 16;
  const ObjectCapture integrated = RenderObjectCapture(options), sampled = RenderObjectCapture(centres);
  const Eigen::Vector3d& light = integrated.light_directions[1];
  int edge_pixels = 0;
  for (int j = 0; j < 32; ++j) {
    for (int i = 0; i < 32; ++i) {
      if (integrated.mask.at(0, j, i) == 0) continue;
      const Footprint truth = IntegrateLambertianSpherePixel(options, i, j, light);
      const double value = integrated.images[1].at(0, j, i);
      EXPECT_NEAR(value, truth.radiance, 0.01 * truth.radiance + 1e-4) << "pixel " << i << ", " << j;
      if (truth.coverage < 0.7 && truth.radiance > 0.02) {
        ++edge_pixels;
        EXPECT_GT(std::abs(sampled.images[1].at(0, j, i) - truth.radiance), 0.1 * truth.radiance)
            << "pixel " << i << ", " << j << ": a centre sample should miss the background it covers";
      }
    }
  }
  EXPECT_GT(edge_pixels, 4);
  EXPECT_EQ(integrated.mask.at(0, 16, 16), sampled.mask.at(0, 16, 16));
  EXPECT_EQ(integrated.truth.at(3, 16, 16), sampled.truth.at(3, 16, 16)) << "the truth stays the pixel centre's";
}

TEST(ObjectCaptureTest, SubpixelsOutsideTheirRangeAreRefusedNamingTheField) {
  for (int subpixels : {0, 17}) {
    ObjectCaptureOptions options;
    options.subpixels = subpixels;
    const Status status = options.Check();
    EXPECT_NE(status.ToString().find("subpixels"), std::string::npos) << subpixels;
  }
}

}  // namespace
}  // namespace loom::sim
