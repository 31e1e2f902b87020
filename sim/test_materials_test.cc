#include "sim/test_materials.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fitting/model/svbrdf_maps.h"
#include "sim/sample.h"

namespace loom::sim {
namespace {

// The map pixel containing sample-frame point (x_mm, y_mm).
fitting::WardParams<double> At(const Material& m, double x_mm, double y_mm) {
  const int x = static_cast<int>(std::floor(x_mm / m.pixel_mm + m.width() / 2.0));
  const int y = static_cast<int>(std::floor(y_mm / m.pixel_mm + m.height() / 2.0));
  return fitting::GetParams(m.maps, x, y);
}

TEST(TestMaterialsTest, ChessboardSquaresWhereTheBoardSaysSo) {
  // 9 x 6 inner corners → 10 x 7 squares of 10 mm, centred: the top-left square is dark.
  const Material board = Chessboard(9, 6, 10.0, {.width_px = 240, .height_px = 200, .pixel_mm = 0.5});
  EXPECT_NEAR(At(board, -45, -30).a_d.x(), 0.04, 1e-6);  // square (0, 0)
  EXPECT_NEAR(At(board, -35, -30).a_d.x(), 0.85, 1e-6);  // square (1, 0)
  EXPECT_NEAR(At(board, -35, -20).a_d.x(), 0.04, 1e-6);  // square (1, 1)
  EXPECT_NEAR(At(board, 0, 45).a_d.x(), 0.85, 1e-6);     // margin
  EXPECT_EQ(std::get<std::string>(board.provenance.at("loom.board")).substr(0, 15), "chessboard:9x6:");
}

TEST(TestMaterialsTest, ColourChartPatchesHaveTheChartsAlbedos) {
  const Material chart = ColourChart(ColourChartModel{.patch_mm = 20.0}, {.width_px = 320, .height_px = 240, .pixel_mm = 0.5});
  const double cell = 24.0;
  for (int patch : {0, 5, 14, 18, 23}) {
    const int row = patch / 6;
    const int col = patch % 6;
    const double x = (col - 3 + 0.5) * cell;
    const double y = (row - 2 + 0.5) * cell;
    EXPECT_TRUE(At(chart, x, y).a_d.isApprox(ColourChartModel::Albedo(patch), 1e-6)) << patch;
  }
  EXPECT_NEAR(ColourChartModel::Albedo(18).x(), 0.896, 0.005);  // white patch, linear
  EXPECT_NEAR(ColourChartModel::Albedo(14).x(), 0.429, 0.005);  // red patch's red
}

TEST(TestMaterialsTest, WhiteTileAndUniformAreFlat) {
  const Material tile = WhiteTile({.width_px = 16, .height_px = 16, .pixel_mm = 1.0});
  const fitting::WardParams<double> p = At(tile, 3, -2);
  EXPECT_TRUE(p.a_d.isApprox(Eigen::Vector3d::Constant(0.95), 1e-6));
  EXPECT_EQ(p.a_s, Eigen::Vector3d::Zero());
  EXPECT_EQ(p.n_s, Eigen::Vector3d::UnitZ());
  EXPECT_EQ(tile.maps.at(*tile.maps.ChannelIndex("height"), 3, 3), 0.0f);
}

TEST(TestMaterialsTest, TheTileOnItsSpacerIsTheTileRaised) {
  const Material raised = WhiteTileOnSpacer({.width_px = 16, .height_px = 16, .pixel_mm = 1.0}, 0.95, 30);
  EXPECT_TRUE(At(raised, 3, -2).a_d.isApprox(Eigen::Vector3d::Constant(0.95), 1e-6));
  EXPECT_EQ(raised.maps.at(*raised.maps.ChannelIndex("height"), 3, 3), 30.0f);
  SampleSpec spec;
  spec.kind = "white-tile-on-spacer";
  const Result<Material> without_spacer = MakeSample(spec);
  ASSERT_FALSE(without_spacer.ok());
  EXPECT_NE(without_spacer.status().ToString().find("spacer_mm"), std::string::npos) << without_spacer.status().ToString();
  spec.white.spacer_mm = 30;
  const Result<Material> made = MakeSample(spec);
  ASSERT_TRUE(made.ok()) << made.status().ToString();
  EXPECT_EQ(made->name, "white tile on its spacer");
}

// A sample's size and pixel are refused before anything is made (a NaN or 1e-300 pixel once
// crashed `loom rig list`, issue #24), naming the field.
TEST(TestMaterialsTest, ASampleOfNoSizeOrNoPixelIsRefusedBeforeItIsMade) {
  for (const double pixel_mm : {std::nan(""), 0.0, 1e-300, -1.0}) {
    SampleSpec spec;
    spec.pixel_mm = pixel_mm;
    const Result<Material> refused = MakeSample(spec);
    ASSERT_FALSE(refused.ok()) << pixel_mm;
    EXPECT_NE(refused.status().ToString().find("pixel_mm"), std::string::npos) << refused.status().ToString();
  }
  SampleSpec huge;
  huge.size_px = kMaxSampleSide + 1;
  const Result<Material> refused = MakeSample(huge);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().ToString().find("size_px"), std::string::npos) << refused.status().ToString();
}

}  // namespace
}  // namespace loom::sim
