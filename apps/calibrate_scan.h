#pragma once
// What the `loom calibrate` subcommands share (calibrate_command.cc, calibrate_check.cc): opening
// a calibration scan, and `check` itself.

#include <string>

#include "calibration/geometry.h"
#include "core/rig_model.h"
#include "scan/capture_store.h"

namespace loom::apps {

// `loom calibrate check`: the stored calibration no longer explains the rig.
inline constexpr int kExitRecalibrate = 3;

// A calibration scan's rig (its snapshot) and the target views in it.
struct CalibrationScan {
  RigModel nominal;
  CalibrationTargetModel target;
  calibration::DetectedTargetViews detected;
  std::string rig_yaml;
};

// A scan directory that must hold a calibration scan (an error names it otherwise).
Result<scan::CaptureStore> OpenCalibrationStore(const std::string& scan_dir);
// Its rig snapshot and the target views detected in it (`store`: OpenCalibrationStore's).
Result<CalibrationScan> OpenCalibrationScan(const scan::CaptureStore& store);

// loom calibrate check: prints the comparison, writes it to `json_path` when given; returns
// whether to recalibrate.
Result<bool> CheckCalibration(const std::string& scan_dir, const std::string& calib, const std::string& json_path);

}  // namespace loom::apps
