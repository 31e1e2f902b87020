#include "calibration/scan_calibration.h"

#include <algorithm>
#include <iomanip>
#include <sstream>

#include "calibration/calibration_directory.h"
#include "calibration/calibration_yaml.h"
#include "calibration/projector_columns.h"
#include "calibration/radiometry_yaml.h"
#include "calibration/scan_radiance.h"
#include "core/file_io.h"
#include "core/output_directory.h"
#include "core/rig_file.h"
#include "core/version.h"

namespace loom::calibration {
namespace {

namespace fs = std::filesystem;

std::string TargetText(const CalibrationTargetModel& t) {
  std::ostringstream text;
  text << "chessboard:" << t.inner_cols << "x" << t.inner_rows << ":" << t.square_mm << " on a " << t.tilt_deg
       << " deg wedge, centre " << t.centre_height_mm << " mm high";
  return text.str();
}

// How far a calibrated camera is from the rig YAML's nominal one.
struct AgainstNominal {
  double rotation_deg, centre_mm, focal_percent;
  AgainstNominal(const CameraModel& nominal, const CameraGeometry& camera)
      : rotation_deg(
            RadToDeg(Eigen::AngleAxisd(camera.cam_from_rig.rotation() * nominal.cam_from_rig.rotation().transpose()).angle())),
        centre_mm((camera.cam_from_rig.inverse().translation() - nominal.CentreInRig()).norm()),
        focal_percent(100 * (camera.intrinsics.K(0, 0) / nominal.K(0, 0) - 1)) {}
};

// The LEDs' positions from the scan's light-probe views (`scan`: over the cameras just
// calibrated); nothing when the scan has none.
Result<std::optional<LightPositions>> CalibrateLights(const ScanRadiance& scan) {
  LOOM_ASSIGN_OR_RETURN(const std::vector<LitView> views, scan.LitViews(scan::StepKind::kLightProbe));
  if (views.empty()) return std::optional<LightPositions>();
  LOOM_ASSIGN_OR_RETURN(LightPositions positions, CalibrateLightPositions(scan.rig(), views));
  return std::optional<LightPositions>(std::move(positions));
}

// The projector's pose from its columns at the target's corners, and its focal length and centre
// from the white tile at two heights (`scan`: over the cameras just calibrated); nothing when the
// scan has no structured light on the target.
Result<std::optional<ProjectorCalibration>> CalibrateProjectorPose(const ScanRadiance& scan, const CalibrationTargetModel& target,
                                                                   const TargetPlacement& placement) {
  const std::optional<ProjectorModel>& projector_model = scan.rig().projector;
  if (!projector_model || StructuredLightAngles(scan.plan(), scan::ScanObject::kTarget).empty()) {
    return std::optional<ProjectorCalibration>();
  }
  ProjectorObservations observed;
  LOOM_ASSIGN_OR_RETURN(observed.corners, TargetCornerColumns(scan, target, placement));
  LOOM_ASSIGN_OR_RETURN(observed.boards, FlatBoardRays(scan));
  LOOM_ASSIGN_OR_RETURN(ProjectorCalibration projector, CalibrateProjector(*projector_model, observed));
  return std::optional<ProjectorCalibration>(std::move(projector));
}

void ReportLights(const std::optional<LightPositions>& positions, std::ostream& out) {
  if (!positions) {
    out << "LED positions: not calibrated (the scan has no light-probe views: the rig YAML needs geometry: light_probe:)\n";
    return;
  }
  double worst_change = 0, worst_residual = 0;
  for (const LightPosition& led : positions->leds) {
    worst_residual = std::max(worst_residual, led.residual_deg);
    worst_change = std::max(worst_change, led.change_mm);
    if (led.change_mm > 2) {
      out << "led " << led.led << ": " << led.change_mm << " mm (" << led.change_deg << " deg) from the rig YAML\n";
    }
  }
  out << "LED positions from the chrome sphere: " << positions->leds.size() << " LEDs, at most " << worst_change
      << " mm from the rig YAML, rays within " << worst_residual << " deg (light_positions.yaml)\n";
  if (const std::optional<LinearLightSweep>& sweep = positions->linear_light) {
    out << "linear light from the chrome sphere: arm at " << sweep->start_deg << " to " << sweep->end_deg
        << " deg over its travel, " << sweep->change_deg << " deg from the rig YAML, " << sweep->views << " views within "
        << sweep->residual_deg << " deg (light_positions.yaml)\n";
  }
}

void ReportProjector(const std::optional<ProjectorCalibration>& projector, std::ostream& out) {
  if (!projector) {
    out << "projector: not calibrated (the scan has no structured light on the target)\n";
    return;
  }
  out << "projector: " << projector->correspondences << " target corners decoded, RMS " << projector->rms_columns
      << " columns; the rig YAML's columns there off by up to " << projector->column_change_px << " px (projector.yaml)\n";
  for (const FlatBoardFit& board : projector->boards) {
    out << "projector: " << board.name << " at " << board.height_mm << " mm (tilted " << board.tilt_deg << " deg), " << board.rays
        << " pixels, RMS " << board.rms_columns << " columns\n";
  }
  if (projector->boards.empty()) {
    out << "projector: focal length and centre kept at the rig YAML's (the scan has no white tile on a spacer under the "
           "patterns)\n";
  } else if (projector->intrinsics_fitted) {
    out << "projector: focal length " << std::showpos << projector->focal_change_percent << " % (1 sigma " << std::noshowpos
        << projector->focal_sigma_percent << " %), centre " << std::showpos << projector->cx_change_px << " px (1 sigma "
        << std::noshowpos << projector->cx_sigma_px << " px) against the rig YAML; the sigmas count the decoding noise only\n";
  } else {
    out << "projector: focal length and centre kept at the rig YAML's: the boards pin them down only to "
        << projector->focal_sigma_percent << " % and " << projector->cx_sigma_px
        << " px (1 sigma; the cameras see too little of the projector's field, 0.1 % and 0.5 px needed)\n";
  }
}

}  // namespace

Result<scan::CaptureStore> OpenCalibrationStore(const fs::path& directory) {
  LOOM_ASSIGN_OR_RETURN(scan::CaptureStore store, scan::CaptureStore::Open(directory));
  if (store.info().plan.purpose != scan::PlanPurpose::kCalibration) {
    return InvalidArgumentError(directory.string(), "is a " + std::string(scan::PlanPurposeName(store.info().plan.purpose)) +
                                                        " scan, not a calibration scan (loom scan --calibration)");
  }
  return store;
}

Result<CalibrationScan> CalibrationScan::Open(const scan::CaptureStore& store) {
  const std::string rig_source = (store.directory() / "scan.yaml").string() + " (rig)";
  CalibrationScan result;
  result.rig_yaml = store.info().rig_yaml;
  LOOM_ASSIGN_OR_RETURN(result.nominal, RigModelFromText(result.rig_yaml, rig_source));
  if (!result.nominal.calibration_target) {
    return InvalidArgumentError(rig_source, "geometry has no calibration_target: what the scan's target is");
  }
  result.target = *result.nominal.calibration_target;
  LOOM_ASSIGN_OR_RETURN(const ScanRadiance scan, ScanRadiance::Open(store, result.nominal));
  LOOM_ASSIGN_OR_RETURN(result.detected, DetectTargetViews(scan, result.target));
  return result;
}

Result<GeometryCalibration> CalibrateGeometryFromScan(const fs::path& scan_dir) {
  LOOM_ASSIGN_OR_RETURN(const scan::CaptureStore store, OpenCalibrationStore(scan_dir));
  LOOM_ASSIGN_OR_RETURN(const CalibrationScan opened, CalibrationScan::Open(store));
  GeometryCalibration result;
  result.scan = scan_dir.string();
  result.target = opened.target;
  result.nominal = opened.nominal;
  result.target_views = static_cast<int>(opened.detected.views.size());
  result.skipped = opened.detected.skipped;
  LOOM_ASSIGN_OR_RETURN(result.geometry, CalibrateRigGeometry(opened.nominal, opened.target, opened.detected.views));
  const RigModel calibrated = ApplyGeometry(opened.nominal, result.geometry);
  // One opening of the scan over the calibrated cameras serves the lights and the projector.
  LOOM_ASSIGN_OR_RETURN(const ScanRadiance scan, ScanRadiance::Open(store, calibrated));
  LOOM_ASSIGN_OR_RETURN(result.lights, CalibrateLights(scan));
  LOOM_ASSIGN_OR_RETURN(result.projector, CalibrateProjectorPose(scan, opened.target, result.geometry.target));
  return result;
}

Result<GeometryCalibration> CalibrateGeometryToDirectory(const fs::path& scan_dir, const fs::path& out) {
  LOOM_ASSIGN_OR_RETURN(OutputDirectory staged, OutputDirectory::Create(out, "--out"));
  LOOM_ASSIGN_OR_RETURN(GeometryCalibration result, CalibrateGeometryFromScan(scan_dir));
  LOOM_RETURN_IF_ERROR(result.Write(staged.partial()));
  LOOM_RETURN_IF_ERROR(staged.Commit());
  return result;
}

Status GeometryCalibration::Write(const fs::path& directory) const {
  LOOM_RETURN_IF_ERROR(CreateDirectories(directory));
  for (const CameraGeometry& camera : geometry.cameras) {
    std::vector<std::string> camera_skipped;
    for (const std::vector<scan::ViewId>* list : {&skipped, &geometry.rejected}) {
      for (const scan::ViewId& view : *list) {
        if (view.camera == camera.name) camera_skipped.push_back(view.ToString());
      }
    }
    const CameraCalibration file{camera.name, camera.intrinsics, camera.cam_from_rig, camera.view_sources, camera_skipped,
                                 scan,        TargetText(target)};
    LOOM_RETURN_IF_ERROR(WriteCameraCalibration(directory / (camera.name + ".yaml"), file));
  }
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(directory / "geometry.json", ToJson().dump(2) + "\n"));
  if (lights) LOOM_RETURN_IF_ERROR(WriteLightPositions(directory, *lights, scan));
  if (projector) LOOM_RETURN_IF_ERROR(WriteProjectorCalibration(directory, *projector, scan));
  return Status::Ok();
}

