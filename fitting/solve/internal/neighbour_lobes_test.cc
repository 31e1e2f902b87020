// The smoothing pass's target lobes on a weave of two yarns whose anisotropy angles differ by
// 90°, two pixels wide each, as tac7-mini's stacks see a fabric.
#include "fitting/solve/internal/neighbour_lobes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/geometry.h"
#include "fitting/model/svbrdf_maps.h"

namespace loom::fitting::internal {
namespace {

constexpr int kSize = 12;

// Pairs of columns alternate between the yarns: α 45°, 45°, 135°, 135°, 45°, …
double YarnAlpha(int x) { return DegToRad(x / 2 % 2 == 0 ? 45.0 : 135.0); }

// The angle between two anisotropy angles, in degrees (a lobe is the same turned by 180°).
double AxialDistanceDeg(double a, double b) {
  const double d = std::fmod(std::abs(a - b), kPi);
  return RadToDeg(std::min(d, kPi - d));
}

WardParams<double> Lobe(double alpha, double sigma_x) {
  WardParams<double> p;
  p.a_s = Eigen::Vector3d::Constant(0.2);
  p.sigma_x = sigma_x;
  p.sigma_y = 0.1;
  p.alpha = alpha;
  p.f0 = 1;
  return p;
}

// Per-pixel fits of the weave: each pixel's yarn angle off by up to ±`noise_deg`.
std::vector<WardParams<double>> NoisyFits(double noise_deg, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> off(-noise_deg, noise_deg);
  std::vector<WardParams<double>> fits;
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) fits.push_back(Lobe(YarnAlpha(x) + DegToRad(off(random)), 0.3));
  }
  return fits;
}

// A guide that knows the yarns, though not their angles exactly (±15°), as the CNN's maps do.
Image GuideMaps() {
  std::mt19937 random(5);
  std::uniform_real_distribution<double> off(-15, 15);
  Image maps = MakeSvbrdfImage(kSize, kSize, /*with_height=*/false);
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) SetParams(maps, x, y, Lobe(YarnAlpha(x) + DegToRad(off(random)), 0.3));
  }
  return maps;
}

double WorstInteriorErrorDeg(const std::vector<WardParams<double>>& lobes) {
  double worst = 0;
  for (int y = kSmoothingRadius; y < kSize - kSmoothingRadius; ++y) {
    for (int x = kSmoothingRadius; x < kSize - kSmoothingRadius; ++x) {
      worst = std::max(worst, AxialDistanceDeg(lobes[static_cast<size_t>(y) * kSize + x].alpha, YarnAlpha(x)));
    }
  }
  return worst;
}

// Unguided, each pixel's neighbourhood holds both yarns, whose 2α are opposite, and the one with
// more pixels there wins: a 5 × 5 square holds 15 of the other yarn's and 9 of the pixel's own,
// or 10 and 14. Guided by maps that tell the yarns apart, each pixel gets its own yarn's angle.
TEST(NeighbourLobesTest, AGuideKeepsEachYarnsAnisotropyAngle) {
  const std::vector<WardParams<double>> fits = NoisyFits(20, 1);
  const Image guide = GuideMaps();
  const double unguided = WorstInteriorErrorDeg(NeighbourLobes(fits, kSize, kSize, nullptr));
  const double guided = WorstInteriorErrorDeg(NeighbourLobes(fits, kSize, kSize, &guide));
  std::cout << "worst alpha error: unguided " << unguided << " deg, guided " << guided << " deg\n";
  EXPECT_GT(unguided, 40);
  EXPECT_LT(guided, 12);
}

// Without a guide the lobe is the neighbours' median, the pixel itself left out, and a lobe
// written with σx < σy counts as the same lobe turned by 90°.
TEST(NeighbourLobesTest, UnguidedTheLobeIsTheNeighboursMedian) {
  std::vector<WardParams<double>> fits;
  for (int i = 0; i < 9; ++i) fits.push_back(Lobe(DegToRad(30), 0.2 + 0.01 * i));
  fits[4].sigma_x = 5;                                                    // the centre: left out
  std::swap(fits[0].sigma_x, fits[0].sigma_y), fits[0].alpha += kPi / 2;  // the same lobe
  const std::vector<WardParams<double>> lobes = NeighbourLobes(fits, 3, 3, nullptr);
  const WardParams<double>& centre = lobes[4];
  EXPECT_EQ(centre.sigma_x, fits[5].sigma_x);  // of 0.20 … 0.28 without 0.24: the upper median
  EXPECT_DOUBLE_EQ(centre.sigma_y, 0.1);
  EXPECT_NEAR(AxialDistanceDeg(centre.alpha, DegToRad(30)), 0, 1e-9);
  EXPECT_DOUBLE_EQ(centre.a_s.y(), 0.2);
}

}  // namespace
}  // namespace loom::fitting::internal
