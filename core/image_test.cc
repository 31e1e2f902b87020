#include "core/image.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "core/check.h"

namespace loom {
namespace {

TEST(ImageTest, PlanarLayoutWithNamedChannels) {
  Image image(4, 3, {"a_d.R", "a_d.G", "a_d.B", "sigma_x"});
  EXPECT_EQ(image.num_channels(), 4);
  EXPECT_EQ(image.pixel_count(), 12u);
  image.at(3, 2, 1) = 5.0f;
  // channel 3, row 2, column 1 → plane 3, offset 2 * 4 + 1
  EXPECT_EQ(image.data()[3 * 12 + 2 * 4 + 1], 5.0f);
  EXPECT_EQ(image.channel(3)[9], 5.0f);
  EXPECT_EQ(*image.ChannelIndex("sigma_x"), 3);
  EXPECT_EQ(image.ChannelsWithPrefix("a_d."), (std::vector<int>{0, 1, 2}));
}

TEST(ImageTest, MissingChannelIsAnErrorNamingIt) {
  const Image image(2, 2, {"R", "G"});
  const Result<int> missing = image.ChannelIndex("B");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), StatusCode::kNotFound);
  EXPECT_NE(missing.status().ToString().find("'B'"), std::string::npos);
  EXPECT_NE(missing.status().ToString().find("R, G"), std::string::npos);
}

TEST(ImageTest, AddChannelKeepsExistingData) {
  Image image(2, 2, {"R"});
  image.at(0, 1, 1) = 2.0f;
  const int g = image.AddChannel("G");
  EXPECT_EQ(g, 1);
  EXPECT_EQ(image.at(0, 1, 1), 2.0f);
  EXPECT_EQ(image.at(1, 1, 1), 0.0f);
}

TEST(ImageTest, DuplicateNamesAreABug) {
  EXPECT_THROW(Image(1, 1, {"R", "R"}), CheckError);
  Image image(1, 1, {"R"});
  EXPECT_THROW(image.AddChannel("R"), CheckError);
  EXPECT_THROW(static_cast<void>(image.channel(1)), CheckError);
}

TEST(ImageTest, SampleBilinearInterpolatesBetweenCentresAndIsNaNOffTheImage) {
  Image image(3, 2, {"v"});
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 3; ++x) image.at(0, y, x) = static_cast<float>(10 * y + x);
  }
  EXPECT_FLOAT_EQ(SampleBilinear(image, 0, 1.25, 0.5), 6.25f);
  EXPECT_FLOAT_EQ(SampleBilinear(image, 0, 2, 1), 12.0f);  // the last centre is inside
  EXPECT_TRUE(std::isnan(SampleBilinear(image, 0, 2.01, 0)));
  EXPECT_TRUE(std::isnan(SampleBilinear(image, 0, -0.01, 0)));
  image.at(0, 0, 1) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_TRUE(std::isnan(SampleBilinear(image, 0, 0.5, 0.5)));
}

}  // namespace
}  // namespace loom
