#include "calibration/board.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <regex>

namespace loom::calibration {

std::string BoardSpec::ToString() const {
  char square[32];
  std::snprintf(square, sizeof(square), "%g", square_mm);
  return kind + ":" + std::to_string(inner_cols) + "x" + std::to_string(inner_rows) + ":" + square;
}

std::vector<Eigen::Vector3d> BoardSpec::CornersInBoard() const {
  std::vector<Eigen::Vector3d> corners;
  for (int r = 0; r < inner_rows; ++r) {
    for (int c = 0; c < inner_cols; ++c) corners.emplace_back(c * square_mm, r * square_mm, 0.0);
  }
  return corners;
}

Result<BoardSpec> ParseBoardSpec(const std::string& text) {
  static const std::regex pattern(R"(([a-z]+):(\d+)x(\d+):([0-9]*\.?[0-9]+))");
  std::smatch match;
  if (!std::regex_match(text, match, pattern)) {
    return InvalidArgumentError("board '" + text + "'", "expected chessboard:COLSxROWS:SQUARE_MM, e.g. chessboard:9x6:25");
  }
  BoardSpec board;
  board.kind = match[1];
  board.inner_cols = std::stoi(match[2]);
  board.inner_rows = std::stoi(match[3]);
  board.square_mm = std::stod(match[4]);
  if (board.kind != "chessboard") {
    return InvalidArgumentError("board '" + text + "'", "unknown kind '" + board.kind + "' (known: chessboard)");
  }
  if (board.inner_cols < 3 || board.inner_rows < 3 || board.square_mm <= 0) {
    return InvalidArgumentError("board '" + text + "'", "needs at least 3x3 inner corners and a square size > 0 mm");
  }
  return board;
}

std::optional<std::vector<Eigen::Vector2d>> FindBoardCorners(const cv::Mat& grey, const BoardSpec& board,
                                                             const Eigen::Vector2d& origin) {
  std::vector<cv::Point2f> found;
  const cv::Size pattern(board.inner_cols, board.inner_rows);
  if (!cv::findChessboardCornersSB(grey, pattern, found, cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_ACCURACY)) {
    return std::nullopt;
  }
  std::vector<Eigen::Vector2d> corners;
  for (const cv::Point2f& p : found) corners.push_back(origin + Eigen::Vector2d(p.x, p.y));
  // A symmetric board is found in either of two orders (rotated by 180°): start from the
  // corner nearest the image's top-left so that the same view always numbers corners alike.
  if (corners.front().norm() > corners.back().norm()) {
    std::reverse(corners.begin(), corners.end());
  }
  return corners;
}

}  // namespace loom::calibration
