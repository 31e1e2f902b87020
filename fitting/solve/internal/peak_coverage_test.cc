// Whether a pixel's observations see its lobe's peak, on the layouts where it decides: a camera
// looking down under a ring of directional lights, with normals inside, on and beyond the ring of
// half-vectors they make.
#include "fitting/solve/internal/peak_coverage.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "core/geometry.h"

namespace loom::fitting::internal {
namespace {

// A unit vector `tilt_deg` from +z, turned `azimuth_deg` about it.
Eigen::Vector3d Direction(double tilt_deg, double azimuth_deg) {
  const double t = DegToRad(tilt_deg), a = DegToRad(azimuth_deg);
  return {std::sin(t) * std::cos(a), std::sin(t) * std::sin(a), std::cos(t)};
}

// An orthographic view from above, lit from `count` directions `tilt_deg` from the view: their
// half-vectors lie on a ring `tilt_deg / 2` from the view.
std::vector<PixelObservation> RingOfLights(int count, double tilt_deg) {
  std::vector<PixelObservation> observations;
  for (int k = 0; k < count; ++k) {
    PixelObservation o;
    o.radiance = 1;
    o.lights = {{Direction(tilt_deg, 360.0 * k / count), 1.0}};
    observations.push_back(o);
  }
  return observations;
}

TEST(PeakCoverageTest, IsTheAngleToTheRingOfHalfVectorsInsideAndNegativeBeyondIt) {
  const std::vector<PixelObservation> ring = RingOfLights(64, 60);  // half-vectors 30° from the view
  EXPECT_NEAR(RadToDeg(PeakCoverage(Eigen::Vector3d::UnitZ(), ring)), 30, 0.5);
  EXPECT_NEAR(RadToDeg(PeakCoverage(Direction(20, 45), ring)), 10, 1.5);
  EXPECT_NEAR(PeakCoverage(Direction(30, 10), ring), 0, DegToRad(0.5));
  EXPECT_LT(RadToDeg(PeakCoverage(Direction(45, 200), ring)), -10);
}

TEST(PeakCoverageTest, AStripCountsAsItsBrightestSample) {
  std::vector<PixelObservation> ring = RingOfLights(16, 60);
  for (PixelObservation& o : ring) o.lights.push_back({Eigen::Vector3d::UnitZ(), 0.5});  // dimmer, at the view
  EXPECT_GT(RadToDeg(PeakCoverage(Eigen::Vector3d::UnitZ(), ring)), 25);
  for (PixelObservation& o : ring) o.lights.back().irradiance = 2;  // brighter: every half-vector at the view
  EXPECT_EQ(PeakCoverage(Eigen::Vector3d::UnitZ(), ring), -kPi / 2);
}

TEST(PeakCoverageTest, UnseenObservationsAndTooFewHalfVectorsSpanNoCone) {
  std::vector<PixelObservation> ring = RingOfLights(8, 60);
  for (int k = 0; k < 6; ++k) ring[k].radiance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(PeakCoverage(Eigen::Vector3d::UnitZ(), ring), -kPi / 2);
  EXPECT_EQ(PeakCoverage(Eigen::Vector3d::UnitZ(), {}), -kPi / 2);
}

}  // namespace
}  // namespace loom::fitting::internal
