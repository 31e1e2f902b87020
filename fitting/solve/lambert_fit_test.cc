#include "fitting/solve/lambert_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/geometry.h"

namespace loom::fitting {
namespace {

// One pixel under `count` directional lights spread over the upper hemisphere, a Lambertian
// surface of normal `n` and albedo `a` seen by three colour channels; light samples of
// irradiance 1.
std::vector<PixelObservation> LambertianPixel(const Eigen::Vector3d& n, const Eigen::Vector3d& a, int count) {
  std::vector<PixelObservation> observations;
  for (int k = 0; k < count; ++k) {
    const Eigen::Vector3d l = DirectionFromSpherical(DegToRad(10 + 60.0 * k / count), 2.4 * k);
    for (int c = 0; c < 3; ++c) {
      PixelObservation o;
      o.rgb_weights = Eigen::Vector3d::Unit(c);
      o.lights = {{l, 1.0}};
      o.radiance = a[c] / std::numbers::pi * std::max(0.0, n.dot(l));
      observations.push_back(o);
    }
  }
  return observations;
}

TEST(LambertFitTest, RecoversTheNormalAndAlbedoOfALambertianPixel) {
  const Eigen::Vector3d n = Eigen::Vector3d(0.3, -0.4, 0.8).normalized();
  const Eigen::Vector3d a(0.6, 0.4, 0.2);
  const std::optional<LambertPixel> fit = FitLambertPixel(LambertianPixel(n, a, 40), {});
  ASSERT_TRUE(fit.has_value());
  EXPECT_LT(RadToDeg(std::acos(std::min(1.0, fit->normal.dot(n)))), 0.01);
  EXPECT_LT((fit->albedo - a).norm(), 1e-6);
  EXPECT_LT(fit->rms, 1e-6);
  EXPECT_LT(fit->rms_all, 1e-6);  // nothing left out: the same
}

TEST(LambertFitTest, LeavesOutHighlightsAndCastShadowsByItsRule) {
  const Eigen::Vector3d n = Eigen::Vector3d(-0.2, 0.1, 1).normalized();
  const Eigen::Vector3d a(0.5, 0.5, 0.5);
  std::vector<PixelObservation> observations = LambertianPixel(n, a, 40);
  // Three views with a highlight 5× the diffuse, four in a cast shadow (black).
  for (int k : {3, 4, 5}) {
    for (int c = 0; c < 3; ++c) observations[3 * k + c].radiance *= 5;
  }
  for (int k : {10, 20, 30, 35}) {
    for (int c = 0; c < 3; ++c) observations[3 * k + c].radiance = 0;
  }
  const std::optional<LambertPixel> fit = FitLambertPixel(observations, {});
  ASSERT_TRUE(fit.has_value());
  EXPECT_LT(RadToDeg(std::acos(std::min(1.0, fit->normal.dot(n)))), 0.01);
  EXPECT_LT((fit->albedo - a).norm(), 1e-6);
  EXPECT_EQ(fit->observations_used, 3 * (40 - 7));
  // On every observation, as a GD10 fit is measured, the highlights and shadows count.
  EXPECT_LT(fit->rms, 1e-6);
  EXPECT_GT(fit->rms_all, 0.5);
  // Least squares on every observation is pulled off by them (what the rule is for).
  LambertFitOptions plain;
  plain.trim_dark = 0, plain.trim_bright = 1, plain.rounds = 0;
  const std::optional<LambertPixel> naive = FitLambertPixel(observations, plain);
  ASSERT_TRUE(naive.has_value());
  EXPECT_GT(RadToDeg(std::acos(std::min(1.0, naive->normal.dot(n)))), 1.0);
}

TEST(LambertFitTest, AGreyCameraLeavesTheAlbedoGreyAndTooFewObservationsFitNothing) {
  std::vector<PixelObservation> observations = LambertianPixel(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Constant(0.3), 10);
  for (PixelObservation& o : observations) o.rgb_weights = Eigen::Vector3d::Constant(1.0 / 3);
  for (PixelObservation& o : observations) o.radiance = 0.3 / std::numbers::pi * o.lights[0].l_local.z();
  const std::optional<LambertPixel> fit = FitLambertPixel(observations, {});
  ASSERT_TRUE(fit.has_value());
  EXPECT_NEAR(fit->albedo.x(), 0.3, 1e-6);
  EXPECT_NEAR(fit->albedo.z(), 0.3, 1e-6);
  observations.resize(2);
  EXPECT_FALSE(FitLambertPixel(observations, {}).has_value());
  LambertFitOptions bad;
  bad.trim_dark = 0.9;
  bad.min_observations = 1;
  const Status problems = bad.Check();
  EXPECT_NE(problems.message().find("trim_dark"), std::string::npos) << problems.ToString();
  EXPECT_NE(problems.message().find("min_observations"), std::string::npos) << problems.ToString();
}

}  // namespace
}  // namespace loom::fitting