nlohmann::json GeometryCalibration::ToJson() const {
  nlohmann::json json = {{"scan", scan},
                         {"target", TargetText(target)},
                         {"rms_px", geometry.rms_px},
                         {"target_offset_mm", {geometry.target.offset_mm.x(), geometry.target.offset_mm.y()}},
                         {"skipped", scan::ViewNames(skipped)},
                         {"rejected", scan::ViewNames(geometry.rejected)},
                         {"loom_version", std::string(VersionWithCommit())}};
  for (size_t c = 0; c < geometry.cameras.size(); ++c) {
    const CameraGeometry& camera = geometry.cameras[c];
    const AgainstNominal delta(nominal.cameras[c], camera);
    // The turntable axis (the rig's z through its origin) in the camera's frame.
    const Eigen::Vector3d axis_point = camera.cam_from_rig.translation();
    const Eigen::Vector3d axis_direction = camera.cam_from_rig.rotation().col(2);
    json["cameras"][camera.name] = {
        {"views", camera.view_sources.size()},
        {"rms_px", camera.intrinsics.rms_px},
        {"turntable_axis_in_camera",
         {{"point_mm", {axis_point.x(), axis_point.y(), axis_point.z()}},
          {"direction", {axis_direction.x(), axis_direction.y(), axis_direction.z()}}}},
        {"against_nominal",
         {{"rotation_deg", delta.rotation_deg}, {"centre_mm", delta.centre_mm}, {"focal_percent", delta.focal_percent}}}};
  }
  return json;
}

