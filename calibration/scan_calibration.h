#pragma once
// Calibrating a rig from a calibration scan (loom scan --calibration), as `loom calibrate
// geometry` and `loom calibrate radiometry` run it: each opens the scan, calibrates, and returns
// a result that writes its files into a calibration directory (calibration_directory.h) and
// reports itself (ToJson; Report: a few lines for the operator).

#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calibration/geometry.h"
#include "calibration/light_positions.h"
#include "calibration/projector.h"
#include "calibration/radiometry.h"
#include "core/rig_model.h"
#include "scan/capture_store.h"

namespace loom::calibration {

// A directory that must hold a calibration scan (an error names it otherwise).
Result<scan::CaptureStore> OpenCalibrationStore(const std::filesystem::path& directory);

// A calibration scan's rig (its snapshot of the rig YAML) and the target views found in it.
struct CalibrationScan {
  RigModel nominal;
  CalibrationTargetModel target;
  DetectedTargetViews detected;
  std::string rig_yaml;

  // `store`: OpenCalibrationStore's. Its rig must describe a calibration_target.
  static Result<CalibrationScan> Open(const scan::CaptureStore& store);
};

// `loom calibrate geometry`: every camera's intrinsics and pose in the turntable's frame from the
// target views, then, with those cameras, the LEDs' positions and the linear light's sweep from
// the chrome sphere and the projector's pose (and focal length and centre, where the white tile's
// two heights pin them down) from structured light.
struct GeometryCalibration {
  std::string scan;  // the scan directory
  CalibrationTargetModel target;
  RigModel nominal;  // the scan's rig YAML
  RigGeometry geometry;
  int target_views = 0;                           // views the target was found in
  std::vector<scan::ViewId> skipped;              // target views without a usable board
  std::optional<LightPositions> lights;           // when the scan has light-probe views
  std::optional<ProjectorCalibration> projector;  // when it has structured light on the target

  // CAMERA.yaml files and geometry.json (ToJson), and light_positions.yaml and projector.yaml
  // when they were calibrated, into `directory` (created).
  Status Write(const std::filesystem::path& directory) const;
  nlohmann::json ToJson() const;
  void Report(std::ostream& out) const;
};
Result<GeometryCalibration> CalibrateGeometryFromScan(const std::filesystem::path& scan_dir);
// The same, written into the new directory `out` (whole or not at all; `out` checked first).
Result<GeometryCalibration> CalibrateGeometryToDirectory(const std::filesystem::path& scan_dir, const std::filesystem::path& out);

// `loom calibrate radiometry`: light intensities, camera sensitivities and flat fields, filter
// colour weights and linearity from the white reference and the colour chart, over the cameras
// and LED positions a calibration directory holds.
struct RadiometryCalibration {
  std::string scan;
  Radiometry radiometry;
  std::vector<std::string> notes;  // parts of the calibration directory that were missing

  // DIR/radiometry/*.yaml.
  Status Write(const std::filesystem::path& calibration_directory) const;
  void Report(std::ostream& out) const;
};
// `reference_camera`: empty picks the one looking most nearly straight down.
Result<RadiometryCalibration> CalibrateRadiometryFromScan(const std::filesystem::path& scan_dir,
                                                          const std::filesystem::path& calibration_directory,
                                                          const std::string& reference_camera);

}  // namespace loom::calibration
