#pragma once
// The structured-light projector's pose, and with flat boards its intrinsics, from the columns
// it throws on calibration objects (reconstruction's projector_columns.h decodes and gathers
// them); fitted by Ceres to
//   column = fx · X/Z + cx   (X, Z a point in the projector's frame)
// Two kinds of observation:
//  - the target's corners, their rig-frame positions known from loom calibrate geometry. Over a
//    target a few centimetres wide, focal length trades against distance, so corners alone fit
//    the pose with fx, cx held at their prior (as the cameras' are, geometry.h). On the
//    simulated tac7-mini, exact as built, the pose came out 1.2° and 1.4 mm from the truth while
//    fitting the decoded columns to 0.009 px RMS, yet its columns over the sample volume came
//    within 0.074 px of the truth (built 4 mm and 0.5° away): what triangulation uses.
//  - a flat board (the white tile) on the table and again raised on a spacer: every camera pixel
//    that sees it is a ray with a decoded column. The change of column spacing with height
//    separates focal length from distance, so with two boards fx and cx are fitted too — where
//    the boards fill enough of the projector's field (below). The boards' planes (height and
//    tilt) are fitted with them: two cameras must see each column at the same point of the
//    plane, which fixes it, so the spacer's height need not be exact.
// Measured on simulated scans (projector built 4 mm and 0.5° away, fx 3 % longer, cx 4 px aside):
//  - tac7-mini (cameras see 32 mm of the projector's 210 mm field): boards found at −0.007 and
//    30.019 mm; fx, cx pinned down only to 0.16 % and 1.2 px, so held; columns up to the spacer
//    within 0.079 px of the truth (the rig YAML's: 4.8 px off).
//  - the same with cameras seeing 96 mm (an `as_built:` rig, 320² px at f 2000):
//    fx +2.92 % (1σ 0.019 %), cx +1.3 px (1σ 0.08 px); columns within 0.008 px in the sample
//    volume, 0.41 px over ±45 mm up to 30 mm, 0.93 px over the projector's whole field at the
//    table (corners alone: 0.017, 0.34 and 1.05 px). The 1σ counts the decoding noise only:
//    the cameras' pose errors (a few hundredths of a degree move a board point by tenths of a
//    millimetre, i.e. tenths of a column) are what limit it, and cx trades against a turn about
//    the projector's y axis (they differ by 3 % across its field).
// Columns are planes through the projector's centre that all share its y axis: moving the
// centre along that axis changes no column, so that one direction is held at its prior (a weak
// residual) — structured light cannot see it either; nor do columns see fy or cy, which stay at
// the prior's.

#include <filesystem>
#include <string>
#include <vector>

#include "core/rig_model.h"
#include "core/status.h"

namespace loom::calibration {

struct ProjectorCorrespondence {
  Eigen::Vector3d point_mm = Eigen::Vector3d::Zero();  // rig frame
  double column = 0;                                   // decoded projector column (px, centres at integers)
};

// A camera pixel that saw a flat board under the patterns: its ray and the column decoded there.
struct FlatBoardRay {
  int camera = 0;                                        // index into the rig's cameras
  Eigen::Vector3d origin_mm = Eigen::Vector3d::Zero();   // the camera's centre, rig frame
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();  // unit, rig frame
  double column = 0;
};

// One placement of the flat board: its plane z = height + slope · (x, y) in the rig frame starts
// at nominal_height_mm, level.
struct FlatBoardView {
  std::string name;  // the plan's object ("white tile on its spacer"), for messages and reports
  double nominal_height_mm = 0;
  std::vector<FlatBoardRay> rays;
};

struct ProjectorObservations {
  std::vector<ProjectorCorrespondence> corners;
  std::vector<FlatBoardView> boards;  // none: fx and cx held at the prior's
};

struct FlatBoardFit {
  std::string name;
  double height_mm = 0;  // where the plane meets the turntable's axis
  double tilt_deg = 0;
  int rays = 0;  // kept: rays the plane cannot explain (its edges, shadows) are dropped
  double rms_columns = 0;
};

struct ProjectorCalibration {
  ProjectorModel projector;
  double rms_columns = 0;  // at the target's corners
  int correspondences = 0;
  // With boards, fx and cx are fitted, and kept when the boards pin them down (1σ of fx within
  // 0.1 %, of cx within 0.5 px); else they stay at the prior's, and the boards still fit the
  // pose over the volume up to the spacer.
  bool intrinsics_fitted = false;
  double focal_sigma_percent = 0;  // 1σ of the boards' fx and cx from the decoding noise (0 without boards)
  double cx_sigma_px = 0;
  double focal_change_percent = 0;  // fx against the prior: 0 unless fitted
  double cx_change_px = 0;
  std::vector<FlatBoardFit> boards;
  double column_change_px = 0;     // largest change of a corner's column against the prior
  double rotation_change_deg = 0;  // against the prior (loosely determined, see above)
  double centre_change_mm = 0;
};

// At least 12 corners; with boards, at least two whose nominal heights are 5 mm apart or more,
// each seen by two cameras at 200 rays or more. An error otherwise (naming the board), or when the fit fails.
Result<ProjectorCalibration> CalibrateProjector(const ProjectorModel& prior, const ProjectorObservations& observed);

// CALIB/projector.yaml (device: projector): written atomically, read strictly.
Status WriteProjectorCalibration(const std::filesystem::path& directory, const ProjectorCalibration& calibration,
                                 const std::string& from);
// Applies CALIB/projector.yaml when there is one; returns whether. A file for another projector
// resolution names the file.
Result<bool> ApplyProjectorCalibration(const std::filesystem::path& directory, RigModel* rig);

}  // namespace loom::calibration