void GeometryCalibration::Report(std::ostream& out) const {
  out << "target found in " << target_views << " of " << target_views + skipped.size() << " views\n"
      << std::fixed << std::setprecision(3);
  for (size_t c = 0; c < geometry.cameras.size(); ++c) {
    const CameraGeometry& camera = geometry.cameras[c];
    const AgainstNominal delta(nominal.cameras[c], camera);
    out << camera.name << ": " << camera.view_sources.size() << " views, RMS " << camera.intrinsics.rms_px << " px; fx "
        << camera.intrinsics.K(0, 0) << " k1 " << camera.intrinsics.distortion[0] << "; against the rig YAML: rotation "
        << delta.rotation_deg << " deg, centre " << delta.centre_mm << " mm, focal " << delta.focal_percent << " %\n";
  }
  ReportLights(lights, out);
  ReportProjector(projector, out);
  out << "RMS reprojection error " << geometry.rms_px << " px over every camera; target placed at ("
      << geometry.target.offset_mm.x() << ", " << geometry.target.offset_mm.y() << ") mm from the axis\n";
}

Result<RadiometryCalibration> CalibrateRadiometryFromScan(const fs::path& scan_dir, const fs::path& calibration_directory,
                                                          const std::string& reference_camera) {
  LOOM_ASSIGN_OR_RETURN(const scan::CaptureStore store, OpenCalibrationStore(scan_dir));
  LOOM_ASSIGN_OR_RETURN(RigModel rig, RigModelFromText(store.info().rig_yaml, (scan_dir / "scan.yaml").string() + " (rig)"));
  RadiometryCalibration result;
  result.scan = scan_dir.string();
  // Radiometry needs where each pixel looks and where each light shines from.
  LOOM_ASSIGN_OR_RETURN(const AppliedCalibration applied, CalibrationDirectory(calibration_directory).ApplyGeometry(&rig));
  const std::string calib = calibration_directory.string();
  if (applied.cameras.empty()) {
    result.notes.push_back("warning: " + calib + " holds no camera calibration: using the rig YAML's cameras");
  }
  if (!applied.led_positions) result.notes.push_back("note: " + calib + " holds no LED positions: using the rig YAML's");
  LOOM_ASSIGN_OR_RETURN(const ScanRadiance scan, ScanRadiance::Open(store, rig));
  RadiometryOptions options;
  options.reference_camera = reference_camera;
  LOOM_ASSIGN_OR_RETURN(result.radiometry, CalibrateRadiometry(scan, options));
  return result;
}

