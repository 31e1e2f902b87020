#pragma once
// A calibration directory, as `loom calibrate` writes it — CAMERA.yaml files (calibration_yaml.h),
// light_positions.yaml (light_positions.h), projector.yaml (projector.h), radiometry/
// (radiometry_yaml.h) — applied over a rig's nominal description (its rig YAML's `geometry:`).
// Every part is optional: what the directory does not hold stays nominal.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calibration/radiometry.h"
#include "core/rig_model.h"

namespace loom::calibration {

// What a calibration directory replaced in a rig.
struct AppliedCalibration {
  std::vector<std::string> cameras;  // cameras with their calibrated intrinsics (and poses)
  bool led_positions = false;        // LED positions and the linear light's sweep
  bool projector = false;
  std::optional<Radiometry> radiometry;  // light intensities, camera sensitivities, filter colours

  // Each part: calibrated, or nominal (the rig YAML's).
  nlohmann::json ToJson() const;
};

class CalibrationDirectory {
 public:
  explicit CalibrationDirectory(std::filesystem::path path) : path_(std::move(path)) {}
  const std::filesystem::path& path() const { return path_; }

  // Every part the directory holds, applied to `rig`. A file that does not fit the rig (another
  // image size, number of LEDs, device name) is an error naming the file.
  Result<AppliedCalibration> Apply(RigModel* rig) const;
  // Only the cameras and LED positions: where each pixel looks and where each light shines from,
  // what a radiometric calibration starts from.
  Result<AppliedCalibration> ApplyGeometry(RigModel* rig) const;

 private:
  std::filesystem::path path_;
};

}  // namespace loom::calibration
