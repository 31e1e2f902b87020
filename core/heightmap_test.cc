#include "core/heightmap.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/check.h"

namespace loom {
namespace {

TEST(HeightmapTest, InterpolatesBetweenPixelCentresAndIsZeroOffTheGrid) {
  // 2 × 1 pixels of 1 mm: centres at x = −0.5 and +0.5.
  const Heightmap map({1.0f, 3.0f}, 2, 1, 1.0);
  EXPECT_DOUBLE_EQ(map.HeightAt(0.0, 0.0), 2.0);
  EXPECT_DOUBLE_EQ(map.HeightAt(-0.5, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(map.HeightAt(10.0, 0.0), 0.0);
  EXPECT_EQ(map.max_height_mm(), 3.0);
}

TEST(HeightmapTest, AWallCastsAShadowOnlyOnItsFarSide) {
  // A 2 mm wall at x ∈ [0, 1) mm on a 10 mm wide flat grid.
  std::vector<float> heights(40 * 40, 0.0f);
  for (int y = 0; y < 40; ++y) {
    for (int x = 20; x < 24; ++x) heights[y * 40 + x] = 2.0f;
  }
  const Heightmap map(heights, 40, 40, 0.25);
  const Eigen::Vector3d light(500, 0, 500);               // 45° from +x
  EXPECT_TRUE(map.Shadowed({-1.0, 0, 0}, light));         // behind the wall, within its 2 mm shadow
  EXPECT_FALSE(map.Shadowed({-3.0, 0, 0}, light));        // beyond the shadow
  EXPECT_FALSE(map.Shadowed({2.0, 0, 0}, light));         // on the lit side
  EXPECT_TRUE(map.Shadowed({2.0, 0, 0}, {-500, 0, -1}));  // below the horizon
}

// The march without blocks: every half-pixel sample (t = t_first + k·dt) up to the highest
// point, as Shadowed was before it skipped any.
bool ShadowedByMarchingEverySample(const Heightmap& map, const Eigen::Vector3d& p, const Eigen::Vector3d& light,
                                   double pixel_mm) {
  const Eigen::Vector3d s = (light - p).normalized();
  if (s.z() <= 0) return true;
  const double t_max = (map.max_height_mm() - p.z()) / s.z();
  const double dt = 0.5 * pixel_mm / std::max(s.head<2>().norm(), 1e-9);
  const double t_first = std::min(dt, t_max) * 0.5;
  for (double k = 0, t = t_first; t < t_max; t = t_first + ++k * dt) {
    const Eigen::Vector3d q = p + t * s;
    if (q.z() < map.HeightAt(q.x(), q.y()) - 1e-4) return true;
  }
  return false;
}

// The camera's march without blocks: every half-pixel sample down from the highest point,
// bisected where it first is below the surface.
Eigen::Vector3d FirstHitByMarchingEverySample(const Heightmap& map, const Eigen::Vector3d& origin,
                                              const Eigen::Vector3d& direction, double pixel_mm) {
  const double t_top = std::max(0.0, (map.max_height_mm() + 1e-6 - origin.z()) / direction.z());
  const double t_bottom = -origin.z() / direction.z();
  const double dt = 0.5 * pixel_mm / std::max(direction.head<2>().norm(), 1e-9);
  const auto below = [&](double t) {
    const Eigen::Vector3d p = origin + t * direction;
    return p.z() <= map.HeightAt(p.x(), p.y());
  };
  double previous = t_top;
  for (double k = 1;; ++k) {
    const double tt = std::min(t_top + k * dt, t_bottom);
    if (below(tt)) {
      double lo = previous, hi = tt;
      while (hi - lo > 1e-5) (below(0.5 * (lo + hi)) ? hi : lo) = 0.5 * (lo + hi);
      return origin + hi * direction;
    }
    if (tt >= t_bottom) return origin + t_bottom * direction;
    previous = tt;
  }
}

// Rough bumps with a plateau and a pit below the holder, on a grid whose size is no multiple
// of any block tried.
std::vector<float> RoughHeights(int w, int h, std::mt19937& random) {
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<float> heights(w * h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      float z = static_cast<float>(0.3 * std::sin(0.7 * x) * std::cos(0.5 * y) + 0.05 * unit(random));
      if (x > 30 && y > 25) z = 1.5f;  // a plateau
      if (x < 6 && y < 6) z = -0.4f;   // a pit
      heights[y * w + x] = z;
    }
  }
  return heights;
}

constexpr int kW = 45, kH = 38;
constexpr double kPixelMm = 0.2;
constexpr int kBlockSizesPx[] = {1, 3, 8, 64};

// A surface point on or off the rough grid (up to 20 % beyond its edges).
Eigen::Vector3d RandomSurfacePoint(const Heightmap& map, std::mt19937& random) {
  std::uniform_real_distribution<double> unit(0, 1);
  const double x = (unit(random) - 0.5) * 1.4 * kW * kPixelMm;
  const double y = (unit(random) - 0.5) * 1.4 * kH * kPixelMm;
  return {x, y, map.HeightAt(x, y)};
}

// A light 400 mm from p, from slightly below the horizon to overhead; its elevation in *elevation.
Eigen::Vector3d RandomLight(const Eigen::Vector3d& p, std::mt19937& random, double* elevation) {
  std::uniform_real_distribution<double> unit(0, 1);
  *elevation = std::asin(unit(random) * 1.05 - 0.05);
  const double azimuth = 2 * M_PI * unit(random);
  return p + 400.0 * Eigen::Vector3d(std::cos(*elevation) * std::cos(azimuth), std::cos(*elevation) * std::sin(azimuth),
                                     std::sin(*elevation));
}

TEST(HeightmapTest, SkippingBlocksGivesTheFullMarchsShadows) {
  // Surface points on and off the grid, lights from below the horizon to overhead.
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(0, 1);
  const std::vector<float> heights = RoughHeights(kW, kH, random);
  for (int block_px : kBlockSizesPx) {
    const Heightmap map(heights, kW, kH, kPixelMm, block_px);
    int shadowed = 0;
    for (int k = 0; k < 20000; ++k) {
      const Eigen::Vector3d p = RandomSurfacePoint(map, random);
      double elevation = 0;
      const Eigen::Vector3d light = RandomLight(p, random, &elevation);
      const bool expected = ShadowedByMarchingEverySample(map, p, light, kPixelMm);
      ASSERT_EQ(map.Shadowed(p, light), expected) << "block " << block_px << ", ray " << k << " from " << p.transpose();
      shadowed += expected;
    }
    // Both answers occur often enough to matter.
    EXPECT_GT(shadowed, 2000) << block_px;
    EXPECT_LT(shadowed, 18000) << block_px;
  }
}

TEST(HeightmapTest, TheHorizonBoundGivesTheFullMarchsShadows) {
  // Points on the rough grid (the pit below the holder included), each with its bound computed
  // once and lights from below the horizon to overhead.
  std::mt19937 random(9);
  std::uniform_real_distribution<double> unit(0, 1);
  const std::vector<float> heights = RoughHeights(kW, kH, random);
  for (int block_px : kBlockSizesPx) {
    const Heightmap map(heights, kW, kH, kPixelMm, block_px);
    int shadowed = 0, cleared = 0;
    for (int point = 0; point < 1000; ++point) {
      const Eigen::Vector3d p = RandomSurfacePoint(map, random);
      const Heightmap::Horizon horizon = map.HorizonAt(p);
      for (int k = 0; k < 40; ++k) {
        double elevation = 0;
        const Eigen::Vector3d light = RandomLight(p, random, &elevation);
        const bool expected = ShadowedByMarchingEverySample(map, p, light, kPixelMm);
        ASSERT_EQ(map.Shadowed(p, light, horizon), expected)
            << "block " << block_px << ", light " << k << " from " << p.transpose();
        shadowed += expected;
        cleared += horizon.Clears(light - p);
      }
    }
    EXPECT_GT(shadowed, 2000) << block_px;
    EXPECT_GT(cleared, 1000) << block_px;  // the bound does skip marches, even on this relief
  }
}

TEST(HeightmapTest, OnAFabricsReliefTheHorizonBoundClearsMostLights) {
  // Threads 0.1 mm high every 0.8 mm, 0.05 mm pixels: lights above 25° need no march.
  std::vector<float> heights(160 * 160);
  for (int y = 0; y < 160; ++y) {
    for (int x = 0; x < 160; ++x) heights[y * 160 + x] = static_cast<float>(0.05 + 0.05 * std::sin(x * 0.4) * std::sin(y * 0.4));
  }
  const Heightmap map(heights, 160, 160, 0.05);
  std::mt19937 random(3);
  std::uniform_real_distribution<double> unit(0, 1);
  int above = 0, cleared = 0;
  for (int point = 0; point < 2000; ++point) {
    const double x = (unit(random) - 0.5) * 7.0, y = (unit(random) - 0.5) * 7.0;
    const Eigen::Vector3d p(x, y, map.HeightAt(x, y));
    const double azimuth = 2 * M_PI * unit(random), elevation = 25 * M_PI / 180;
    const Eigen::Vector3d to_light(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                                   std::sin(elevation));
    cleared += map.HorizonAt(p).Clears(to_light);
    ++above;
  }
  EXPECT_GT(cleared, 0.9 * above);
}

TEST(HeightmapTest, AlongParallelThreadsTheHorizonIsLowerThanAcrossThem) {
  // Ridges along x, 0.1 mm high every 0.8 mm (slopes up to 22°): a light 8° up clears them
  // looking along the threads (within 10°) from most points, across them from far fewer. One
  // bound for every azimuth, the steepest slope, cleared none of either.
  std::vector<float> heights(160 * 160);
  for (int y = 0; y < 160; ++y) {
    for (int x = 0; x < 160; ++x) heights[y * 160 + x] = static_cast<float>(0.05 + 0.05 * std::sin(y * 0.4));
  }
  const Heightmap map(heights, 160, 160, 0.05);
  std::mt19937 random(5);
  std::uniform_real_distribution<double> unit(0, 1);
  int along = 0, across = 0, points = 0;
  for (int point = 0; point < 1000; ++point) {
    const double x = (unit(random) - 0.5) * 7.0, y = (unit(random) - 0.5) * 7.0;
    const Eigen::Vector3d p(x, y, map.HeightAt(x, y));
    const Heightmap::Horizon horizon = map.HorizonAt(p);
    const double spread = (unit(random) - 0.5) * 20 * M_PI / 180, elevation = 8 * M_PI / 180;
    const auto towards = [&](double azimuth) {
      return Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                             std::sin(elevation));
    };
    const double azimuth_along = (point % 2 ? M_PI : 0) + spread, azimuth_across = (point % 2 ? -M_PI : M_PI) / 2 + spread;
    along += horizon.Clears(towards(azimuth_along));
    across += horizon.Clears(towards(azimuth_across));
    for (const double azimuth : {azimuth_along, azimuth_across}) {
      const Eigen::Vector3d light = p + 400 * towards(azimuth);
      ASSERT_EQ(map.Shadowed(p, light, horizon), ShadowedByMarchingEverySample(map, p, light, 0.05)) << p.transpose();
    }
    ++points;
  }
  EXPECT_GT(along, 0.7 * points);    // 788 of 1000
  EXPECT_LT(across, 0.45 * points);  // 338
}

TEST(HeightmapTest, SkippingBlocksGivesTheFullMarchsFirstHits) {
  // Camera rays from 300 mm, from straight down to grazing, aimed on and off the grid.
  std::mt19937 random(11);
  std::uniform_real_distribution<double> unit(0, 1);
  const std::vector<float> heights = RoughHeights(kW, kH, random);
  for (int block_px : kBlockSizesPx) {
    const Heightmap map(heights, kW, kH, kPixelMm, block_px);
    int on_the_grid = 0;
    for (int k = 0; k < 20000; ++k) {
      const Eigen::Vector3d aim((unit(random) - 0.5) * 1.4 * kW * kPixelMm, (unit(random) - 0.5) * 1.4 * kH * kPixelMm, 0);
      const double elevation = std::acos(unit(random) * 0.97), azimuth = 2 * M_PI * unit(random);
      const Eigen::Vector3d towards_eye(std::sin(elevation) * std::cos(azimuth), std::sin(elevation) * std::sin(azimuth),
                                        std::cos(elevation));
      const Eigen::Vector3d eye = aim + 300.0 * towards_eye;
      const Eigen::Vector3d expected = FirstHitByMarchingEverySample(map, eye, -towards_eye, kPixelMm);
      ASSERT_EQ(map.FirstHit(eye, -towards_eye), expected) << "block " << block_px << ", ray " << k;
      on_the_grid += std::abs(expected.x()) < kW * kPixelMm / 2 && std::abs(expected.y()) < kH * kPixelMm / 2;
    }
    EXPECT_GT(on_the_grid, 8000) << block_px;
  }
  EXPECT_THROW(Heightmap(heights, kW, kH, kPixelMm).FirstHit({0, 0, 10}, {0, 0, 1}), CheckError);
}

// A calibration target's board (a plane tilted 25° about x, its centre 8 mm up) and a white tile
// (flat, 5 mm up): planar, so Shadowed takes the plane's shortcut; it must give the full march's
// answer from points on the grid and off it, and from a camera ray's hit (FirstHit stops within
// its bisection's tolerance of the surface).
TEST(HeightmapTest, OnAPlaneTheShortcutGivesTheFullMarchsShadows) {
  constexpr int kPlaneW = 70, kPlaneH = 56;
  constexpr double kPlanePixelMm = 0.1;
  const double slope = std::tan(25 * M_PI / 180);
  std::vector<float> board(kPlaneW * kPlaneH), tile(kPlaneW * kPlaneH, 5.0f);
  for (int y = 0; y < kPlaneH; ++y) {
    for (int x = 0; x < kPlaneW; ++x)
      board[y * kPlaneW + x] = static_cast<float>(8 + (y + 0.5 - kPlaneH / 2.0) * kPlanePixelMm * slope);
  }
  std::mt19937 random(17);
  std::uniform_real_distribution<double> unit(0, 1);
  for (const std::vector<float>* heights : {&board, &tile}) {
    const Heightmap map(*heights, kPlaneW, kPlaneH, kPlanePixelMm);
    ASSERT_TRUE(map.planar());
    int shadowed = 0;
    for (int k = 0; k < 20000; ++k) {
      const double x = (unit(random) - 0.5) * 1.4 * kPlaneW * kPlanePixelMm;
      const double y = (unit(random) - 0.5) * 1.4 * kPlaneH * kPlanePixelMm;
      Eigen::Vector3d p(x, y, map.HeightAt(x, y));
      if (k % 2 == 1) p = map.FirstHit(p + Eigen::Vector3d(30, -20, 400), Eigen::Vector3d(-30, 20, -400).normalized());
      double elevation = 0;
      const Eigen::Vector3d light = RandomLight(p, random, &elevation);
      const bool expected = ShadowedByMarchingEverySample(map, p, light, kPlanePixelMm);
      ASSERT_EQ(map.Shadowed(p, light), expected) << "ray " << k << " from " << p.transpose();
      shadowed += expected;
    }
    EXPECT_GT(shadowed, 1000);
    EXPECT_LT(shadowed, 19000);
  }
}

TEST(HeightmapTest, OnlyAPlaneAboveItsHolderIsPlanar) {
  std::mt19937 random(7);
  EXPECT_FALSE(Heightmap(RoughHeights(kW, kH, random), kW, kH, kPixelMm).planar());
  // A plane down to the holder at one edge: the blend to the holder's 0 around the grid rises
  // above the plane's extension there.
  std::vector<float> reaching_the_holder(kW * kH);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) reaching_the_holder[y * kW + x] = static_cast<float>(0.01 * x);
  }
  EXPECT_FALSE(Heightmap(reaching_the_holder, kW, kH, kPixelMm).planar());
  std::vector<float> flat_on_the_holder(kW * kH, 0.0f);
  EXPECT_TRUE(Heightmap(flat_on_the_holder, kW, kH, kPixelMm).planar());
}

