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

TEST(LambertFitTest, AColouredAlbedoIsNotTrimmedByColour) {
  // A pixel of a simulated flash capture of a blue twill (`loom sim capture --layout flash
  // --images 9 --size 256`, imported with `--downsample 4`): eight photographs, each its
  // irradiance vector (local frame) and R, G, B radiances. Each colour's shading ratios lie apart
  // by the albedo's colour; ranked together, the first fit kept the red observations and a few
  // others, mixed colours under one chromaticity, and found a normal facing away (no fit).
  const struct {
    Eigen::Vector3d irradiance, rgb;
  } views[] = {
      {{1.279, 1.203, 1.623}, {0.0308, 0.0245, 0.0807}}, {{1.286, 1.019, 1.375}, {0.0260, 0.0208, 0.0685}},
      {{1.417, 1.012, 1.588}, {0.0301, 0.0240, 0.0789}}, {{1.475, 1.112, 1.871}, {0.0355, 0.0281, 0.0929}},
      {{1.384, 1.289, 2.023}, {0.0382, 0.0306, 0.1006}}, {{1.101, 1.361, 1.610}, {0.0305, 0.0243, 0.0803}},
      {{1.093, 1.232, 1.387}, {0.0263, 0.0208, 0.0689}}, {{1.164, 1.103, 1.305}, {0.0248, 0.0197, 0.0651}},
  };
  std::vector<PixelObservation> observations;
  for (const auto& view : views) {
    for (int c = 0; c < 3; ++c) {
      PixelObservation o;
      o.rgb_weights = Eigen::Vector3d::Unit(c);
      o.lights = {{view.irradiance.normalized(), view.irradiance.norm()}};
      o.radiance = view.rgb[c];
      observations.push_back(o);
    }
  }
  const std::optional<LambertPixel> fit = FitLambertPixel(observations, {});
  ASSERT_TRUE(fit.has_value());
  // The twill lies flat: its normal up, its albedo blue, the views fitted to a fraction of a percent.
  EXPECT_LT(RadToDeg(std::acos(std::min(1.0, fit->normal.z()))), 2.0);
  EXPECT_GT(fit->albedo.z(), 2 * fit->albedo.x());
  EXPECT_GE(fit->observations_used, 15);
  EXPECT_LT(fit->rms, 0.01);
}

TEST(LambertFitTest, WithTheFallbackAPixelWithoutANormalGetsItsAlbedoUnderTheGeometricNormal) {
  // Every view lit from one direction: the observations determine no normal.
  std::vector<PixelObservation> observations = LambertianPixel(Eigen::Vector3d::UnitZ(), Eigen::Vector3d(0.6, 0.4, 0.2), 10);
  const Eigen::Vector3d light = Eigen::Vector3d(0.2, 0.1, 1).normalized();
  for (PixelObservation& o : observations) {
    o.lights = {{light, 1.0}};
    o.radiance = o.rgb_weights.dot(Eigen::Vector3d(0.6, 0.4, 0.2)) / std::numbers::pi * light.z();
  }
  EXPECT_FALSE(FitLambertPixel(observations, {}).has_value());
  const std::optional<LambertPixel> fit = FitLambertPixel(observations, {.geometric_normal_fallback = true});
  ASSERT_TRUE(fit.has_value());
  EXPECT_FALSE(fit->normal_fitted);
  EXPECT_EQ(fit->normal, Eigen::Vector3d::UnitZ());
  EXPECT_LT((fit->albedo - Eigen::Vector3d(0.6, 0.4, 0.2)).norm(), 1e-6);
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
