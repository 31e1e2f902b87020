#include "calibration/board.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

namespace loom::calibration {
namespace {

TEST(BoardSpecTest, ParsesAndPrintsTheSameText) {
  const Result<BoardSpec> board = ParseBoardSpec("chessboard:9x6:25");
  ASSERT_TRUE(board.ok()) << board.status().ToString();
  EXPECT_EQ(board->inner_cols, 9);
  EXPECT_EQ(board->inner_rows, 6);
  EXPECT_EQ(board->square_mm, 25);
  EXPECT_EQ(board->ToString(), "chessboard:9x6:25");
  EXPECT_EQ(ParseBoardSpec("chessboard:7x5:2.5")->ToString(), "chessboard:7x5:2.5");
  const std::vector<Eigen::Vector3d> corners = board->CornersInBoard();
  ASSERT_EQ(corners.size(), 54u);
  EXPECT_EQ(corners[10], Eigen::Vector3d(25, 25, 0));
}

TEST(BoardSpecTest, BadSpecsNameTheTextAndTheExpectedForm) {
  for (const char* text : {"chessboard:9x6", "9x6:25", "chessboard:9by6:25", "charuco:9x6:25", "chessboard:2x6:25"}) {
    const Result<BoardSpec> board = ParseBoardSpec(text);
    ASSERT_FALSE(board.ok()) << text;
    EXPECT_EQ(board.status().code(), StatusCode::kInvalidArgument);
    EXPECT_EQ(board.status().subject(), "board '" + std::string(text) + "'");
  }
}

TEST(FindBoardCornersTest, InACropTheCornersAreTheWholeImagesAndOrderedFromItsTopLeft) {
  // A windowed view as calibrate geometry draws it: a 2048 × 1536 sensor white where it was not
  // read, and in an 816 × 624 window at (616, 456) a board of 70 px squares (7 × 5 inner corners).
  cv::Mat grey(1536, 2048, CV_8U, cv::Scalar(255));
  const cv::Rect window(616, 456, 816, 624);
  grey(window).setTo(cv::Scalar(230));
  const double square = 70;
  const Eigen::Vector2d first_corner(window.x + 230.5, window.y + 180.5);
  for (int j = 0; j < 6; ++j) {
    for (int i = 0; i < 8; ++i) {
      if ((i + j) % 2) continue;
      const cv::Point top_left(static_cast<int>(first_corner.x() + 0.5 + (i - 1) * square),
                               static_cast<int>(first_corner.y() + 0.5 + (j - 1) * square));
      cv::rectangle(grey, cv::Rect(top_left, cv::Size(70, 70)), cv::Scalar(10), cv::FILLED);
    }
  }
  cv::GaussianBlur(grey, grey, cv::Size(5, 5), 1.0);
  const BoardSpec board{"chessboard", 7, 5, 5};
  const auto corners = FindBoardCorners(grey(window), board, Eigen::Vector2d(window.x, window.y));
  ASSERT_TRUE(corners.has_value());
  ASSERT_EQ(corners->size(), 35u);
  // Pixel centres at integers: the squares' edges lie between pixels, at first_corner + k·square.
  for (int j = 0; j < 5; ++j) {
    for (int i = 0; i < 7; ++i) {
      const Eigen::Vector2d expected = first_corner + square * Eigen::Vector2d(i, j);
      EXPECT_LT(((*corners)[j * 7 + i] - expected).norm(), 0.2) << i << ", " << j << ": " << (*corners)[j * 7 + i].transpose();
    }
  }
  // The same crop without its origin: the same corners, shifted by it.
  const auto in_the_crop = FindBoardCorners(grey(window), board);
  ASSERT_TRUE(in_the_crop.has_value());
  EXPECT_LT(((*in_the_crop)[0] + Eigen::Vector2d(window.x, window.y) - (*corners)[0]).norm(), 1e-9);
}

}  // namespace
}  // namespace loom::calibration