TEST(HeightmapTest, OverTallObjectsThePyramidGivesTheFullMarchs) {
  // A calibration scan's objects: a wedge rising 4 mm and a sphere 6 mm tall beside it, on a
  // grid many blocks wide, where rays far above the surface cross coarse pyramid levels.
  constexpr int kSide = 150;
  constexpr double kFinePixelMm = 0.1;
  std::vector<float> heights(kSide * kSide, 0.0f);
  for (int y = 0; y < kSide; ++y) {
    for (int x = 0; x < kSide; ++x) {
      const double cx = (x - 110) * kFinePixelMm, cy = (y - 75) * kFinePixelMm, rho2 = cx * cx + cy * cy;
      if (x < 70) heights[y * kSide + x] = static_cast<float>(1 + 3.0 * y / kSide);
      if (rho2 < 9) heights[y * kSide + x] = static_cast<float>(3 + std::sqrt(9 - rho2));
    }
  }
  const Heightmap map(heights, kSide, kSide, kFinePixelMm);
  std::mt19937 random(13);
  std::uniform_real_distribution<double> unit(0, 1);
  int shadowed = 0;
  for (int k = 0; k < 20000; ++k) {
    const double x = (unit(random) - 0.5) * 1.2 * kSide * kFinePixelMm, y = (unit(random) - 0.5) * 1.2 * kSide * kFinePixelMm;
    const Eigen::Vector3d p(x, y, map.HeightAt(x, y));
    double elevation = 0;
    const Eigen::Vector3d light = RandomLight(p, random, &elevation);
    const bool expected = ShadowedByMarchingEverySample(map, p, light, kFinePixelMm);
    ASSERT_EQ(map.Shadowed(p, light), expected) << "ray " << k << " from " << p.transpose();
    shadowed += expected;
    const Eigen::Vector3d eye = p + 300.0 * (light - p).normalized();
    if (eye.z() > 10) {
      const Eigen::Vector3d towards = (p - eye).normalized();
      ASSERT_EQ(map.FirstHit(eye, towards), FirstHitByMarchingEverySample(map, eye, towards, kFinePixelMm)) << "ray " << k;
    }
  }
  EXPECT_GT(shadowed, 2000);
  EXPECT_LT(shadowed, 18000);
}

}  // namespace
}  // namespace loom
