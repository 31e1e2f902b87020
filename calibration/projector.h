#pragma once
// The structured-light projector's pose from the columns it throws on the calibration target:
// where the calibrated cameras see the target's corners (their rig-frame positions known from
// loom calibrate geometry), the decoded projector column is measured (reconstruction's
// projector_columns.h gathers these); the projector's pose is then fitted to them by Ceres:
//   column = fx · X/Z + cx   (X, Z the corner in the projector's frame)
// with the intrinsics held at their prior, as the cameras' are (geometry.h).
// Columns are planes through the projector's centre that all share its y axis: moving the
// centre along that axis changes no column, so that one direction is held at its prior (a
// weak residual) — structured light cannot see it either. Over a sample a few centimetres wide
// other combinations are nearly as blind (a turn about the y axis against a shift along x): on
// the simulated tac7-mini, exact as built, the fitted pose came out 1.2° and 1.4 mm from the
// truth while fitting the decoded columns to 0.009 px RMS (and, built 4 mm and 0.5° away, its
// columns over the sample volume came within 0.074 px of the truth). The columns are what
// triangulation uses, so they are what is reported (column_change_px) and tested.

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

struct ProjectorCalibration {
  ProjectorModel projector;
  double rms_columns = 0;        // of the fit
  int correspondences = 0;
  double column_change_px = 0;     // largest change of a corner's column against the prior
  double rotation_change_deg = 0;  // against the prior (loosely determined, see above)
  double centre_change_mm = 0;
};

// At least 12 correspondences; an error otherwise, or when the fit fails.
Result<ProjectorCalibration> CalibrateProjector(const ProjectorModel& prior, const std::vector<ProjectorCorrespondence>& points);

// CALIB/projector.yaml (device: projector): written atomically, read strictly.
Status WriteProjectorCalibration(const std::filesystem::path& directory, const ProjectorCalibration& calibration,
                                 const std::string& from);
// Applies CALIB/projector.yaml when there is one; returns whether. A file for another projector
// resolution names the file.
Result<bool> ApplyProjectorCalibration(const std::filesystem::path& directory, RigModel* rig);

}  // namespace loom::calibration
