#pragma once
// Geometric calibration of the rig's cameras from views of its calibration target (a chessboard
// on a wedge, core/rig_model.h's CalibrationTargetModel) on the turntable at several angles.
//
// The rig frame is the turntable's: z along its axis, the origin where the axis meets the
// turntable, x along the target's rows at turntable angle 0. So every view k of camera c obeys
//   cam_from_board(c, k) = cam_from_rig(c) · Rz(θ_k) · Translate(offset) · Rz(yaw) · sample_from_board
// with θ_k the recorded turntable angle, sample_from_board the wedge (tilt, centre height) and
// offset and yaw where the operator put the target on the table (TargetPlacement; a
// calibration holds yaw at 0, which defines the rig's x).
//  1. each camera's cam_from_rig starts from the best of its views' board poses (OpenCV's IPPE
//     with the camera's prior intrinsics: the rig YAML's, or loom calibrate intrinsics');
//  2. one Ceres bundle adjustment over every corner of every view refines every camera's
//     cam_from_rig and the target's offset together — and with fit_intrinsics the intrinsics
//     (fx fy cx cy k1 k2 p1 p2) too. That needs a target filling much of a wide field: with
//     tac7-mini's 3° field, focal length trades against distance (measured: focal 69 % off,
//     centre 400 mm off, same 0.2 px RMS) and distortion is unobservable, so by default the
//     intrinsics are held at their prior, calibrated from close-up photos.
// The turntable axis in a camera's frame is cam_from_rig's image of the rig's z axis.

#include <optional>
#include <string>
#include <vector>

#include "calibration/intrinsics.h"
#include "calibration/scan_radiance.h"
#include "core/rig_model.h"
#include "core/status.h"

namespace loom::calibration {

struct TargetView {
  int camera = 0;                        // index into the rig's cameras
  double turntable_deg = 0;              // as recorded with the frame
  scan::ViewId view;                     // the scan step and camera
  std::vector<Eigen::Vector2d> corners;  // in CalibrationTargetModel::CornersInBoard order
};

struct CameraGeometry {
  std::string name;
  Intrinsics intrinsics;  // K, distortion; rms and per-view residuals after the adjustment
  Rigid3d cam_from_rig = Rigid3d::Identity();
  std::vector<std::string> view_sources;  // in per_view_rms_px order
};

// Where the operator put the target on the turntable: shifted in the turntable's plane and
// turned about its axis. A calibration defines the rig's x axis by the target (yaw 0); checking
// a stored calibration against a new capture fits the yaw too, as nobody places a target twice
// the same way.
struct TargetPlacement {
  Eigen::Vector2d offset_mm = Eigen::Vector2d::Zero();
  double yaw_deg = 0;
};

struct RigGeometry {
  std::vector<CameraGeometry> cameras;  // in the rig's camera order
  TargetPlacement target;               // yaw 0: the target's rows define the rig's x
  double rms_px = 0;                    // over every corner of every camera
  std::vector<scan::ViewId> rejected;   // views the adjustment could not explain (misdetected)
};

struct GeometryOptions {
  int min_views_per_camera = 3;
  bool fit_intrinsics = false;
  // A view further than this (RMS px) from where the adjusted rig puts the target is a
  // misdetection (seen at grazing angles): rejected, and the rest adjusted again.
  double reject_view_above_px = 2;
  Status Check() const;  // every problem, naming the field
};

// `nominal` gives the cameras (names, sizes, starting intrinsics). A camera with fewer than
// min_views_per_camera views is an error naming it and the count.
Result<RigGeometry> CalibrateRigGeometry(const RigModel& nominal, const CalibrationTargetModel& target,
                                         const std::vector<TargetView>& views, const GeometryOptions& options = {});

// The target in a calibration scan: every target step's merged radiance per camera, scaled to
// 8 bits and searched for the board. A symmetric board is found in either order (and the
// detector may mirror it), so the order that lies nearest where `nominal` puts the board is
// kept. A view without the whole board is skipped, named in `skipped` with a warning.
struct DetectedTargetViews {
  std::vector<TargetView> views;
  std::vector<scan::ViewId> skipped;
};
Result<DetectedTargetViews> DetectTargetViews(const ScanRadiance& scan, const CalibrationTargetModel& target);

// The target's inner corners in one view (sensor pixels, in the detector's order), sought only
// in the window its frames read: outside it the view is unobserved (NaN), which the 8-bit image
// draws white, and on a large sensor that white was most of the image, on which the detector's
// normalisation (histogram equalisation) lost the board. Nothing when the board is not found.
std::optional<std::vector<Eigen::Vector2d>> FindTargetCorners(const RadianceView& view, const CalibrationTargetModel& target);

// `nominal` with the calibrated cameras, in the turntable's frame.
RigModel ApplyGeometry(const RigModel& nominal, const RigGeometry& geometry);

// The RMS distance (px) between the corners of `views` and where `rig`'s cameras and turntable
// put the target (placed as `placement`): how well a calibration explains views.
double ReprojectionRms(const RigModel& rig, const CalibrationTargetModel& target, const TargetPlacement& placement,
                       const std::vector<TargetView>& views);

// Where `rig`'s cameras, held as they are, see the target of `views` lie: the placement that
// explains the views best — robustly (Cauchy, 1 px), so that a camera that has moved since
// `rig` was calibrated does not drag it away from what the others agree on.
Result<TargetPlacement> FitTargetPlacement(const RigModel& rig, const CalibrationTargetModel& target,
                                           const std::vector<TargetView>& views);

}  // namespace loom::calibration
