// loom calibrate: turn calibration captures into calibration files (calibration/).
//   intrinsics  one camera from a folder of photos of a chessboard (recalibration in the field)
//   geometry    every camera's intrinsics and pose in the turntable's frame from a calibration scan
//   radiometry  light intensities, camera sensitivity and flat field, filter colours from a calibration scan
//   check       how far a fresh calibration scan has drifted from a stored calibration (calibrate_check.cc)
#include <glob.h>

#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <iostream>

#include <nlohmann/json.hpp>

#include "apps/calibrate_scan.h"
#include "apps/command.h"
#include "apps/rig_loader.h"
#include "calibration/calibration_yaml.h"
#include "calibration/drift.h"
#include "calibration/geometry.h"
#include "calibration/intrinsics.h"
#include "calibration/light_positions.h"
#include "calibration/projector.h"
#include "calibration/projector_columns.h"
#include "calibration/radiometry.h"
#include "calibration/radiometry_yaml.h"
#include "core/file_io.h"
#include "core/version.h"
#include "scan/capture_store.h"

namespace loom::apps {
namespace {

Result<std::vector<std::string>> ExpandGlob(const std::string& pattern) {
  glob_t matches{};
  const int code = ::glob(pattern.c_str(), 0, nullptr, &matches);
  std::vector<std::string> files(matches.gl_pathv, matches.gl_pathv + matches.gl_pathc);
  ::globfree(&matches);
  if (code == GLOB_NOMATCH || files.empty()) return NotFoundError("--images '" + pattern + "'", "matches no file");
  if (code != 0) return IoError("--images '" + pattern + "'", "cannot be expanded");
  std::sort(files.begin(), files.end());
  return files;
}

Status CalibrateFromPhotos(const std::string& images, const std::string& board_text, const std::string& name,
                  const std::string& out) {
  LOOM_ASSIGN_OR_RETURN(const calibration::BoardSpec board, calibration::ParseBoardSpec(board_text));
  LOOM_ASSIGN_OR_RETURN(const std::vector<std::string> files, ExpandGlob(images));
  std::cerr << "looking for " << board.ToString() << " in " << files.size() << " images\n";
  LOOM_ASSIGN_OR_RETURN(const calibration::DetectedViews detected, calibration::DetectBoardInFiles(files, board));
  LOOM_ASSIGN_OR_RETURN(const calibration::Intrinsics intrinsics,
                        calibration::CalibrateIntrinsics(board, detected.views, detected.width, detected.height));
  calibration::CameraCalibration result{name, intrinsics, std::nullopt, {}, detected.skipped, images, board.ToString()};
  for (const calibration::BoardView& view : detected.views) result.view_sources.push_back(view.source);
  LOOM_RETURN_IF_ERROR(calibration::WriteCameraCalibration(out, result));
  std::cout << std::fixed << std::setprecision(3) << "board found in " << detected.views.size() << " of " << files.size()
            << " images; RMS reprojection error " << intrinsics.rms_px << " px\n"
            << "fx " << intrinsics.K(0, 0) << "  fy " << intrinsics.K(1, 1) << "  cx " << intrinsics.K(0, 2) << "  cy "
            << intrinsics.K(1, 2) << " px;  k1 " << intrinsics.distortion[0] << "  k2 " << intrinsics.distortion[1]
            << "\nworst view: ";
  const auto worst = std::max_element(intrinsics.per_view_rms_px.begin(), intrinsics.per_view_rms_px.end());
  std::cout << result.view_sources[worst - intrinsics.per_view_rms_px.begin()] << " (" << *worst << " px)\n"
            << "written: " << out << "\n";
  return Status::Ok();
}

namespace fs = std::filesystem;

std::string TargetText(const CalibrationTargetModel& t) {
  std::ostringstream text;
  text << "chessboard:" << t.inner_cols << "x" << t.inner_rows << ":" << t.square_mm << " on a " << t.tilt_deg
       << " deg wedge, centre " << t.centre_height_mm << " mm high";
  return text.str();
}

// How far a calibrated camera is from the rig YAML's nominal one.
nlohmann::json AgainstNominal(const CameraModel& nominal, const calibration::CameraGeometry& camera) {
  const Eigen::AngleAxisd rotation(camera.cam_from_rig.rotation() * nominal.cam_from_rig.rotation().transpose());
  return {{"rotation_deg", RadToDeg(rotation.angle())},
          {"centre_mm", (camera.cam_from_rig.inverse().translation() - nominal.CentreInRig()).norm()},
          {"focal_percent", 100 * (camera.intrinsics.K(0, 0) / nominal.K(0, 0) - 1)}};
}

// The LEDs' positions from the scan's light-probe views, with the cameras just calibrated.
Status CalibrateLights(const scan::CaptureStore& store, const RigModel& calibrated, const std::string& out) {
  const std::string scan_dir = store.directory().string();
  LOOM_ASSIGN_OR_RETURN(const calibration::ScanRadiance scan, calibration::ScanRadiance::Open(store, calibrated));
  LOOM_ASSIGN_OR_RETURN(const std::vector<calibration::LitView> views, scan.LitViews(scan::StepKind::kLightProbe));
  if (views.empty()) {
    std::cout << "LED positions: not calibrated (the scan has no light-probe views: the rig YAML needs geometry: light_probe:)\n";
    return Status::Ok();
  }
  LOOM_ASSIGN_OR_RETURN(const calibration::LightPositions positions, calibration::CalibrateLightPositions(calibrated, views));
  LOOM_RETURN_IF_ERROR(calibration::WriteLightPositions(out, positions, scan_dir));
  double worst_change = 0, worst_residual = 0;
  for (const calibration::LightPosition& led : positions.leds) {
    worst_residual = std::max(worst_residual, led.residual_deg);
    worst_change = std::max(worst_change, led.change_mm);
    if (led.change_mm > 2) std::cout << "led " << led.led << ": " << led.change_mm << " mm (" << led.change_deg << " deg) from the rig YAML\n";
  }
  std::cout << "LED positions from the chrome sphere: " << positions.leds.size() << " LEDs, at most " << worst_change
            << " mm from the rig YAML, rays within " << worst_residual << " deg (light_positions.yaml)\n";
  if (const std::optional<calibration::LinearLightSweep>& sweep = positions.linear_light) {
    std::cout << "linear light from the chrome sphere: arm at " << sweep->start_deg << " to " << sweep->end_deg
              << " deg over its travel, " << sweep->change_deg << " deg from the rig YAML, " << sweep->views
              << " views within " << sweep->residual_deg << " deg (light_positions.yaml)\n";
  }
  return Status::Ok();
}

void PrintProjector(const calibration::ProjectorCalibration& projector) {
  std::cout << "projector: " << projector.correspondences << " target corners decoded, RMS " << projector.rms_columns
            << " columns; the rig YAML's columns there off by up to " << projector.column_change_px << " px (projector.yaml)\n";
  for (const calibration::FlatBoardFit& board : projector.boards) {
    std::cout << "projector: " << board.name << " at " << board.height_mm << " mm (tilted " << board.tilt_deg << " deg), "
              << board.rays << " pixels, RMS " << board.rms_columns << " columns\n";
  }
  if (projector.boards.empty()) {
    std::cout << "projector: focal length and centre kept at the rig YAML's (the scan has no white tile on a spacer under the patterns)\n";
  } else if (projector.intrinsics_fitted) {
    std::cout << "projector: focal length " << std::showpos << projector.focal_change_percent << " % (1 sigma " << std::noshowpos
              << projector.focal_sigma_percent << " %), centre " << std::showpos << projector.cx_change_px << " px (1 sigma "
              << std::noshowpos << projector.cx_sigma_px << " px) against the rig YAML; the sigmas count the decoding noise only\n";
  } else {
    std::cout << "projector: focal length and centre kept at the rig YAML's: the boards pin them down only to " << projector.focal_sigma_percent
              << " % and " << projector.cx_sigma_px << " px (1 sigma; the cameras see too little of the projector's field, 0.1 % and 0.5 px needed)\n";
  }
}

// The projector's pose from its columns at the target's corners, and its focal length and centre
// from the white tile at two heights, with the cameras just calibrated.
Status CalibrateProjectorPose(const scan::CaptureStore& store, const RigModel& calibrated, const CalibrationTargetModel& target,
                              const calibration::TargetPlacement& placement, const std::string& out) {
  const std::string scan_dir = store.directory().string();
  if (!calibrated.projector || calibration::StructuredLightAngles(store.info().plan, "target").empty()) {
    std::cout << "projector: not calibrated (the scan has no structured light on the target)\n";
    return Status::Ok();
  }
  LOOM_ASSIGN_OR_RETURN(const calibration::ScanRadiance scan, calibration::ScanRadiance::Open(store, calibrated));
  calibration::ProjectorObservations observed;
  LOOM_ASSIGN_OR_RETURN(observed.corners, calibration::TargetCornerColumns(scan, target, placement));
  LOOM_ASSIGN_OR_RETURN(observed.boards, calibration::FlatBoardRays(scan));
  LOOM_ASSIGN_OR_RETURN(const calibration::ProjectorCalibration projector, calibration::CalibrateProjector(*calibrated.projector, observed));
  LOOM_RETURN_IF_ERROR(calibration::WriteProjectorCalibration(out, projector, scan_dir));
  PrintProjector(projector);
  return Status::Ok();
}

Status CalibrateGeometry(const std::string& scan_dir, const std::string& out) {
  LOOM_ASSIGN_OR_RETURN(const scan::CaptureStore store, OpenCalibrationStore(scan_dir));
  LOOM_ASSIGN_OR_RETURN(const CalibrationScan opened, OpenCalibrationScan(store));
  const RigModel& nominal = opened.nominal;
  const CalibrationTargetModel& target = opened.target;
  const calibration::DetectedTargetViews& detected = opened.detected;
  LOOM_ASSIGN_OR_RETURN(const calibration::RigGeometry geometry,
                        calibration::CalibrateRigGeometry(nominal, target, detected.views));
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) return IoError(out, "cannot create: " + ec.message());
  nlohmann::json summary = {{"scan", scan_dir}, {"target", TargetText(target)}, {"rms_px", geometry.rms_px},
                            {"target_offset_mm", {geometry.target.offset_mm.x(), geometry.target.offset_mm.y()}},
                            {"skipped", detected.skipped}, {"rejected", geometry.rejected}, {"loom_version", std::string(VersionWithCommit())}};
  std::cout << std::fixed << std::setprecision(3);
  for (size_t c = 0; c < geometry.cameras.size(); ++c) {
    const calibration::CameraGeometry& camera = geometry.cameras[c];
    std::vector<std::string> skipped;
    for (const std::vector<std::string>* list : {&detected.skipped, &geometry.rejected}) {
      for (const std::string& view : *list) {
        if (view.ends_with(" " + camera.name)) skipped.push_back(view);
      }
    }
    const calibration::CameraCalibration file{camera.name, camera.intrinsics, camera.cam_from_rig, camera.view_sources,
                                              skipped, scan_dir, TargetText(target)};
    LOOM_RETURN_IF_ERROR(calibration::WriteCameraCalibration(fs::path(out) / (camera.name + ".yaml"), file));
    const nlohmann::json nominal_delta = AgainstNominal(nominal.cameras[c], camera);
    // The turntable axis (the rig's z through its origin) in the camera's frame.
    const Eigen::Vector3d axis_point = camera.cam_from_rig.translation();
    const Eigen::Vector3d axis_direction = camera.cam_from_rig.rotation().col(2);
    summary["cameras"][camera.name] = {{"views", camera.view_sources.size()}, {"rms_px", camera.intrinsics.rms_px},
                                       {"turntable_axis_in_camera", {{"point_mm", {axis_point.x(), axis_point.y(), axis_point.z()}},
                                                                     {"direction", {axis_direction.x(), axis_direction.y(), axis_direction.z()}}}},
                                       {"against_nominal", nominal_delta}};
    std::cout << camera.name << ": " << camera.view_sources.size() << " views, RMS " << camera.intrinsics.rms_px
              << " px; fx " << camera.intrinsics.K(0, 0) << " k1 " << camera.intrinsics.distortion[0]
              << "; against the rig YAML: rotation " << nominal_delta["rotation_deg"].get<double>() << " deg, centre "
              << nominal_delta["centre_mm"].get<double>() << " mm, focal " << nominal_delta["focal_percent"].get<double>()
              << " %\n";
  }
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(fs::path(out) / "geometry.json", summary.dump(2) + "\n"));
  const RigModel calibrated = calibration::ApplyGeometry(nominal, geometry);
  LOOM_RETURN_IF_ERROR(CalibrateLights(store, calibrated, out));
  LOOM_RETURN_IF_ERROR(CalibrateProjectorPose(store, calibrated, target, geometry.target, out));
  std::cout << "RMS reprojection error " << geometry.rms_px << " px over every camera; target placed at ("
            << geometry.target.offset_mm.x() << ", " << geometry.target.offset_mm.y() << ") mm from the axis\n"
            << "written: " << out << " (one YAML per camera, geometry.json; light_positions.yaml, projector.yaml when the scan has what they need)\n";
  return Status::Ok();
}