Status RadiometryCalibration::Write(const fs::path& calibration_directory) const {
  return WriteRadiometry(calibration_directory, radiometry, scan);
}

void RadiometryCalibration::Report(std::ostream& out) const {
  const Radiometry& r = radiometry;
  out << std::defaultfloat << std::setprecision(4)
      << "camera  sensitivity  change     vignetting  flat residual  per-pixel max  black DN  read noise DN  linearity\n";
  for (const CameraRadiometry& c : r.cameras) {
    out << std::left << std::setw(8) << c.name << std::setw(13) << c.sensitivity << std::setw(11)
        << (c.name == r.reference_camera ? std::string("reference") : std::to_string(c.sensitivity_change)) << std::setw(12)
        << c.vignetting << std::setw(15) << c.flat_field_residual << std::setw(15) << c.flat_field_max << std::setw(10)
        << c.black_dn << std::setw(15) << c.read_noise_dn;
    if (std::isnan(c.linearity_deviation)) {
      out << "not measured\n";
    } else {
      out << 100 * c.linearity_deviation << " % up to " << c.linearity_max_dn << " DN\n";
    }
  }
  out << "light          intensity   change    spread between cameras\n";
  for (const LightRadiometry& l : r.lights) {
    out << std::left << std::setw(15) << l.name << std::setw(12) << l.intensity << std::setw(10) << l.change
        << 100 * l.camera_spread << " %\n";
  }
  out << "LED falloff: kept nominal (the white reference subtends " << r.tile_subtends_deg << " deg from an LED)\n";
  for (const FilterRadiometry& f : r.filters) {
    out << f.wheel << " slot " << f.slot << " (" << f.center_nm << " nm): weights " << f.weights.transpose()
        << " (spectral model " << f.nominal_weights.transpose() << "), fit residual " << 100 * f.fit_residual << " %\n";
  }
  for (const WheelColour& w : r.wheels) {
    out << w.wheel << " colour matrix: chart albedos recovered to " << w.chart_rms << " RMS, worst " << w.chart_max << "\n";
  }
  out << std::right;
}

}  // namespace loom::calibration
