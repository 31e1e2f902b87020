// The rig's geometric calibration on synthetic target views: corners projected by an as-built
// rig that differs from the nominal one the calibration starts from, with corner noise.
#include "calibration/geometry.h"

#include <gtest/gtest.h>

#include <random>

namespace loom::calibration {
namespace {

CameraModel Camera(const std::string& name, const Eigen::Vector3d& centre) {
  CameraModel camera;
  camera.name = name;
  camera.width = camera.height = 160;
  camera.K << 3000, 0, 79.5, 0, 3000, 79.5, 0, 0, 1;
  const Eigen::Vector3d z = -centre.normalized();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
  Eigen::Matrix3d rotation;
  rotation << x.transpose(), z.cross(x).transpose(), z.transpose();
  camera.cam_from_rig = MakeRigid(rotation, -rotation * centre);
  return camera;
}

RigModel Nominal() {
  RigModel rig;
  rig.cameras = {Camera("top", {0, 0, 600}), Camera("side", {-424.26, 0, 424.26})};
  return rig;
}

// The views the as-built rig sees at 8 turntable angles, target offset by (0.4, -0.3) mm.
std::vector<TargetView> Views(const RigModel& as_built, const CalibrationTargetModel& target, double noise_px) {
  std::mt19937 random(3);
  std::normal_distribution<double> noise(0, noise_px);
  std::vector<TargetView> views;
  for (int c = 0; c < 2; ++c) {
    for (int k = 0; k < 8; ++k) {
      TargetView view{c, 45.0 * k, "view " + std::to_string(k), {}};
      const Rigid3d cam_from_sample = as_built.cameras[c].cam_from_rig * as_built.turntable.RigFromSample(view.turntable_deg);
      for (const Eigen::Vector3d& p : target.CornersInBoard()) {
        Eigen::Vector2d pixel;
        as_built.cameras[c].Project(cam_from_sample * (target.SampleFromBoard() * p + Eigen::Vector3d(0.4, -0.3, 0)), &pixel);
        view.corners.push_back(pixel + Eigen::Vector2d(noise(random), noise(random)));
      }
      views.push_back(std::move(view));
    }
  }
  return views;
}

TEST(GeometryTest, FindsTheAsBuiltCamerasFromTheNominalOnes) {
  const RigModel nominal = Nominal();
  RigModel as_built = nominal;
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(DegToRad(0.5), Eigen::Vector3d(1, -1, 0.5).normalized()).toRotationMatrix();
  Rigid3d& side = as_built.cameras[1].cam_from_rig;
  const Eigen::Vector3d centre = side.inverse().translation() + Eigen::Vector3d(2, -1.5, 1);
  side = MakeRigid(turn * side.rotation(), -(turn * side.rotation()) * centre);
  const CalibrationTargetModel target;
  // 0.25 px: what the sector-based detector leaves on the simulated target (measured).
  const Result<RigGeometry> geometry = CalibrateRigGeometry(nominal, target, Views(as_built, target, 0.25));
  ASSERT_TRUE(geometry.ok()) << geometry.status().ToString();
  // rms_px is per corner (x and y): √2 × the noise.
  EXPECT_NEAR(geometry->rms_px, std::sqrt(2.0) * 0.25, 0.03);
  EXPECT_NEAR(geometry->target_offset_mm.x(), 0.4, 0.1);
  EXPECT_NEAR(geometry->target_offset_mm.y(), -0.3, 0.1);
  for (int c = 0; c < 2; ++c) {
    const CameraModel& truth = as_built.cameras[c];
    CameraModel found = truth;
    found.cam_from_rig = geometry->cameras[c].cam_from_rig;
    const double rotation_deg = RadToDeg(Eigen::AngleAxisd(found.cam_from_rig.rotation() * truth.cam_from_rig.rotation().transpose()).angle());
    const double centre_mm = (found.CentreInRig() - truth.CentreInRig()).norm();
    // What reconstruction needs: where points of the sample volume land in the image.
    double worst_px = 0;
    for (double x : {-10.0, 0.0, 10.0}) {
      for (double y : {-10.0, 0.0, 10.0}) {
        for (double z : {0.0, 5.0}) {
          Eigen::Vector2d a, b;
          truth.Project(truth.cam_from_rig * Eigen::Vector3d(x, y, z), &a);
          found.Project(found.cam_from_rig * Eigen::Vector3d(x, y, z), &b);
          worst_px = std::max(worst_px, (a - b).norm());
        }
      }
    }
    std::cout << "camera " << c << ": " << rotation_deg << " deg, " << centre_mm << " mm, " << worst_px << " px\n";
    // Measured: top 0.25° and 2.6 mm, side 0.10° and 0.8 mm; projection 0.20 and 0.12 px. A nearly
    // orthographic camera (3° field) can turn and shift across its view together with little
    // change to the image: the pose is loose along that one combination, the projection is not.
    EXPECT_LT(rotation_deg, 0.5) << c;
    EXPECT_LT(centre_mm, 5) << c;
    EXPECT_LT(worst_px, 0.4) << c;
  }
}

TEST(GeometryTest, ACameraWithTooFewViewsIsNamed) {
  const RigModel nominal = Nominal();
  const CalibrationTargetModel target;
  std::vector<TargetView> views = Views(nominal, target, 0);
  views.erase(views.begin() + 10, views.end());  // the side camera keeps 2 views
  const Result<RigGeometry> geometry = CalibrateRigGeometry(nominal, target, views);
  ASSERT_FALSE(geometry.ok());
  EXPECT_NE(geometry.status().ToString().find("camera side"), std::string::npos) << geometry.status().ToString();
  EXPECT_NE(geometry.status().ToString().find("in 2 views"), std::string::npos) << geometry.status().ToString();
}

}  // namespace
}  // namespace loom::calibration
