// loom calibrate check: a fresh calibration scan against a stored calibration — cameras
// (calibration/drift.h), LED positions, radiometry and the projector — with the rig YAML's
// thresholds.
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <optional>

#include <nlohmann/json.hpp>

#include "apps/calibrate_scan.h"
#include "apps/rig_loader.h"
#include "calibration/calibration_yaml.h"
#include "calibration/drift.h"
#include "calibration/light_positions.h"
#include "calibration/projector.h"
#include "calibration/projector_columns.h"
#include "calibration/radiometry.h"
#include "calibration/radiometry_yaml.h"
#include "core/file_io.h"
#include "core/version.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

// The rig YAML's `recalibration:` thresholds (defaults where it has none).
Result<calibration::DriftThresholds> DriftThresholdsOf(const std::string& rig_yaml, const std::string& source) {
  LOOM_ASSIGN_OR_RETURN(const ConfigDocument doc, ConfigDocument::LoadString(rig_yaml, source, kRigSchemaVersion));
  calibration::DriftThresholds thresholds;
  for (const std::string& key : doc.root().Keys()) {
    if (key == "recalibration") {
      thresholds = calibration::ReadDriftThresholds(doc.root().Child(key));
    } else {
      doc.root().Ignore(key);
    }
  }
  LOOM_RETURN_IF_ERROR(doc.Finish());
  return thresholds;
}

// The stored calibration over the scan's rig: every camera needs its pose.
Result<RigModel> StoredRig(const RigModel& nominal, const std::string& calib) {
  RigModel stored = nominal;
  LOOM_ASSIGN_OR_RETURN(const std::vector<std::string> applied, calibration::ApplyCameraCalibrations(calib, &stored));
  for (const CameraModel& camera : nominal.cameras) {
    if (std::find(applied.begin(), applied.end(), camera.name) == applied.end()) {
      return NotFoundError((fs::path(calib) / (camera.name + ".yaml")).string(),
                           "no such file: the check compares every camera's stored calibration");
    }
  }
  return stored;
}

nlohmann::json DriftJson(const calibration::DriftReport& report, const calibration::DriftThresholds& thresholds,
                         const std::string& scan, const std::string& calib) {
  nlohmann::json json = {{"scan", scan}, {"calibration", calib}, {"recalibrate", report.recalibrate},
                         {"stored_rms_px", report.stored_rms_px}, {"fresh_rms_px", report.fresh_rms_px},
                         {"target_placement", {{"offset_mm", {report.placement.offset_mm.x(), report.placement.offset_mm.y()}},
                                               {"yaw_deg", report.placement.yaw_deg}}},
                         {"rejected", report.rejected},
                         {"thresholds", {{"reprojection_px", thresholds.reprojection_px},
                                         {"turntable_axis_deg", thresholds.turntable_axis_deg},
                                         {"turntable_axis_mm", thresholds.turntable_axis_mm},
                                         {"intensity_percent", thresholds.intensity_percent},
                                         {"led_position_mm", thresholds.led_position_mm},
                                         {"projector_column_px", thresholds.projector_column_px},
                                         {"linear_light_deg", thresholds.linear_light_deg}}},
                         {"loom_version", std::string(VersionWithCommit())}};
  for (const calibration::CameraDrift& c : report.cameras) {
    json["cameras"][c.name] = {{"views", c.views}, {"stored_rms_px", c.stored_rms_px}, {"fresh_rms_px", c.fresh_rms_px},
                               {"drift_px", c.drift_px}, {"rotation_deg", c.rotation_deg}, {"centre_mm", c.centre_mm},
                               {"turntable_axis_tilt_deg", c.axis_tilt_deg}, {"turntable_axis_shift_mm", c.axis_shift_mm},
                               {"exceeded", c.exceeded}};
  }
  return json;
}

