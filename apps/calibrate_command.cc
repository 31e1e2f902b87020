// loom calibrate: turn calibration captures into calibration files (calibration/).
//   intrinsics  one camera from a folder of photos of a chessboard (recalibration in the field)
//   geometry    every camera's intrinsics and pose in the turntable's frame from a calibration scan
//   radiometry  light intensities, camera sensitivity and flat field, filter colours from a calibration scan
//   check       how far a fresh calibration scan has drifted from a stored calibration (calibrate_check.cc)
#include <filesystem>
#include <iostream>

#include "apps/command.h"
#include "calibration/calibration_check.h"
#include "calibration/calibration_yaml.h"
#include "calibration/photo_intrinsics.h"
#include "calibration/scan_calibration.h"
#include "core/file_io.h"
#include "core/output_file.h"

namespace loom::apps {
namespace {

Status CalibrateFromPhotos(const std::string& images, const std::string& board_text, const std::string& name,
                           const std::string& out, bool force) {
  LOOM_RETURN_IF_ERROR(CheckOutputFile(out, "--out", force));
  LOOM_ASSIGN_OR_RETURN(const calibration::BoardSpec board, calibration::ParseBoardSpec(board_text));
  std::cerr << "looking for " << board.ToString() << " in " << images << "\n";
  LOOM_ASSIGN_OR_RETURN(const calibration::CameraCalibration result, calibration::CalibrateFromPhotos(images, board, name));
  LOOM_RETURN_IF_ERROR(calibration::WriteCameraCalibration(out, result));
  calibration::ReportPhotoCalibration(std::cout, result);
  std::cout << "written: " << out << "\n";
  return Status::Ok();
}

namespace fs = std::filesystem;

// `loom calibrate check`: the stored calibration no longer explains the rig.
constexpr int kExitRecalibrate = 3;

Status CalibrateGeometry(const std::string& scan_dir, const std::string& out) {
  LOOM_ASSIGN_OR_RETURN(const calibration::GeometryCalibration result, calibration::CalibrateGeometryToDirectory(scan_dir, out));
  result.Report(std::cout);
  std::cout << "written: " << out
            << " (one YAML per camera, geometry.json; light_positions.yaml, projector.yaml when the scan has what they need)\n";
  return Status::Ok();
}

Status CalibrateRadiometry(const std::string& scan_dir, const std::string& calib, const std::string& reference_camera) {
  LOOM_ASSIGN_OR_RETURN(const calibration::RadiometryCalibration result,
                        calibration::CalibrateRadiometryFromScan(scan_dir, calib, reference_camera));
  for (const std::string& note : result.notes) std::cerr << note << "\n";
  LOOM_RETURN_IF_ERROR(result.Write(calib));
  result.Report(std::cout);
  std::cout << "written: " << (fs::path(calib) / "radiometry").string() << " (one YAML per camera, leds, linear_light, wheel)\n";
  return Status::Ok();
}

// Returns whether to recalibrate.
Result<bool> CheckCalibration(const std::string& scan_dir, const std::string& calib, const std::string& json_path, bool force) {
  LOOM_RETURN_IF_ERROR(CheckOutputFiles({{"--json", json_path}}, force));
  LOOM_ASSIGN_OR_RETURN(const calibration::CalibrationCheck check, calibration::CheckCalibration(scan_dir, calib));
  check.Report(std::cout);
  if (!json_path.empty()) {
    LOOM_RETURN_IF_ERROR(WriteJsonReport(json_path, check.ToJson()));
    std::cout << "written: " << json_path << "\n";
  }
  return check.recalibrate;
}

}  // namespace

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
  bool force = false;
  AddForceOption(*intrinsics, force);
  std::string scan;
  CLI::App* geometry = app.add_subcommand(
      "geometry",
      "Camera poses from a calibration scan's target views, the LEDs' positions and the linear light's sweep from the "
      "chrome sphere, the projector from its patterns");
  geometry->add_option("scan", scan, "Calibration scan directory (loom scan --calibration)")->required();
  geometry
      ->add_option("--out", out,
                   "Calibration directory to write: CAMERA.yaml files, geometry.json, light_positions.yaml, "
                   "projector.yaml")
      ->required();
  std::string calib, json, reference_camera;
  CLI::App* radiometry = app.add_subcommand(
      "radiometry",
      "Light intensities, camera sensitivity and flat field, filter colour weights and camera linearity from a "
      "calibration scan's white reference and colour chart");
  radiometry->add_option("scan", scan, "Calibration scan directory (loom scan --calibration)")->required();
  radiometry
      ->add_option("--calib", calib,
                   "Calibration directory with the cameras (loom calibrate geometry); radiometry/ is written into it")
      ->required();
  radiometry->add_option(
      "--reference-camera", reference_camera,
      "The camera that keeps its sensitivity and anchors the scale (default: the one looking most nearly straight down)");
  CLI::App* check =
      app.add_subcommand("check", "How far a fresh calibration scan has drifted from a stored calibration; exit status " +
                                      std::to_string(kExitRecalibrate) +
                                      " when it is time to recalibrate (thresholds: the rig YAML's recalibration:)");
  check->add_option("scan", scan, "Fresh calibration scan directory (loom scan --calibration)")->required();
  check->add_option("--calib", calib, "The stored calibration directory (loom calibrate geometry --out)")->required();
  check->add_option("--json", json, "Also write the measurements to this JSON file");
  AddForceOption(*check, force);
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  Status done;
  if (*intrinsics) done = CalibrateFromPhotos(images, board, name, out, force);
  if (*geometry) done = CalibrateGeometry(scan, out);
  if (*radiometry) done = CalibrateRadiometry(scan, calib, reference_camera);
  if (*check) {
    const Result<bool> recalibrate = CheckCalibration(scan, calib, json, force);
    if (recalibrate.ok()) return *recalibrate ? kExitRecalibrate : kExitOk;
    done = recalibrate.status();
  }
  return ExitCode(done);
}

}  // namespace loom::apps
