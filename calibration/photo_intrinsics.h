#pragma once
// One camera calibrated from ordinary photos of a chessboard (loom calibrate intrinsics), as a
// lab does after a lens change: the photos found by a glob, the board detected where it can be,
// then CalibrateIntrinsics.

#include <ostream>
#include <string>

#include "calibration/board.h"
#include "calibration/calibration_yaml.h"

namespace loom::calibration {

// Every file matching the shell glob `pattern` (sorted). A pattern that matches nothing, or
// photos in which too few boards are found, is an error naming it.
Result<CameraCalibration> CalibrateFromPhotos(const std::string& pattern, const BoardSpec& board, const std::string& name);

// Views used, RMS reprojection error, focal length, centre, k1 and k2, and the worst view.
void ReportPhotoCalibration(std::ostream& out, const CameraCalibration& calibration);

}  // namespace loom::calibration
