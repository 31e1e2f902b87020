#pragma once
// Calibration files: one self-describing YAML per device, e.g. for a camera
//
//   schema_version: 1
//   device: camera
//   name: cam0
//   model: pinhole + OpenCV 5-term distortion (k1 k2 p1 p2 k3); pixel centres at integers
//   image_size_px: [2048, 1536]
//   K_px: [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]
//   distortion: [k1, k2, p1, p2, k3]
//   cam_from_rig: {rotation: [[...]], translation_mm: [...]}   # when known (loom calibrate geometry)
//   quality: {rms_px: 0.21, views: [{source: left01.jpg, rms_px: 0.19}, ...], skipped: [...]}
//   source: {from: "DIR/*.jpg", board: "chessboard:9x6:25", loom_version: ..., created: ...}
//
// Written atomically; read strictly (a wrong key names the file and the key).

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "calibration/intrinsics.h"

namespace loom::calibration {

struct CameraCalibration {
  std::string name;
  Intrinsics intrinsics;
  std::optional<Rigid3d> cam_from_rig;
  std::vector<std::string> view_sources;  // one per intrinsics.per_view_rms_px
  std::vector<std::string> skipped;       // views without a usable board
  std::string from;                       // the images or scan it came from
  std::string board;
};

Status WriteCameraCalibration(const std::filesystem::path& path, const CameraCalibration& calibration);
Result<CameraCalibration> ReadCameraCalibration(const std::filesystem::path& path);

// A calibration directory over a rig's nominal description: every camera of `rig` with a file
// DIR/<camera>.yaml gets its intrinsics, and its extrinsics when the file has them. Returns the
// cameras replaced. A file of another image size than the camera's is an error naming it.
// Calibrated poses are in the turntable's frame, which then becomes the rig's: when one file has
// cam_from_rig, every camera needs one (an error names the first without).
Result<std::vector<std::string>> ApplyCameraCalibrations(const std::filesystem::path& directory, RigModel* rig);

}  // namespace loom::calibration
