#include "sim/rig_scene.h"

#include <gtest/gtest.h>

#include "core/geometry.h"
#include "core/testing/shipped_rig.h"

namespace loom::sim {
namespace {

TEST(RigSceneTest, AsBuiltMovesAndTurnsDevicesAboutTheirOwnCentres) {
  const RigFile file = testing::ShippedRigFile("tac7-mini", R"(as_built:
  cameras: [{name: cam1, move_mm: [2, -1.5, 1], rotate_deg: [0, 0, 90], sensitivity_scale: 0.5}]
  leds: [{index: 3, intensity_scale: 0.85, move_mm: [1, 2, 3]}]
  projector: {focal_scale: 1.03, shift_cx_px: 4}
  linear_light: {turn_deg: 1.5}
)");
  const RigModel nominal = *file.Model();
  const RigModel built = AsBuilt(file, nominal);
  ASSERT_TRUE(file.Finish().ok()) << file.Finish().ToString();

  const CameraModel &was = nominal.cameras[1], &is = built.cameras[1];
  EXPECT_LT((is.CentreInRig() - (was.CentreInRig() + Eigen::Vector3d(2, -1.5, 1))).norm(), 1e-9);
  // rotate_deg z 90: what the camera saw along its y axis it now sees along its x axis
  // (cam_from_rig turned by Rz(90°) in the camera's frame), its viewing axis kept.
  const Eigen::Matrix3d was_r = was.cam_from_rig.rotation(), is_r = is.cam_from_rig.rotation();
  EXPECT_LT((Eigen::Vector3d(is_r.row(0)) + Eigen::Vector3d(was_r.row(1))).norm(), 1e-9);
  EXPECT_LT((Eigen::Vector3d(is_r.row(1)) - Eigen::Vector3d(was_r.row(0))).norm(), 1e-9);
  EXPECT_LT((Eigen::Vector3d(is_r.row(2)) - Eigen::Vector3d(was_r.row(2))).norm(), 1e-9);
  EXPECT_DOUBLE_EQ(is.sensor.sensitivity, 0.5 * was.sensor.sensitivity);
  EXPECT_DOUBLE_EQ(built.leds[3].intensity, 0.85 * nominal.leds[3].intensity);
  EXPECT_LT((built.leds[3].position_mm - nominal.leds[3].position_mm - Eigen::Vector3d(1, 2, 3)).norm(), 1e-12);
  EXPECT_DOUBLE_EQ(built.projector->K(0, 0), 1.03 * nominal.projector->K(0, 0));
  EXPECT_DOUBLE_EQ(built.projector->K(0, 2), nominal.projector->K(0, 2) + 4);
  EXPECT_DOUBLE_EQ(built.linear_light->start_deg, nominal.linear_light->start_deg + 1.5);
  EXPECT_EQ(built.cameras[0].cam_from_rig.matrix(), nominal.cameras[0].cam_from_rig.matrix());
}

TEST(RigSceneTest, AsBuiltNamesWhatTheGeometryDoesNotHave) {
  const RigFile file = testing::ShippedRigFile("tac7-mini",
                                               "as_built:\n  cameras: [{name: cam7, move_mm: [1, 0, 0]}]\n"
                                               "  leds: [{index: 999, intensity_scale: 2}]\n");
  AsBuilt(file, *file.Model());
  const std::string problems = file.Finish().ToString();
  EXPECT_NE(problems.find("no camera 'cam7'"), std::string::npos) << problems;
  EXPECT_NE(problems.find("no LED 999"), std::string::npos) << problems;
}

// A lens vignetting about a point off the image centre, with a quartic term, as a flat field over
// the quadratic model; the strip's profile as built. Bad values are named.
TEST(RigSceneTest, AsBuiltLensesAndStripsOutOfTheNominalModelsReach) {
  const RigFile file = testing::ShippedRigFile("tac7-mini", R"(as_built:
  cameras: [{name: cam1, vignetting: 0.2, vignetting_centre_px: [8, -6], vignetting_quartic: 0.1}]
  linear_light: {profile: [0.8, 1, 1.2]}
)");
  const RigModel nominal = *file.Model();
  const RigModel built = AsBuilt(file, nominal);
  ASSERT_TRUE(file.Finish().ok()) << file.Finish().ToString();
  EXPECT_FALSE(built.cameras[0].sensor.flat_field);
  const CameraModel& camera = built.cameras[1];
  ASSERT_TRUE(camera.sensor.flat_field);
  // Next to the optical centre (79.5 + 8, 79.5 − 6) the response is 1; at pixel (80, 80),
  // 1 − 0.2 q − 0.1 q², q its squared distance from the optical centre over the corner's.
  const double corner2 = 0.25 * (camera.width * camera.width + camera.height * camera.height);
  const double q = (7.5 * 7.5 + 6.5 * 6.5) / corner2;
  EXPECT_NEAR(camera.sensor.RelativeResponse(88, 74, camera.width, camera.height), 1, 1e-4);
  EXPECT_NEAR(camera.sensor.RelativeResponse(80, 80, camera.width, camera.height), 1 - 0.2 * q - 0.1 * q * q, 1e-6);
  EXPECT_EQ(built.linear_light->profile, (std::vector<double>{0.8, 1, 1.2}));
  EXPECT_DOUBLE_EQ(built.linear_light->ProfileAt(-built.linear_light->strip_length_mm / 4), 0.9);
  EXPECT_DOUBLE_EQ(built.linear_light->start_deg, nominal.linear_light->start_deg);

  const RigFile bad = testing::ShippedRigFile("tac7-mini", R"(as_built:
  cameras: [{name: cam1, vignetting_quartic: .nan}]
  linear_light: {profile: [1, 0]}
)");
  AsBuilt(bad, *bad.Model());
  const std::string problems = bad.Finish().ToString();
  EXPECT_NE(problems.find("vignetting_quartic"), std::string::npos) << problems;
  EXPECT_NE(problems.find("profile"), std::string::npos) << problems;
}

TEST(RigSceneTest, TheObjectAskedForReplacesTheSampleAndABadOneIsRefusedByName) {
  const RigFile file = testing::ShippedRigFile("tac7-mini");
  const Result<RigScene> rig = MakeRigScene(file, *file.Model(), "fabric:5");
  ASSERT_TRUE(rig.ok()) << rig.status().ToString();
  EXPECT_EQ(rig->sample.seed, 5u);
  EXPECT_EQ(rig->scene->material().name.find("fabric"), 0u) << rig->scene->material().name;
  for (const char* bad : {"fabric:x", "fabric:5x", "fabric:-1", "fabric:", "fabric:99999999999999999999999"}) {
    const Result<RigScene> refused = MakeRigScene(file, *file.Model(), bad);
    ASSERT_FALSE(refused.ok()) << bad;
    EXPECT_NE(refused.status().ToString().find(bad), std::string::npos) << refused.status().ToString();
  }
}

}  // namespace
}  // namespace loom::sim