void PrintRadiometry(const calibration::Radiometry& r) {
  std::cout << std::defaultfloat << std::setprecision(4)
            << "camera  sensitivity  change     vignetting  flat residual  black DN  read noise DN  linearity\n";
  for (const calibration::CameraRadiometry& c : r.cameras) {
    std::cout << std::left << std::setw(8) << c.name << std::setw(13) << c.sensitivity << std::setw(11)
              << (c.name == r.reference_camera ? std::string("reference") : std::to_string(c.sensitivity_change)) << std::setw(12)
              << c.vignetting << std::setw(15) << c.flat_field_residual << std::setw(10) << c.black_dn << std::setw(15)
              << c.read_noise_dn;
    if (std::isnan(c.linearity_deviation)) {
      std::cout << "not measured\n";
    } else {
      std::cout << 100 * c.linearity_deviation << " % up to " << c.linearity_max_dn << " DN\n";
    }
  }
  std::cout << "light          intensity   change    spread between cameras\n";
  for (const calibration::LightRadiometry& l : r.lights) {
    std::cout << std::left << std::setw(15) << l.name << std::setw(12) << l.intensity << std::setw(10) << l.change
              << 100 * l.camera_spread << " %\n";
  }
  std::cout << "LED falloff: kept nominal (the white reference subtends " << r.tile_subtends_deg << " deg from an LED)\n";
  for (const calibration::FilterRadiometry& f : r.filters) {
    std::cout << f.wheel << " slot " << f.slot << " (" << f.center_nm << " nm): weights " << f.weights.transpose()
              << " (spectral model " << f.nominal_weights.transpose() << "), fit residual " << 100 * f.fit_residual << " %\n";
  }
  for (const calibration::WheelColour& w : r.wheels) {
    std::cout << w.wheel << " colour matrix: chart albedos recovered to " << w.chart_rms << " RMS, worst " << w.chart_max << "\n";
  }
  std::cout << std::right;
}

