#pragma once
// `loom calibrate check`: a fresh calibration scan against a stored calibration directory —
// cameras (drift.h), LED positions and the linear light's sweep, radiometry and the projector —
// with the rig YAML's `recalibration:` thresholds. Each part is measured on the fresh camera
// geometry, so that a camera that moved does not read as a light that changed.

#include <filesystem>
#include <optional>
#include <ostream>
#include <string>

#include <nlohmann/json.hpp>

#include "calibration/drift.h"

namespace loom::calibration {

struct CalibrationCheck {
  // One part compared against the stored calibration, or why it was not.
  struct Part {
    std::string title;               // what was compared, for the report
    std::optional<Changes> changes;  // nothing: not compared
    std::string not_compared;        // why, when not compared
  };

  std::string scan;
  std::string calibration;
  DriftThresholds thresholds;
  DriftReport cameras;
  Part led_positions, linear_light, radiometry, projector;
  bool recalibrate = false;  // some camera or part exceeded its threshold

  nlohmann::json ToJson() const;
  void Report(std::ostream& out) const;
};

// Every camera of the scan's rig needs its stored CAMERA.yaml (an error names the first missing).
Result<CalibrationCheck> CheckCalibration(const std::filesystem::path& scan_dir,
                                          const std::filesystem::path& calibration_directory);

}  // namespace loom::calibration