void PrintDrift(const calibration::DriftReport& report) {
  std::cout << std::fixed << std::setprecision(3) << "target placed at (" << report.placement.offset_mm.x() << ", "
            << report.placement.offset_mm.y() << ") mm, turned " << report.placement.yaw_deg << " deg\n"
            << "camera   views  stored px  fresh px  drift px  rotation deg  centre mm  axis tilt deg  axis shift mm\n";
  for (const calibration::CameraDrift& c : report.cameras) {
    std::cout << std::left << std::setw(8) << c.name << std::right << std::setw(6) << c.views << std::setw(11) << c.stored_rms_px
              << std::setw(10) << c.fresh_rms_px << std::setw(10) << c.drift_px << std::setw(14) << c.rotation_deg
              << std::setw(11) << c.centre_mm << std::setw(15) << c.axis_tilt_deg << std::setw(15) << c.axis_shift_mm << "\n";
  }
  for (const calibration::CameraDrift& c : report.cameras) {
    for (const std::string& exceeded : c.exceeded) std::cout << c.name << ": " << exceeded << "\n";
  }
}

void PrintChanges(const std::string& title, const calibration::Changes& changes) {
  std::cout << title << ":" << std::fixed << std::setprecision(2);
  for (const auto& [what, change] : changes.change) std::cout << " " << what << " " << std::showpos << change << std::noshowpos << " " << changes.unit << ";";
  std::cout << "\n";
  for (const std::string& exceeded : changes.exceeded) std::cout << exceeded << "\n";
}

// The lights against the stored calibration: fresh LED positions from the light probe, then a
// fresh radiometry with them; both on the fresh geometry, so that a camera or an LED that moved
// does not read as a light that changed. Nothing where CALIB holds no such calibration.
struct LightChecks {
  std::optional<calibration::Changes> positions;
  std::optional<calibration::Changes> linear_light;
  std::optional<calibration::Changes> radiometry;
};

// `fresh_cameras`: the stored calibration with the fresh scan's camera geometry applied.
Result<LightChecks> CheckLights(const scan::CaptureStore& store, const RigModel& fresh_cameras, const std::string& calib,
                                const calibration::DriftThresholds& thresholds) {
  LightChecks checks;
  RigModel rig = fresh_cameras;
  LOOM_ASSIGN_OR_RETURN(const bool has_positions, calibration::ApplyLightPositionCalibration(calib, &rig));
  if (has_positions) {
    LOOM_ASSIGN_OR_RETURN(const calibration::ScanRadiance scan, calibration::ScanRadiance::Open(store, rig));
    LOOM_ASSIGN_OR_RETURN(const std::vector<calibration::LitView> views, scan.LitViews(scan::StepKind::kLightProbe));
    LOOM_ASSIGN_OR_RETURN(const calibration::LightPositions fresh, calibration::CalibrateLightPositions(rig, views));
    checks.positions = calibration::MeasureLightPositionDrift(fresh, thresholds);
    PrintChanges("LED positions against the stored ones", *checks.positions);
    checks.linear_light = calibration::MeasureLinearLightDrift(fresh, thresholds);
    if (checks.linear_light) PrintChanges("the linear light's sweep against the stored one", *checks.linear_light);
    calibration::ApplyLightPositions(fresh, &rig);
  } else {
    std::cout << "LED positions: not compared (" << calib << " holds none: loom calibrate geometry with a light_probe)\n";
  }
  LOOM_ASSIGN_OR_RETURN(const std::optional<calibration::Radiometry> stored_radiometry,
                        calibration::ApplyRadiometryCalibration(calib, &rig));
  if (!stored_radiometry) {
    std::cout << "light intensities: not compared (" << calib << " holds no radiometric calibration: loom calibrate radiometry)\n";
    return checks;
  }
  LOOM_ASSIGN_OR_RETURN(const calibration::ScanRadiance scan, calibration::ScanRadiance::Open(store, rig));
  calibration::RadiometryOptions options;
  options.reference_camera = stored_radiometry->reference_camera;
  LOOM_ASSIGN_OR_RETURN(const calibration::Radiometry fresh, calibration::CalibrateRadiometry(scan, options));
  checks.radiometry = calibration::MeasureRadiometricDrift(fresh, thresholds);
  PrintChanges("against the stored radiometry (reference camera " + fresh.reference_camera + ")", *checks.radiometry);
  return checks;
}