// The scan's rig with the cameras and LED positions CALIB holds: radiometry needs where each
// pixel looks and where each light shines from.
Result<RigModel> WithStoredGeometry(const RigModel& nominal, const std::string& calib) {
  RigModel rig = nominal;
  LOOM_ASSIGN_OR_RETURN(const std::vector<std::string> applied, calibration::ApplyCameraCalibrations(calib, &rig));
  if (applied.empty()) std::cerr << "warning: " << calib << " holds no camera calibration: using the rig YAML's cameras\n";
  LOOM_ASSIGN_OR_RETURN(const bool lights, calibration::ApplyLightPositionCalibration(calib, &rig));
  if (!lights) std::cerr << "note: " << calib << " holds no LED positions: using the rig YAML's\n";
  return rig;
}

Status CalibrateRadiometry(const std::string& scan_dir, const std::string& calib, const std::string& reference_camera) {
  LOOM_ASSIGN_OR_RETURN(const scan::CaptureStore store, OpenCalibrationStore(scan_dir));
  LOOM_ASSIGN_OR_RETURN(const RigModel nominal, LoadRigModelFromText(store.info().rig_yaml, scan_dir + "/scan.yaml (rig)"));
  LOOM_ASSIGN_OR_RETURN(const RigModel rig, WithStoredGeometry(nominal, calib));
  LOOM_ASSIGN_OR_RETURN(const calibration::ScanRadiance scan, calibration::ScanRadiance::Open(store, rig));
  calibration::RadiometryOptions options;
  options.reference_camera = reference_camera;
  LOOM_ASSIGN_OR_RETURN(const calibration::Radiometry radiometry, calibration::CalibrateRadiometry(scan, options));
  LOOM_RETURN_IF_ERROR(calibration::WriteRadiometry(calib, radiometry, scan_dir));
  PrintRadiometry(radiometry);
  std::cout << "written: " << (fs::path(calib) / "radiometry").string() << " (one YAML per camera, leds, linear_light, wheel)\n";
  return Status::Ok();
}

}  // namespace

