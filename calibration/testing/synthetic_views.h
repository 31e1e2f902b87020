#pragma once
// Test helpers: a two-camera rig like tac7-mini's (a top camera and one 45° from the normal, 3°
// fields) and the corners its cameras see of the calibration target at 8 turntable angles.
// Header-only, for the calibration tests.

#include <random>
#include <string>
#include <vector>

#include "calibration/geometry.h"

namespace loom::calibration::testing {

inline CameraModel SyntheticCamera(const std::string& name, const Eigen::Vector3d& centre) {
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

inline RigModel SyntheticNominalRig() {
  RigModel rig;
  rig.cameras = {SyntheticCamera("top", {0, 0, 600}), SyntheticCamera("side", {-424.26, 0, 424.26})};
  return rig;
}

// `rig` with its side camera (index 1) turned 0.5° and moved (2, -1.5, 1) mm.
inline RigModel WithSideCameraNudged(RigModel rig) {
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(DegToRad(0.5), Eigen::Vector3d(1, -1, 0.5).normalized()).toRotationMatrix();
  Rigid3d& side = rig.cameras[1].cam_from_rig;
  const Eigen::Vector3d centre = side.inverse().translation() + Eigen::Vector3d(2, -1.5, 1);
  side = MakeRigid(turn * side.rotation(), -(turn * side.rotation()) * centre);
  return rig;
}

// The views `rig` sees at 8 turntable angles of the target placed as `placement`, with Gaussian
// corner noise (seeded: the same every run).
inline std::vector<TargetView> SyntheticViews(const RigModel& rig, const CalibrationTargetModel& target,
                                              const TargetPlacement& placement, double noise_px) {
  std::mt19937 random(3);
  std::normal_distribution<double> noise(0, noise_px);
  const Eigen::Matrix3d yaw = Eigen::AngleAxisd(DegToRad(placement.yaw_deg), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d offset(placement.offset_mm.x(), placement.offset_mm.y(), 0);
  std::vector<TargetView> views;
  for (int c = 0; c < static_cast<int>(rig.cameras.size()); ++c) {
    for (int k = 0; k < 8; ++k) {
      TargetView view{c, 45.0 * k, scan::ViewId{k, rig.cameras[c].name}, {}};
      const Rigid3d cam_from_sample = rig.cameras[c].cam_from_rig * rig.turntable.RigFromSample(view.turntable_deg);
      for (const Eigen::Vector3d& p : target.CornersInBoard()) {
        Eigen::Vector2d pixel;
        rig.cameras[c].Project(cam_from_sample * (yaw * (target.SampleFromBoard() * p) + offset), &pixel);
        view.corners.push_back(pixel + Eigen::Vector2d(noise(random), noise(random)));
      }
      views.push_back(std::move(view));
    }
  }
  return views;
}

}  // namespace loom::calibration::testing
