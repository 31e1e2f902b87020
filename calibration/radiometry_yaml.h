#pragma once
// Radiometric calibration files: one self-describing YAML per device in CALIB/radiometry/,
// beside the geometric calibration's CAMERA.yaml files (calibration_yaml.h):
//
//   CAMERA.yaml        device: camera — sensitivity (electrons per radiance unit · s), vignetting,
//                      black level and read noise (DN), linearity, flat-field residual
//   leds.yaml          device: leds — per LED: radiant intensity at 1000 mA, falloff exponent
//                      (nominal: not observable, with the angle the tile subtends), change
//   linear_light.yaml  device: linear_light — intensity per mm of strip, change
//   WHEEL.yaml         device: filter_wheel — per band-pass slot: colour weights (what a camera
//                      records of an RGB albedo) and the spectral model's; the colour matrix
//                      (filter readings → linear sRGB) and its error on the chart
//
// Each also records the reference camera (whose sensitivity anchors the scale), the white
// reference's albedo and the scan it came from. Written atomically; read strictly (a wrong key,
// or a device the rig does not have, names the file).

#include <filesystem>
#include <optional>
#include <string>

#include "calibration/radiometry.h"

namespace loom::calibration {

// Writes DIR/radiometry/*.yaml, replacing an earlier radiometry/ whole; `from`: the scan.
Status WriteRadiometry(const std::filesystem::path& directory, const Radiometry& radiometry, const std::string& from);
// Reads DIR/radiometry/ for `rig` (the device names and counts it must match).
Result<Radiometry> ReadRadiometry(const std::filesystem::path& directory, const RigModel& rig);
// Applies DIR/radiometry/ over `rig` when the calibration directory has one; returns what it
// applied (nothing without one).
Result<std::optional<Radiometry>> ApplyRadiometryCalibration(const std::filesystem::path& directory, RigModel* rig);

}  // namespace loom::calibration
