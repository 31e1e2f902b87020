#pragma once
// One camera's intrinsics from views of a board: pinhole + OpenCV's 5-term distortion (k1 k2 p1
// p2 k3), by cv::calibrateCamera on the detected corners; quality as RMS and per-view residuals.

#include <string>
#include <vector>

#include "calibration/board.h"
#include "core/rig_model.h"
#include "core/status.h"

namespace loom::calibration {

struct BoardView {
  std::string source;                    // file or frame it came from
  std::vector<Eigen::Vector2d> corners;  // in BoardSpec::CornersInBoard order
};

struct Intrinsics {
  int width = 0;
  int height = 0;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  Eigen::Matrix<double, 5, 1> distortion = Eigen::Matrix<double, 5, 1>::Zero();
  double rms_px = 0;                    // over every corner of every view
  std::vector<double> per_view_rms_px;  // in the order of the views
  std::vector<Rigid3d> cam_from_board;  // per view
};

// Needs at least 3 views (an error says how many were given).
Result<Intrinsics> CalibrateIntrinsics(const BoardSpec& board, const std::vector<BoardView>& views, int width, int height);

// Views of a board in image files: each found board is a view; files without one are listed
// in `skipped` (with why). An unreadable file is an error naming it.
struct DetectedViews {
  std::vector<BoardView> views;
  std::vector<std::string> skipped;
  int width = 0;
  int height = 0;
};
Result<DetectedViews> DetectBoardInFiles(const std::vector<std::string>& files, const BoardSpec& board);

}  // namespace loom::calibration
