#pragma once
// Calibration targets: what the board is (parsed from "chessboard:COLSxROWS:SQUARE_MM"), where
// its corners lie on the board, and finding them in an image.

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/status.h"

namespace cv {
class Mat;
}

namespace loom::calibration {

struct BoardSpec {
  std::string kind = "chessboard";
  int inner_cols = 9;  // inner corners along a row
  int inner_rows = 6;
  double square_mm = 25;

  std::string ToString() const;  // the text Parse accepts
  // Corner (c, r) at (c·square, r·square, 0) in the board frame, row-major.
  std::vector<Eigen::Vector3d> CornersInBoard() const;
  int corners() const { return inner_cols * inner_rows; }
};

// "chessboard:9x6:25"; an error names the text and says what was expected.
Result<BoardSpec> ParseBoardSpec(const std::string& text);

// The board's inner corners in an 8-bit grey image, row-major in the board's order, refined to
// subpixel; nothing if the whole board is not found. Uses OpenCV's sector-based detector
// (findChessboardCornersSB), which is more accurate than the classic one and copes with small
// squares; the board's orientation is made unambiguous by ordering from its top-left corner
// as seen. `grey` may be a crop of a larger image whose top-left pixel is at `origin` there: the
// corners are then that image's (and so is the top-left they are ordered from).
std::optional<std::vector<Eigen::Vector2d>> FindBoardCorners(const cv::Mat& grey, const BoardSpec& board,
                                                             const Eigen::Vector2d& origin = Eigen::Vector2d::Zero());

}  // namespace loom::calibration
