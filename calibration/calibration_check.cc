#include "calibration/calibration_check.h"

#include <algorithm>
#include <iomanip>

#include "calibration/calibration_yaml.h"
#include "calibration/light_positions.h"
#include "calibration/projector.h"
#include "calibration/projector_columns.h"
#include "calibration/radiometry_yaml.h"
#include "calibration/scan_calibration.h"
#include "calibration/scan_radiance.h"
#include "core/rig_file.h"
#include "core/version.h"

namespace loom::calibration {
namespace {

namespace fs = std::filesystem;

// The rig YAML's `recalibration:` thresholds (defaults where it has none).
Result<DriftThresholds> DriftThresholdsOf(const std::string& rig_yaml, const std::string& source) {
  LOOM_ASSIGN_OR_RETURN(const RigFile file, RigFile::Parse(rig_yaml, source));
  DriftThresholds thresholds;
  if (const std::optional<ConfigNode> node = file.Section("recalibration")) thresholds = ReadDriftThresholds(*node);
  LOOM_RETURN_IF_ERROR(file.Finish());
  return thresholds;
}

// The stored calibration over the scan's rig: every camera needs its pose.
Result<RigModel> StoredRig(const RigModel& nominal, const fs::path& calib) {
  RigModel stored = nominal;
  LOOM_ASSIGN_OR_RETURN(const std::vector<std::string> applied, ApplyCameraCalibrations(calib, &stored));
  for (const CameraModel& camera : nominal.cameras) {
    if (std::find(applied.begin(), applied.end(), camera.name) == applied.end()) {
      return NotFoundError((calib / (camera.name + ".yaml")).string(),
                           "no such file: the check compares every camera's stored calibration");
    }
  }
  return stored;
}

// The lights against the stored calibration: fresh LED positions from the light probe, then a
// fresh radiometry with them, both on the fresh geometry. Parts CALIB holds nothing of are not
// compared.
Status CheckLights(const scan::CaptureStore& store, const RigModel& fresh_cameras, const fs::path& calib,
                   CalibrationCheck& check) {
  const std::string dir = calib.string();
  RigModel rig = fresh_cameras;
  LOOM_ASSIGN_OR_RETURN(const bool has_positions, ApplyLightPositionCalibration(calib, &rig));
  check.led_positions = {"LED positions against the stored ones", std::nullopt, ""};
  check.linear_light = {"the linear light's sweep against the stored one", std::nullopt, ""};
  if (has_positions) {
    LOOM_ASSIGN_OR_RETURN(const ScanRadiance scan, ScanRadiance::Open(store, rig));
    LOOM_ASSIGN_OR_RETURN(const std::vector<LitView> views, scan.LitViews(scan::StepKind::kLightProbe));
    LOOM_ASSIGN_OR_RETURN(const LightPositions fresh, CalibrateLightPositions(rig, views));
    check.led_positions.changes = MeasureLightPositionDrift(fresh, check.thresholds);
    check.linear_light.changes = MeasureLinearLightDrift(fresh, check.thresholds);
    if (!check.linear_light.changes) {
      check.linear_light.not_compared = "the scan has no view of the light probe under the linear light";
    }
    ApplyLightPositions(fresh, &rig);
  } else {
    check.led_positions.not_compared = dir + " holds none: loom calibrate geometry with a light_probe";
    check.linear_light.not_compared = check.led_positions.not_compared;
  }
  LOOM_ASSIGN_OR_RETURN(const std::optional<Radiometry> stored_radiometry, ApplyRadiometryCalibration(calib, &rig));
  if (!stored_radiometry) {
    check.radiometry = {"light intensities", std::nullopt, dir + " holds no radiometric calibration: loom calibrate radiometry"};
    return Status::Ok();
  }
  LOOM_ASSIGN_OR_RETURN(const ScanRadiance scan, ScanRadiance::Open(store, rig));
  RadiometryOptions options;
  options.reference_camera = stored_radiometry->reference_camera;
  LOOM_ASSIGN_OR_RETURN(const Radiometry fresh, CalibrateRadiometry(scan, options));
  check.radiometry = {"against the stored radiometry (reference camera " + fresh.reference_camera + ")",
                      MeasureRadiometricDrift(fresh, check.thresholds), ""};
  return Status::Ok();
}

// The projector against the stored one: a fresh calibration of its columns at the target's
// corners, seen by the fresh cameras, starting from the stored projector.
Status CheckProjector(const scan::CaptureStore& store, const RigModel& fresh_cameras, const CalibrationTargetModel& target,
                      const fs::path& calib, CalibrationCheck& check) {
  RigModel rig = fresh_cameras;
  check.projector = {"projector", std::nullopt, ""};
  LOOM_ASSIGN_OR_RETURN(const bool has_projector, ApplyProjectorCalibration(calib, &rig));
  if (!has_projector) {
    check.projector.not_compared = calib.string() + " holds no projector.yaml: loom calibrate geometry";
    return Status::Ok();
  }
  if (StructuredLightAngles(store.info().plan, scan::ScanObject::kTarget).empty()) {
    check.projector.not_compared = "the scan has no structured light on the target";
    return Status::Ok();
  }
  LOOM_ASSIGN_OR_RETURN(const ScanRadiance scan, ScanRadiance::Open(store, rig));
  LOOM_ASSIGN_OR_RETURN(const std::vector<ProjectorCorrespondence> corners,
                        TargetCornerColumns(scan, target, check.cameras.fresh.target));
  LOOM_ASSIGN_OR_RETURN(const ProjectorCalibration fresh, CalibrateProjector(*rig.projector, {corners, {}}));
  check.projector.title = "against the stored projector (" + std::to_string(fresh.correspondences) + " target corners decoded)";
  check.projector.changes = MeasureProjectorDrift(fresh, check.thresholds);
  return Status::Ok();
}

nlohmann::json PartJson(const CalibrationCheck::Part& part) {
  if (!part.changes) return "not compared: " + part.not_compared;
  nlohmann::json json = {{"unit", part.changes->unit}, {"exceeded", part.changes->exceeded}};
  for (const auto& [what, change] : part.changes->change) json["change"][what] = change;
  return json;
}

void ReportPart(const CalibrationCheck::Part& part, std::ostream& out) {
  if (!part.changes) {
    out << part.title << ": not compared (" << part.not_compared << ")\n";
    return;
  }
  out << part.title << ":" << std::fixed << std::setprecision(2);
  for (const auto& [what, change] : part.changes->change) {
    out << " " << what << " " << std::showpos << change << std::noshowpos << " " << part.changes->unit << ";";
  }
  out << "\n";
  for (const std::string& exceeded : part.changes->exceeded) out << exceeded << "\n";
}

}  // namespace

Result<CalibrationCheck> CheckCalibration(const fs::path& scan_dir, const fs::path& calibration_directory) {
  LOOM_ASSIGN_OR_RETURN(const scan::CaptureStore store, OpenCalibrationStore(scan_dir));
  LOOM_ASSIGN_OR_RETURN(const CalibrationScan opened, CalibrationScan::Open(store));
  CalibrationCheck check;
  check.scan = scan_dir.string();
  check.calibration = calibration_directory.string();
  LOOM_ASSIGN_OR_RETURN(check.thresholds, DriftThresholdsOf(opened.rig_yaml, (scan_dir / "scan.yaml").string() + " (rig)"));
  LOOM_ASSIGN_OR_RETURN(const RigModel stored, StoredRig(opened.nominal, calibration_directory));
  LOOM_ASSIGN_OR_RETURN(check.cameras, MeasureDrift(stored, opened.target, opened.detected.views, check.thresholds));
  const RigModel fresh_cameras = ApplyGeometry(stored, check.cameras.fresh);
  LOOM_RETURN_IF_ERROR(CheckLights(store, fresh_cameras, calibration_directory, check));
  LOOM_RETURN_IF_ERROR(CheckProjector(store, fresh_cameras, opened.target, calibration_directory, check));
  const auto exceeded = [](const CalibrationCheck::Part& part) { return part.changes && !part.changes->exceeded.empty(); };
  check.recalibrate = check.cameras.recalibrate || exceeded(check.led_positions) || exceeded(check.linear_light) ||
                      exceeded(check.radiometry) || exceeded(check.projector);
  return check;
}

nlohmann::json CalibrationCheck::ToJson() const {
  const DriftThresholds& t = thresholds;
  nlohmann::json json = {{"scan", scan},
                         {"calibration", calibration},
                         {"recalibrate", recalibrate},
                         {"stored_rms_px", cameras.stored_rms_px},
                         {"fresh_rms_px", cameras.fresh_rms_px},
                         {"target_placement",
                          {{"offset_mm", {cameras.placement.offset_mm.x(), cameras.placement.offset_mm.y()}},
                           {"yaw_deg", cameras.placement.yaw_deg}}},
                         {"rejected", scan::ViewNames(cameras.rejected)},
                         {"thresholds",
                          {{"reprojection_px", t.reprojection_px},
                           {"turntable_axis_deg", t.turntable_axis_deg},
                           {"turntable_axis_mm", t.turntable_axis_mm},
                           {"intensity_percent", t.intensity_percent},
                           {"led_position_mm", t.led_position_mm},
                           {"projector_column_px", t.projector_column_px},
                           {"linear_light_deg", t.linear_light_deg}}},
                         {"led_positions", PartJson(led_positions)},
                         {"linear_light", PartJson(linear_light)},
                         {"radiometry", PartJson(radiometry)},
                         {"projector", PartJson(projector)},
                         {"loom_version", std::string(VersionWithCommit())}};
  for (const CameraDrift& c : cameras.cameras) {
    json["cameras"][c.name] = {{"views", c.views},
                               {"stored_rms_px", c.stored_rms_px},
                               {"fresh_rms_px", c.fresh_rms_px},
                               {"drift_px", c.drift_px},
                               {"rotation_deg", c.rotation_deg},
                               {"centre_mm", c.centre_mm},
                               {"turntable_axis_tilt_deg", c.axis_tilt_deg},
                               {"turntable_axis_shift_mm", c.axis_shift_mm},
                               {"exceeded", c.exceeded}};
  }
  return json;
}

void CalibrationCheck::Report(std::ostream& out) const {
  out << std::fixed << std::setprecision(3) << "target placed at (" << cameras.placement.offset_mm.x() << ", "
      << cameras.placement.offset_mm.y() << ") mm, turned " << cameras.placement.yaw_deg << " deg\n"
      << "camera   views  stored px  fresh px  drift px  rotation deg  centre mm  axis tilt deg  axis shift mm\n";
  for (const CameraDrift& c : cameras.cameras) {
    out << std::left << std::setw(8) << c.name << std::right << std::setw(6) << c.views << std::setw(11) << c.stored_rms_px
        << std::setw(10) << c.fresh_rms_px << std::setw(10) << c.drift_px << std::setw(14) << c.rotation_deg << std::setw(11)
        << c.centre_mm << std::setw(15) << c.axis_tilt_deg << std::setw(15) << c.axis_shift_mm << "\n";
  }
  for (const CameraDrift& c : cameras.cameras) {
    for (const std::string& exceeded : c.exceeded) out << c.name << ": " << exceeded << "\n";
  }
  for (const Part* part : {&led_positions, &linear_light, &radiometry, &projector}) ReportPart(*part, out);
  out << (recalibrate ? "RECALIBRATE: the stored calibration no longer explains the rig\n" : "calibration holds\n");
}

}  // namespace loom::calibration