// The projector against the stored one: a fresh calibration of its columns at the target's
// corners, seen by the fresh cameras, starting from the stored projector. Nothing where CALIB
// holds no projector.yaml or the scan showed no structured light on the target.
Result<std::optional<calibration::Changes>> CheckProjector(const scan::CaptureStore& store, const RigModel& fresh_cameras,
                                                           const CalibrationTargetModel& target,
                                                           const calibration::TargetPlacement& placement, const std::string& calib,
                                                           const calibration::DriftThresholds& thresholds) {
  RigModel rig = fresh_cameras;
  LOOM_ASSIGN_OR_RETURN(const bool has_projector, calibration::ApplyProjectorCalibration(calib, &rig));
  if (!has_projector) {
    std::cout << "projector: not compared (" << calib << " holds no projector.yaml: loom calibrate geometry)\n";
    return std::optional<calibration::Changes>();
  }
  if (calibration::StructuredLightAngles(store.info().plan, "target").empty()) {
    std::cout << "projector: not compared (the scan has no structured light on the target)\n";
    return std::optional<calibration::Changes>();
  }
  LOOM_ASSIGN_OR_RETURN(const calibration::ScanRadiance scan, calibration::ScanRadiance::Open(store, rig));
  LOOM_ASSIGN_OR_RETURN(const std::vector<calibration::ProjectorCorrespondence> corners,
                        calibration::TargetCornerColumns(scan, target, placement));
  LOOM_ASSIGN_OR_RETURN(const calibration::ProjectorCalibration fresh, calibration::CalibrateProjector(*rig.projector, {corners, {}}));
  const calibration::Changes changes = calibration::MeasureProjectorDrift(fresh, thresholds);
  PrintChanges("against the stored projector (" + std::to_string(fresh.correspondences) + " target corners decoded)", changes);
  return std::optional<calibration::Changes>(changes);
}

nlohmann::json ChangesJson(const std::optional<calibration::Changes>& changes, const std::string& missing) {
  if (!changes) return "not compared: " + missing;
  nlohmann::json json = {{"unit", changes->unit}, {"exceeded", changes->exceeded}};
  for (const auto& [what, change] : changes->change) json["change"][what] = change;
  return json;
}

}  // namespace

Result<bool> CheckCalibration(const std::string& scan_dir, const std::string& calib, const std::string& json_path) {
  LOOM_ASSIGN_OR_RETURN(const scan::CaptureStore store, OpenCalibrationStore(scan_dir));
  LOOM_ASSIGN_OR_RETURN(const CalibrationScan opened, OpenCalibrationScan(store));
  LOOM_ASSIGN_OR_RETURN(const calibration::DriftThresholds thresholds,
                        DriftThresholdsOf(opened.rig_yaml, scan_dir + "/scan.yaml (rig)"));
  LOOM_ASSIGN_OR_RETURN(const RigModel stored, StoredRig(opened.nominal, calib));
  LOOM_ASSIGN_OR_RETURN(const calibration::DriftReport report,
                        calibration::MeasureDrift(stored, opened.target, opened.detected.views, thresholds));
  PrintDrift(report);
  const RigModel fresh_cameras = calibration::ApplyGeometry(stored, report.fresh);
  LOOM_ASSIGN_OR_RETURN(const LightChecks lights, CheckLights(store, fresh_cameras, calib, thresholds));
  LOOM_ASSIGN_OR_RETURN(const std::optional<calibration::Changes> projector,
                        CheckProjector(store, fresh_cameras, opened.target, report.fresh.target, calib, thresholds));
  const auto exceeded = [](const std::optional<calibration::Changes>& c) { return c && !c->exceeded.empty(); };
  const bool recalibrate = report.recalibrate || exceeded(lights.positions) || exceeded(lights.linear_light) ||
                           exceeded(lights.radiometry) || exceeded(projector);
  std::cout << (recalibrate ? "RECALIBRATE: the stored calibration no longer explains the rig\n" : "calibration holds\n");
  if (!json_path.empty()) {
    nlohmann::json json = DriftJson(report, thresholds, scan_dir, calib);
    json["recalibrate"] = recalibrate;
    json["led_positions"] = ChangesJson(lights.positions, "the calibration holds no LED positions (loom calibrate geometry)");
    json["linear_light"] = ChangesJson(lights.linear_light, "the scan has no view of the light probe under the linear light");
    json["radiometry"] = ChangesJson(lights.radiometry, "the calibration holds no radiometry (loom calibrate radiometry)");
    json["projector"] = ChangesJson(projector, "no projector.yaml in the calibration, or no structured light in the scan");
    LOOM_RETURN_IF_ERROR(WriteFileAtomically(json_path, json.dump(2) + "\n"));
    std::cout << "written: " << json_path << "\n";
  }
  return recalibrate;
}
}  // namespace loom::apps
