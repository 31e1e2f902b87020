#include "calibration/structured_light.h"

#include <gtest/gtest.h>

#include <cmath>

#include "scan/patterns.h"
#include "scan/plan.h"

namespace loom::calibration {
namespace {

constexpr int kProjectorWidth = 320;
constexpr int kPhaseSteps = 4;

// What a camera records of a pattern when pixel (x, y) sees projector column u(x, y): the
// pattern's level there (linear between columns, as a defocused projector throws it) times an
// albedo that varies over the image, plus ambient light.
Image Observe(const scan::Pattern& pattern, int width, int height, double (*column)(int, int)) {
  Image image(width, height, {"L"});
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double u = column(x, y);
      const int u0 = static_cast<int>(std::floor(u));
      const double f = u - u0;
      const double level = ((1 - f) * pattern.pixels[u0] + f * pattern.pixels[u0 + 1]) / 255.0;
      const double albedo = 0.2 + 0.7 * ((x * 7 + y * 3) % 11) / 10.0;
      image.at(0, y, x) = static_cast<float>(albedo * level + 0.01);
    }
  }
  return image;
}

double SmoothColumn(int x, int y) { return 5.3 + 2.71 * x + 0.4 * std::sin(0.3 * y); }

std::map<std::string, Image> ObserveSequence(double (*column)(int, int)) {
  std::map<std::string, Image> images;
  for (const std::string& name : scan::StructuredLightPatterns(kProjectorWidth, 0, kPhaseSteps)) {
    const Result<scan::Pattern> pattern = scan::MakePattern(name, kProjectorWidth, 1, kPhaseSteps);
    EXPECT_TRUE(pattern.ok()) << pattern.status().ToString();
    images[name] = Observe(*pattern, 100, 20, column);
  }
  return images;
}

TEST(StructuredLightTest, DecodesTheProjectorColumnToAHundredthOfAColumn) {
  const Result<Image> columns = DecodeProjectorColumns(ObserveSequence(SmoothColumn), {kProjectorWidth, kPhaseSteps, 0.1});
  ASSERT_TRUE(columns.ok()) << columns.status().ToString();
  double worst = 0;
  for (int y = 0; y < 20; ++y) {
    for (int x = 0; x < 100; ++x) worst = std::max(worst, std::abs(columns->at(0, y, x) - SmoothColumn(x, y)));
  }
  // 8-bit sinusoids quantise the phase to ~0.01 column.
  EXPECT_LT(worst, 0.03);
}

TEST(StructuredLightTest, PixelsWithoutContrastAreUndecodable) {
  std::map<std::string, Image> images = ObserveSequence(SmoothColumn);
  for (auto& [name, image] : images) {
    for (int y = 0; y < 20; ++y) image.at(0, y, 50) = 0.3f;  // a column the projector does not reach
  }
  const Result<Image> columns = DecodeProjectorColumns(images, {kProjectorWidth, kPhaseSteps, 0.1});
  ASSERT_TRUE(columns.ok()) << columns.status().ToString();
  EXPECT_TRUE(std::isnan(columns->at(0, 5, 50)));
  EXPECT_FALSE(std::isnan(columns->at(0, 5, 49)));
}

TEST(StructuredLightTest, AMissingPatternIsAnErrorNamingIt) {
  std::map<std::string, Image> images = ObserveSequence(SmoothColumn);
  images.erase("gray_x_03_inv");
  const Result<Image> columns = DecodeProjectorColumns(images, {kProjectorWidth, kPhaseSteps, 0.1});
  ASSERT_FALSE(columns.ok());
  EXPECT_NE(columns.status().ToString().find("gray_x_03_inv"), std::string::npos) << columns.status().ToString();
}

TEST(StructuredLightTest, BadDecodeOptionsAreRefusedNamingEachField) {
  const DecodeOptions bad{.projector_width = 0, .phase_steps = 2, .min_contrast = std::nan("")};
  const Status status = bad.Check();
  for (const char* field : {"projector_width", "phase_steps", "min_contrast"}) {
    EXPECT_NE(status.ToString().find(field), std::string::npos) << field << " in " << status.ToString();
  }
  const Result<Image> columns = DecodeProjectorColumns({}, bad);
  ASSERT_FALSE(columns.ok());
  EXPECT_NE(columns.status().ToString().find("DecodeOptions"), std::string::npos) << columns.status().ToString();
}

}  // namespace
}  // namespace loom::calibration
