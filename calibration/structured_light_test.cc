#include "calibration/structured_light.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/testing/shipped_rig.h"
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

// The projector column each pixel of `camera` sees on the table (z = 0) at turntable 0°; NaN
// where it sees no column.
Image ColumnsOnTheTable(const CameraModel& camera, const ProjectorModel& projector, const TurntableModel& turntable) {
  Image columns(camera.width, camera.height, {"column"});
  const Rigid3d sample_from_rig = turntable.RigFromSample(0).inverse();
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const Eigen::Vector3d origin = camera.CentreInRig();
      const Eigen::Vector3d direction = camera.cam_from_rig.linear().transpose() * camera.Unproject(Eigen::Vector2d(x, y));
      columns.at(0, y, x) = std::nanf("");
      if (direction.z() >= 0) continue;
      const Eigen::Vector3d on_table = sample_from_rig * (origin + direction * (-origin.z() / direction.z()));
      const Eigen::Vector3d q = projector.proj_from_rig * turntable.RigFromSample(0) * on_table;
      if (q.z() <= 0) continue;
      const double column = (projector.K * (q / q.z())).x();
      if (column >= 0 && column < projector.width) columns.at(0, y, x) = static_cast<float>(column);
    }
  }
  return columns;
}

TEST(TriangulateHeightsTest, AProjectorElsewhereThanTheModelSaysIsNamedNotTakenForAMissingPattern) {
  const RigModel rig = testing::ShippedRigModel("tac7-mini");
  ASSERT_TRUE(rig.projector.has_value());
  const CameraModel& camera = rig.cameras[0];
  const Image columns = ColumnsOnTheTable(camera, *rig.projector, rig.turntable);
  const HeightmapGrid grid{16, 16, 0.5, -5, 5};

  const Result<TriangulatedHeights> flat = TriangulateHeights(columns, camera, *rig.projector, rig.turntable, 0, grid);
  ASSERT_TRUE(flat.ok()) << flat.status().ToString();
  for (float h : flat->heights_mm) EXPECT_NEAR(h, 0, 0.01);

  // Built 30 mm aside of where the model puts it: columns are seen, but no height explains them.
  ProjectorModel moved = *rig.projector;
  moved.proj_from_rig = moved.proj_from_rig * Rigid3d(Eigen::Translation3d(-30, 0, 0));
  const Result<TriangulatedHeights> off = TriangulateHeights(columns, camera, moved, rig.turntable, 0, grid);
  ASSERT_FALSE(off.ok());
  EXPECT_NE(off.status().message().find("fit no height in [-5, 5] mm"), std::string::npos) << off.status().ToString();
  EXPECT_NE(off.status().message().find("loom calibrate geometry"), std::string::npos) << off.status().ToString();
  EXPECT_NE(off.status().ToString().find("camera 'cam0'"), std::string::npos) << off.status().ToString();

  Image unseen = columns;
  for (float& v : unseen.channel(0)) v = std::nanf("");
  const Result<TriangulatedHeights> dark = TriangulateHeights(unseen, camera, *rig.projector, rig.turntable, 0, grid);
  ASSERT_FALSE(dark.ok());
  EXPECT_NE(dark.status().message().find("pattern not seen"), std::string::npos) << dark.status().ToString();
}
}  // namespace
}  // namespace loom::calibration