Result<scan::CaptureStore> OpenCalibrationStore(const std::string& scan_dir) {
  LOOM_ASSIGN_OR_RETURN(scan::CaptureStore store, scan::CaptureStore::Open(scan_dir));
  if (store.info().plan.purpose != "calibration") {
    return InvalidArgumentError(scan_dir, "is a " + store.info().plan.purpose + " scan, not a calibration scan (loom scan --calibration)");
  }
  return store;
}

Result<CalibrationScan> OpenCalibrationScan(const scan::CaptureStore& store) {
  const std::string scan_dir = store.directory().string();
  CalibrationScan result;
  result.rig_yaml = store.info().rig_yaml;
  LOOM_ASSIGN_OR_RETURN(result.nominal, LoadRigModelFromText(result.rig_yaml, scan_dir + "/scan.yaml (rig)"));
  if (!result.nominal.calibration_target) {
    return InvalidArgumentError(scan_dir + "/scan.yaml (rig)", "geometry has no calibration_target: what the scan's target is");
  }
  result.target = *result.nominal.calibration_target;
  LOOM_ASSIGN_OR_RETURN(const calibration::ScanRadiance scan, calibration::ScanRadiance::Open(store, result.nominal));
  LOOM_ASSIGN_OR_RETURN(result.detected, calibration::DetectTargetViews(scan, result.target));
  std::cerr << "target found in " << result.detected.views.size() << " of "
            << result.detected.views.size() + result.detected.skipped.size() << " views\n";
  return result;
}

