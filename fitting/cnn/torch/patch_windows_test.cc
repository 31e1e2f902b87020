// The network's input windows: a training tile's window is the window of the padded material
// that dense inference reads, at every position, the borders and corners included.
#include "fitting/cnn/torch/patch_windows.h"

#include <gtest/gtest.h>

namespace loom::fitting::internal {
namespace {

// A 1 × 2 × H × W input whose every value is distinct, so that a misplaced pixel shows.
at::Tensor DistinctInput(int height, int width) {
  return at::arange(2 * height * width, at::kFloat).reshape({1, 2, height, width});
}

TEST(PatchWindowsTest, EdgePaddingReplicatesTheBorderAsReplicationPadDoes) {
  const at::Tensor input = DistinctInput(5, 7);
  const at::Tensor padded = EdgePadded(input, 3);
  ASSERT_EQ(padded.sizes(), (at::IntArrayRef{1, 2, 11, 13}));
  EXPECT_TRUE(at::equal(padded, at::replication_pad2d(input, {3, 3, 3, 3})));
  EXPECT_EQ(padded[0][1][0][0].item<float>(), input[0][1][0][0].item<float>());  // a corner takes the corner pixel
}

TEST(PatchWindowsTest, EveryTileWindowIsThePaddedMaterialsWindowThere) {
  constexpr int kTile = 4, kHalo = 7;  // the halo wider than the material: windows clamp on both sides
  const at::Tensor input = DistinctInput(9, 6);
  const at::Tensor padded = EdgePadded(input, kHalo);
  for (int y = 0; y + kTile <= 9; ++y) {
    for (int x = 0; x + kTile <= 6; ++x) {
      const at::Tensor window = TileWindow(input, x, y, kTile, kHalo);
      const at::Tensor expected = padded.narrow(2, y, kTile + 2 * kHalo).narrow(3, x, kTile + 2 * kHalo);
      ASSERT_TRUE(at::equal(window, expected)) << "tile at (" << x << ", " << y << ")";
    }
  }
}

}  // namespace
}  // namespace loom::fitting::internal
