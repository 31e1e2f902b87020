// ReconstructOptions are checked before a reconstruction starts: sizes and pixel sizes that would
// make it run for hours or divide by nothing are refused, each field named.
#include "reconstruction/reconstruct.h"

#include <gtest/gtest.h>

#include <cmath>

namespace loom::reconstruction {
namespace {

TEST(ReconstructOptionsTest, EveryBadValueIsRefusedNamingItsField) {
  EXPECT_TRUE(ReconstructOptions{}.Check().ok());
  ReconstructOptions bad;
  bad.width_px = 0;
  bad.pixel_mm = 1e-300;  // once a crash in the heightmap's blur (issue #24)
  bad.normal_blur_mm = std::nan("");
  bad.min_height_mm = 5;
  bad.max_height_mm = -5;
  bad.threads = -1;
  const Status status = bad.Check();
  ASSERT_FALSE(status.ok());
  for (const char* field : {"width_px", "pixel_mm", "normal_blur_mm", "min_height_mm", "threads"}) {
    EXPECT_NE(status.message().find(field), std::string::npos) << field << " in " << status.message();
  }
  ReconstructOptions huge;
  huge.width_px = kMaxStackSide + 1;
  EXPECT_FALSE(huge.Check().ok());
  ReconstructOptions nan_pixel;
  nan_pixel.pixel_mm = std::nan("");
  EXPECT_FALSE(nan_pixel.Check().ok());
}

}  // namespace
}  // namespace loom::reconstruction
