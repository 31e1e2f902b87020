// Drift of a stored calibration, on synthetic target views of a rig that was (or was not)
// disturbed after its calibration. The target is placed anew, as an operator would: turned 3°
// and shifted, which must not count as drift.
#include "calibration/drift.h"

#include <gtest/gtest.h>

#include "calibration/testing/synthetic_views.h"

namespace loom::calibration {
namespace {

using testing::SyntheticNominalRig;
using testing::SyntheticViews;
using testing::WithSideCameraNudged;

const TargetPlacement kPlacedAgain{Eigen::Vector2d(1.0, -0.5), 3.0};
// What the corner detector leaves on the simulated target (geometry_test.cc).
constexpr double kCornerNoisePx = 0.25;

std::string Describe(const DriftReport& report) {
  std::ostringstream text;
  for (const CameraDrift& c : report.cameras) {
    text << c.name << ": stored " << c.stored_rms_px << " px, fresh " << c.fresh_rms_px << " px, drift " << c.drift_px << " px, "
         << c.rotation_deg << " deg, " << c.centre_mm << " mm, axis " << c.axis_tilt_deg << " deg " << c.axis_shift_mm << " mm;";
    for (const std::string& e : c.exceeded) text << " [" << e << "]";
    text << "\n";
  }
  return text.str();
}

TEST(DriftTest, AnUndisturbedRigHoldsItsCalibrationWhereverTheTargetLies) {
  const RigModel rig = SyntheticNominalRig();
  const CalibrationTargetModel target;
  const Result<DriftReport> report = MeasureDrift(rig, target, SyntheticViews(rig, target, kPlacedAgain, kCornerNoisePx), {});
  ASSERT_TRUE(report.ok()) << report.status().ToString();
  std::cout << Describe(*report);
  EXPECT_FALSE(report->recalibrate) << Describe(*report);
  EXPECT_NEAR(report->placement.yaw_deg, 3.0, 0.05);
  EXPECT_NEAR(report->placement.offset_mm.x(), 1.0, 0.1);
  EXPECT_NEAR(report->placement.offset_mm.y(), -0.5, 0.1);
  // The stored model explains the views as well as a fresh calibration does: both see only noise.
  EXPECT_LT(report->stored_rms_px, report->fresh_rms_px * 1.1);
  for (const CameraDrift& camera : report->cameras) EXPECT_LT(camera.drift_px, 0.1) << Describe(*report);
}

TEST(DriftTest, ANudgedCameraIsNamedAndOnlyIt) {
  const RigModel stored = SyntheticNominalRig();
  const RigModel nudged = WithSideCameraNudged(stored);
  const CalibrationTargetModel target;
  const Result<DriftReport> report =
      MeasureDrift(stored, target, SyntheticViews(nudged, target, kPlacedAgain, kCornerNoisePx), {});
  ASSERT_TRUE(report.ok()) << report.status().ToString();
  std::cout << Describe(*report);
  EXPECT_TRUE(report->recalibrate);
  EXPECT_TRUE(report->cameras[0].exceeded.empty()) << Describe(*report);
  ASSERT_FALSE(report->cameras[1].exceeded.empty()) << Describe(*report);
  EXPECT_NE(report->cameras[1].exceeded[0].find("reprojection drift"), std::string::npos);
  EXPECT_NEAR(report->cameras[1].rotation_deg, 0.5, 0.2) << Describe(*report);
}

TEST(DriftTest, ATiltedTurntableShowsInEveryCamera) {
  const RigModel stored = SyntheticNominalRig();
  RigModel tilted = stored;
  tilted.turntable.axis_direction = Eigen::Vector3d(DegToRad(0.6), 0, 1).normalized();
  const CalibrationTargetModel target;
  const Result<DriftReport> report =
      MeasureDrift(stored, target, SyntheticViews(tilted, target, kPlacedAgain, kCornerNoisePx), {});
  ASSERT_TRUE(report.ok()) << report.status().ToString();
  std::cout << Describe(*report);
  EXPECT_TRUE(report->recalibrate);
  // Measured: axis tilt 0.39° (top) and 0.53° (side) for the true 0.6°; the top camera's share
  // of it lies in its loose pose (up to 0.25° from noise alone, drift.h). The reprojection drift
  // (0.42 and 0.37 px) is what trips.
  for (const CameraDrift& camera : report->cameras) {
    EXPECT_GT(camera.axis_tilt_deg, 0.3) << Describe(*report);
    EXPECT_LT(camera.axis_tilt_deg, 0.9) << Describe(*report);
    EXPECT_GT(camera.drift_px, DriftThresholds{}.reprojection_px) << Describe(*report);
  }
}

TEST(DriftTest, ThresholdsComeFromTheRecalibrationSection) {
  const auto doc = ConfigDocument::LoadString("schema_version: 1\nrecalibration: {reprojection_px: 0.8, turntable_axis_mm: 2}\n",
                                              "rig.yaml", 1);
  ASSERT_TRUE(doc.ok()) << doc.status().ToString();
  const DriftThresholds thresholds = ReadDriftThresholds(doc->root().Child("recalibration"));
  EXPECT_EQ(thresholds.reprojection_px, 0.8);
  EXPECT_EQ(thresholds.turntable_axis_mm, 2);
  EXPECT_EQ(thresholds.turntable_axis_deg, DriftThresholds{}.turntable_axis_deg);
  ASSERT_TRUE(doc->Finish().ok());
  const auto typo = ConfigDocument::LoadString("schema_version: 1\nrecalibration: {reprojection_pix: 0.8}\n", "rig.yaml", 1);
  ASSERT_TRUE(typo.ok());
  ReadDriftThresholds(typo->root().Child("recalibration"));
  const Status finished = typo->Finish();
  EXPECT_NE(finished.ToString().find("reprojection_pix"), std::string::npos) << finished.ToString();
}

// A fresh radiometric calibration over the stored one: what changed past the threshold is named,
// the reference camera is not judged (it anchors the scale).
TEST(DriftTest, RadiometricAndLightDriftNameWhatChanged) {
  Radiometry fresh;
  fresh.reference_camera = "top";
  fresh.lights = {{"led 0", 0, 1e6, 1.01, 0}, {"led 1", 1, 1e6, 0.95, 0}, {"linear light", -1, 4000, 1.0, 0}};
  CameraRadiometry top, side;
  top.name = "top";
  side.name = "side";
  side.sensitivity_change = 1.04;
  fresh.cameras = {top, side};
  const Changes drift = MeasureRadiometricDrift(fresh, DriftThresholds{});
  ASSERT_EQ(drift.change.size(), 4u);
  EXPECT_NEAR(drift.change[1].second, -5, 1e-9);
  ASSERT_EQ(drift.exceeded.size(), 2u);
  EXPECT_EQ(drift.exceeded[0], "led 1 changed -5.0 % (threshold 3.0 %)");
  EXPECT_EQ(drift.exceeded[1], "side sensitivity changed 4.0 % (threshold 3.0 %)");

  LightPositions positions;
  positions.leds = {{0, Eigen::Vector3d::Zero(), 0.1, 1.5, 0.01, 2}, {1, Eigen::Vector3d::Zero(), 1.0, 12.0, 0.01, 2}};
  const Changes moved = MeasureLightPositionDrift(positions, DriftThresholds{});
  ASSERT_EQ(moved.exceeded.size(), 1u);
  EXPECT_EQ(moved.exceeded[0], "led 1 moved 12.0 mm (threshold 8.0 mm)");
  EXPECT_FALSE(MeasureLinearLightDrift(positions, DriftThresholds{}).has_value());
  positions.linear_light = LinearLightSweep{-68.5, 71.5, 1.5, 0.1, 10};
  const std::optional<Changes> turned = MeasureLinearLightDrift(positions, DriftThresholds{});
  ASSERT_TRUE(turned.has_value());
  ASSERT_EQ(turned->exceeded.size(), 1u);
  EXPECT_EQ(turned->exceeded[0], "linear light turned 1.5 deg (threshold 0.5 deg)");

  ProjectorCalibration projector;
  projector.column_change_px = 0.05;
  EXPECT_TRUE(MeasureProjectorDrift(projector, DriftThresholds{}).exceeded.empty());
  projector.column_change_px = 0.4;
  const Changes shifted = MeasureProjectorDrift(projector, DriftThresholds{});
  ASSERT_EQ(shifted.exceeded.size(), 1u);
  EXPECT_EQ(shifted.exceeded[0], "projector columns moved up to 0.40 px (threshold 0.15 px)");
}

}  // namespace
}  // namespace loom::calibration
