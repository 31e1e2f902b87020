#include "calibration/drift.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace loom::calibration {
namespace {

std::vector<TargetView> ViewsOf(const std::vector<TargetView>& views, int camera) {
  std::vector<TargetView> own;
  for (const TargetView& view : views) {
    if (view.camera == camera) own.push_back(view);
  }
  return own;
}

std::vector<TargetView> Without(const std::vector<TargetView>& views, const std::vector<scan::ViewId>& rejected) {
  std::vector<TargetView> kept;
  for (const TargetView& view : views) {
    if (std::find(rejected.begin(), rejected.end(), view.view) == rejected.end()) kept.push_back(view);
  }
  return kept;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return RadToDeg(std::atan2(a.cross(b).norm(), a.dot(b))); }

std::string Exceeded(const std::string& what, double value, const std::string& unit, double threshold) {
  std::ostringstream text;
  text << what << " " << value << " " << unit << " > " << threshold << " " << unit;
  return text.str();
}

// Compares a fresh pose with the stored one. The fresh calibration's x axis is the new target's
// rows, which the stored calibration sees turned by `yaw_deg`: stored rig = Rz(yaw) · fresh rig.
void ComparePoses(const Rigid3d& stored, const Rigid3d& fresh, double yaw_deg, CameraDrift* drift) {
  const Rigid3d aligned = fresh * MakeRigid(Eigen::AngleAxisd(DegToRad(-yaw_deg), Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                                            Eigen::Vector3d::Zero());
  drift->rotation_deg = RadToDeg(Eigen::AngleAxisd(aligned.rotation() * stored.rotation().transpose()).angle());
  drift->centre_mm = (aligned.inverse().translation() - stored.inverse().translation()).norm();
  // The turntable axis (the rig's z through its origin) in the camera's frame; yaw leaves it be.
  drift->axis_tilt_deg = AngleDeg(stored.rotation().col(2), fresh.rotation().col(2));
  const Eigen::Vector3d view = stored.translation().normalized();
  const Eigen::Vector3d shift = fresh.translation() - stored.translation();
  drift->axis_shift_mm = (shift - shift.dot(view) * view).norm();
}

void Judge(const DriftThresholds& thresholds, CameraDrift* drift) {
  if (drift->drift_px > thresholds.reprojection_px) {
    drift->exceeded.push_back(Exceeded("reprojection drift", drift->drift_px, "px", thresholds.reprojection_px));
  }
  if (drift->axis_tilt_deg > thresholds.turntable_axis_deg) {
    drift->exceeded.push_back(Exceeded("turntable axis tilt", drift->axis_tilt_deg, "deg", thresholds.turntable_axis_deg));
  }
  if (drift->axis_shift_mm > thresholds.turntable_axis_mm) {
    drift->exceeded.push_back(Exceeded("turntable axis shift", drift->axis_shift_mm, "mm", thresholds.turntable_axis_mm));
  }
}

}  // namespace

DriftThresholds ReadDriftThresholds(const ConfigNode& node) {
  DriftThresholds thresholds;
  node.Optional("reprojection_px", &thresholds.reprojection_px);
  node.Optional("turntable_axis_deg", &thresholds.turntable_axis_deg);
  node.Optional("turntable_axis_mm", &thresholds.turntable_axis_mm);
  node.Optional("intensity_percent", &thresholds.intensity_percent);
  node.Optional("led_position_mm", &thresholds.led_position_mm);
  node.Optional("projector_column_px", &thresholds.projector_column_px);
  node.Optional("linear_light_deg", &thresholds.linear_light_deg);
  return thresholds;
}

Result<DriftReport> MeasureDrift(const RigModel& stored, const CalibrationTargetModel& target,
                                 const std::vector<TargetView>& all_views, const DriftThresholds& thresholds) {
  LOOM_ASSIGN_OR_RETURN(const RigGeometry fresh, CalibrateRigGeometry(stored, target, all_views));
  // A view the fresh calibration rejected is a misdetection, not drift: both judge the rest.
  const std::vector<TargetView> views = Without(all_views, fresh.rejected);
  DriftReport report;
  report.rejected = fresh.rejected;
  report.fresh = fresh;
  LOOM_ASSIGN_OR_RETURN(report.placement, FitTargetPlacement(stored, target, views));
  report.stored_rms_px = ReprojectionRms(stored, target, report.placement, views);
  report.fresh_rms_px = fresh.rms_px;
  for (size_t c = 0; c < stored.cameras.size(); ++c) {
    CameraDrift& drift = report.cameras.emplace_back();
    drift.name = stored.cameras[c].name;
    const std::vector<TargetView> own = ViewsOf(views, static_cast<int>(c));
    drift.views = static_cast<int>(own.size());
    drift.stored_rms_px = ReprojectionRms(stored, target, report.placement, own);
    drift.fresh_rms_px = fresh.cameras[c].intrinsics.rms_px;
    drift.drift_px =
        std::sqrt(std::max(0.0, drift.stored_rms_px * drift.stored_rms_px - drift.fresh_rms_px * drift.fresh_rms_px));
    ComparePoses(stored.cameras[c].cam_from_rig, fresh.cameras[c].cam_from_rig, report.placement.yaw_deg, &drift);
    Judge(thresholds, &drift);
    report.recalibrate = report.recalibrate || !drift.exceeded.empty();
  }
  return report;
}

namespace {

void Judge(const std::string& what, double change, double threshold, const char* verb, Changes* changes) {
  changes->change.emplace_back(what, change);
  if (std::abs(change) <= threshold) return;
  std::ostringstream text;
  const int decimals = changes->unit == "px" ? 2 : 1;  // pixel thresholds are sub-pixel
  text << std::fixed << std::setprecision(decimals) << what << " " << verb << " " << change << " " << changes->unit
       << " (threshold " << threshold << " " << changes->unit << ")";
  changes->exceeded.push_back(text.str());
}

}  // namespace

Changes MeasureRadiometricDrift(const Radiometry& fresh, const DriftThresholds& thresholds) {
  Changes changes{"%", {}, {}};
  for (const LightRadiometry& light : fresh.lights) {
    Judge(light.name, 100 * (light.change - 1), thresholds.intensity_percent, "changed", &changes);
  }
  for (const CameraRadiometry& camera : fresh.cameras) {
    if (camera.name == fresh.reference_camera) continue;
    Judge(camera.name + " sensitivity", 100 * (camera.sensitivity_change - 1), thresholds.intensity_percent, "changed", &changes);
  }
  return changes;
}

Changes MeasureLightPositionDrift(const LightPositions& fresh, const DriftThresholds& thresholds) {
  Changes changes{"mm", {}, {}};
  for (const LightPosition& led : fresh.leds) {
    Judge("led " + std::to_string(led.led), led.change_mm, thresholds.led_position_mm, "moved", &changes);
  }
  return changes;
}

std::optional<Changes> MeasureLinearLightDrift(const LightPositions& fresh, const DriftThresholds& thresholds) {
  if (!fresh.linear_light) return std::nullopt;
  Changes changes{"deg", {}, {}};
  Judge("linear light", fresh.linear_light->change_deg, thresholds.linear_light_deg, "turned", &changes);
  return changes;
}

Changes MeasureProjectorDrift(const ProjectorCalibration& fresh, const DriftThresholds& thresholds) {
  Changes changes{"px", {}, {}};
  Judge("projector columns", fresh.column_change_px, thresholds.projector_column_px, "moved up to", &changes);
  return changes;
}

}  // namespace loom::calibration