int RunCalibrate(int argc, char** argv) {
  CLI::App app("Calibrate cameras, lights and radiometry from calibration captures", "loom calibrate");
  AddCommonOptions(app);
  app.require_subcommand(1);
  std::string images, board = "chessboard:9x6:25", name = "camera", out;
  CLI::App* intrinsics = app.add_subcommand(
      "intrinsics", "One camera's intrinsics and distortion from photos of a chessboard (e.g. after a lens change)");
  intrinsics->add_option("--images", images, "Glob of the photos, quoted: 'DIR/*.jpg'")->required();
  intrinsics->add_option("--board", board, "chessboard:COLSxROWS:SQUARE_MM, inner corners (default chessboard:9x6:25)");
  intrinsics->add_option("--name", name, "The camera's name in the rig (default: camera)");
  intrinsics->add_option("--out", out, "Calibration YAML to write")->required();
  std::string scan;
  CLI::App* geometry = app.add_subcommand(
      "geometry", "Every camera's pose in the turntable's frame from a calibration scan's target views; the LEDs' positions and "
                  "the linear light's sweep from the chrome sphere; the projector's pose from its columns on the target (and its "
                  "focal length and centre from the white tile at two heights, where the cameras see enough of its field)");
  geometry->add_option("scan", scan, "Calibration scan directory (loom scan --calibration)")->required();
  geometry->add_option("--out", out, "Calibration directory to write: CAMERA.yaml files, geometry.json, light_positions.yaml, "
                                     "projector.yaml")->required();
  std::string calib, json, reference_camera;
  CLI::App* radiometry = app.add_subcommand(
      "radiometry", "Light intensities, camera sensitivity and flat field, filter colour weights and camera linearity from a "
                    "calibration scan's white reference and colour chart");
  radiometry->add_option("scan", scan, "Calibration scan directory (loom scan --calibration)")->required();
  radiometry->add_option("--calib", calib, "Calibration directory with the cameras (loom calibrate geometry); radiometry/ is written into it")
      ->required();
  radiometry->add_option("--reference-camera", reference_camera,
                         "The camera that keeps its sensitivity and anchors the scale (default: the one looking most nearly straight down)");
  CLI::App* check = app.add_subcommand(
      "check", "How far a fresh calibration scan has drifted from a stored calibration; exit status " +
                   std::to_string(kExitRecalibrate) + " when it is time to recalibrate (thresholds: the rig YAML's recalibration:)");
  check->add_option("scan", scan, "Fresh calibration scan directory (loom scan --calibration)")->required();
  check->add_option("--calib", calib, "The stored calibration directory (loom calibrate geometry --out)")->required();
  check->add_option("--json", json, "Also write the measurements to this JSON file");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  Status done;
  if (*intrinsics) done = CalibrateFromPhotos(images, board, name, out);
  if (*geometry) done = CalibrateGeometry(scan, out);
  if (*radiometry) done = CalibrateRadiometry(scan, calib, reference_camera);
  if (*check) {
    const Result<bool> recalibrate = CheckCalibration(scan, calib, json);
    if (recalibrate.ok()) return *recalibrate ? kExitRecalibrate : kExitOk;
    done = recalibrate.status();
  }
  return done.ok() ? kExitOk : ReportFailure(done);
}

}  // namespace loom::apps
