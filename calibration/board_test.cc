#include "calibration/board.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace loom::calibration
