#include "photos/capture_import.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "photos/capture_export.h"

namespace loom::photos {
namespace {

namespace fs = std::filesystem;

class CaptureImportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("loom_photos_test_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  static void WriteText(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

  // A 4 × 3 px ps capture of three lights: image k's value at pixel (x, y) is (k + 1)·(x + 1)/16 in
  // red, half that in green, a quarter in blue; the mask leaves out pixel (0, 0).
  fs::path WritePs() {
    const fs::path ps = dir_ / "ps";
    PhotometricStereoCapture capture;
    for (int k = 0; k < 3; ++k) {
      Image image(4, 3, {"R", "G", "B"});
      for (int y = 0; y < 3; ++y) {
        for (int x = 0; x < 4; ++x) {
          const float v = (k + 1) * (x + 1) / 16.0f;
          image.at(0, y, x) = v, image.at(1, y, x) = v / 2, image.at(2, y, x) = v / 4;
        }
      }
      capture.images.push_back(image);
    }
    capture.light_directions = {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0.6, 0, 0.8), Eigen::Vector3d(0, 0.6, 0.8)};
    capture.mask = Image(4, 3, {"mask"});
    for (float& m : capture.mask->channel(0)) m = 1;
    capture.mask->at(0, 0, 0) = 0;
    capture.white = 1;
    EXPECT_TRUE(WritePhotometricStereo(ps, capture).ok());
    return ps;
  }

  fs::path dir_;
};

TEST_F(CaptureImportTest, APhotometricStereoFolderKeepsTheImageGridAndItsLights) {
  const fs::path ps = WritePs();
  ImportOptions options;
  options.scale = 1.0;
  const Result<ImportResult> imported = ImportCapture(ps, options);
  ASSERT_TRUE(imported.ok()) << imported.status().ToString();
  EXPECT_EQ(imported->layout, Layout::kPhotometricStereo);
  EXPECT_EQ(imported->encoding.Name(), "linear");  // 16-bit
  const ObservationStack& stack = imported->stack;
  ASSERT_EQ(stack.image.width(), 4);
  ASSERT_EQ(stack.image.height(), 3);
  ASSERT_EQ(stack.observations.size(), 9u);  // three images, three channels each
  // Stack pixel (i, j) is image pixel (column i, row j); the values as stored (16-bit rounding).
  EXPECT_NEAR(stack.image.at(ObservationStack::ObservationChannel(3), 2, 3), 2 * 4 / 16.0, 1e-4);      // image 1, red
  EXPECT_NEAR(stack.image.at(ObservationStack::ObservationChannel(5), 2, 3), 2 * 4 / 16.0 / 4, 1e-4);  // image 1, blue
  EXPECT_TRUE(std::isnan(stack.image.at(ObservationStack::ObservationChannel(0), 0, 0)));              // masked
  EXPECT_EQ(imported->masked_pixels, 1);
  // Directional lights, y up in the file, y down in the stack; an orthographic camera.
  const StackObservation& third = stack.observations[6];
  ASSERT_EQ(third.emitters.size(), 1u);
  EXPECT_TRUE(third.emitters[0].at_infinity);
  EXPECT_TRUE(third.emitters[0].DirectionFrom({0, 0, 0}).isApprox(Eigen::Vector3d(0, -0.6, 0.8), 1e-6));
  ASSERT_TRUE(third.view_direction.has_value());
  EXPECT_EQ(third.rgb_weights, Eigen::Vector3d(1, 0, 0));
  // Pixel centres on the sample, as every stack has them.
  EXPECT_NEAR(stack.Position(0, 0).x(), -1.5 * 0.1, 1e-6);
  EXPECT_NEAR(stack.Position(0, 0).y(), -1.0 * 0.1, 1e-6);
}

TEST_F(CaptureImportTest, DownsamplingAveragesTheSeenValuesOfEachBlock) {
  const fs::path ps = WritePs();
  ImportOptions options;
  options.scale = 1.0;
  options.downsample = 2;
  const Result<ImportResult> imported = ImportCapture(ps, options);
  ASSERT_TRUE(imported.ok()) << imported.status().ToString();
  ASSERT_EQ(imported->stack.image.width(), 2);
  ASSERT_EQ(imported->stack.image.height(), 1);
  // Block (0, 0): pixels x = 0, 1 of rows 0, 1, pixel (0, 0) masked: (1 + 2 + 2)/3 sixteenths.
  EXPECT_NEAR(imported->stack.image.at(ObservationStack::ObservationChannel(0), 0, 0), 5.0 / 3 / 16, 1e-4);
  EXPECT_NEAR(imported->stack.pixel_mm, 0.2, 1e-12);
}

TEST_F(CaptureImportTest, ABlockWithAClippedValueIsUnseenInThatChannel) {
  const fs::path ps = WritePs();
  // Image 1's pixel (3, 0) at the top of the 16-bit range in red alone.
  const fs::path second = ps / "002.png";
  cv::Mat stored = cv::imread(second.string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(stored.type(), CV_16UC3) << second;
  stored.at<cv::Vec3w>(0, 3)[2] = 65535;  // B, G, R
  ASSERT_TRUE(cv::imwrite(second.string(), stored));
  ImportOptions options;
  options.scale = 1.0;
  options.downsample = 2;
  const Result<ImportResult> imported = ImportCapture(ps, options);
  ASSERT_TRUE(imported.ok()) << imported.status().ToString();
  const Image& image = imported->stack.image;
  EXPECT_EQ(imported->clipped_values, 1);
  // Block (1, 0) of image 1: its red unseen (the other three's mean, 6.7/16, would lie below the
  // block's true mean, above 7/16); green and blue, and the other block, as before.
  EXPECT_TRUE(std::isnan(image.at(ObservationStack::ObservationChannel(3), 0, 1)));
  EXPECT_NEAR(image.at(ObservationStack::ObservationChannel(4), 0, 1), 2 * 3.5 / 16 / 2, 1e-4);
  // Block (0, 0), whose pixel (0, 0) is masked, the mean of the other three, as before.
  EXPECT_NEAR(image.at(ObservationStack::ObservationChannel(3), 0, 0), 2 * 5.0 / 3 / 16, 1e-4);
}

TEST_F(CaptureImportTest, TheAutomaticScaleBringsTooBrightImagesWithinTheAlbedoBound) {
  const fs::path ps = WritePs();
  const Result<ImportResult> imported = ImportCapture(ps);
  ASSERT_TRUE(imported.ok()) << imported.status().ToString();
  EXPECT_TRUE(imported->scale_automatic);
  // The brightest pixel's values up to 12/16 under irradiance 1: an albedo of π·0.75 > 0.8.
  EXPECT_LT(imported->scale, 1.0);
  EXPECT_GT(imported->scale, 0.2);
}

TEST_F(CaptureImportTest, BadFilesAreErrorsNamingTheFile) {
  const fs::path ps = WritePs();
  {  // a missing light file
    fs::rename(ps / "light_directions.txt", dir_ / "moved.txt");
    const Result<ImportResult> r = ImportCapture(ps);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.status().ToString().find("light_directions.txt"), std::string::npos) << r.status().ToString();
    fs::rename(dir_ / "moved.txt", ps / "light_directions.txt");
  }
  {  // a count that does not match
    WriteText(ps / "light_intensities.txt", "1 1 1\n1 1 1\n");
    const Result<ImportResult> r = ImportCapture(ps);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.status().ToString().find("light_intensities.txt"), std::string::npos) << r.status().ToString();
    EXPECT_NE(r.status().ToString().find("2 lines"), std::string::npos) << r.status().ToString();
    WriteText(ps / "light_intensities.txt", "1 1 1\n1 1 1\n1 1 1\n");
  }
  {  // a mask of another size
    const fs::path mask = ps / "mask.png";
    cv::imwrite(mask.string(), cv::Mat(5, 5, CV_8UC1, cv::Scalar(255)));
    const Result<ImportResult> r = ImportCapture(ps);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.status().ToString().find("mask.png"), std::string::npos) << r.status().ToString();
    EXPECT_NE(r.status().ToString().find("5x5"), std::string::npos) << r.status().ToString();
    fs::remove(mask);
  }
  {  // a 1-bit PNG
    cv::imwrite((ps / "002.png").string(), cv::Mat(3, 4, CV_8UC1, cv::Scalar(255)), {cv::IMWRITE_PNG_BILEVEL, 1});
    const Result<ImportResult> r = ImportCapture(ps);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.status().ToString().find("002.png"), std::string::npos) << r.status().ToString();
    EXPECT_NE(r.status().ToString().find("1-bit"), std::string::npos) << r.status().ToString();
  }
  {  // no layout at all
    const Result<ImportResult> r = ImportCapture(dir_ / "nothing-here");
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.status().ToString().find("nothing-here"), std::string::npos) << r.status().ToString();
  }
}

TEST_F(CaptureImportTest, AFlashCaptureBecomesPointLightsInMillimetresWithTheGammaUndone) {
  const fs::path flash = dir_ / "flash";
  FlashCapture capture;
  Image image(8, 8, {"R", "G", "B"});
  for (int c = 0; c < 3; ++c) {
    for (float& v : image.channel(c)) v = 0.25f;
  }
  capture.images = {image, image};
  capture.cameras_cm = {{1, 2, 20}, {-1, 0, 18}};
  capture.lights_cm = capture.cameras_cm;
  capture.width_cm = 4;
  capture.power = {100, 200, 300};
  ASSERT_TRUE(WriteFlash(flash, capture).ok());
  ImportOptions options;
  options.scale = 1.0;
  options.flash_offset_cm = Eigen::Vector3d(0.5, 0, 0);
  const Result<ImportResult> imported = ImportCapture(flash, options);
  ASSERT_TRUE(imported.ok()) << imported.status().ToString();
  EXPECT_EQ(imported->layout, Layout::kFlash);
  EXPECT_EQ(imported->encoding.Name(), "gamma:2.2");
  const ObservationStack& stack = imported->stack;
  ASSERT_EQ(stack.observations.size(), 6u);
  EXPECT_NEAR(stack.pixel_mm, 40.0 / 8, 1e-12);
  EXPECT_NEAR(stack.image.at(ObservationStack::ObservationChannel(0), 3, 3), 0.25, 0.01);  // 8-bit gamma round trip
  const StackObservation& green = stack.observations[1];
  EXPECT_EQ(green.camera_mm, Eigen::Vector3d(10, -20, 200));                                 // y up in cm → y down in mm
  EXPECT_TRUE(green.emitters[0].position_mm.isApprox(Eigen::Vector3d(15, -20, 200), 1e-9));  // the flash offset
  EXPECT_NEAR(green.emitters[0].intensity, 200 * 100, 1e-9);                                 // power per cm² → per mm²
  EXPECT_FALSE(green.emitters[0].at_infinity);
}

TEST_F(CaptureImportTest, ALightDomesLpFileGivesDirectionalLightsAndSrgbImages) {
  const fs::path lp = dir_ / "dome";
  fs::create_directories(lp);
  for (int k = 0; k < 3; ++k) {
    cv::imwrite((lp / ("img" + std::to_string(k) + ".jpg")).string(), cv::Mat(6, 5, CV_8UC3, cv::Scalar(100, 150, 200)));
  }
  WriteText(lp / "dome.lp", "3\nimg0.jpg 0 0 1\nimg1.jpg 0.6 0 0.8\nimg2.jpg 0 0.6 0.8\n");
  ImportOptions options;
  options.scale = 1.0;
  const Result<ImportResult> imported = ImportCapture(lp, options);
  ASSERT_TRUE(imported.ok()) << imported.status().ToString();
  EXPECT_EQ(imported->layout, Layout::kLightPositions);
  EXPECT_EQ(imported->encoding.Name(), "srgb");
  const ObservationStack& stack = imported->stack;
  ASSERT_EQ(stack.observations.size(), 9u);
  EXPECT_EQ(stack.image.width(), 5);
  EXPECT_TRUE(stack.observations[6].emitters[0].DirectionFrom({0, 0, 0}).isApprox(Eigen::Vector3d(0, -0.6, 0.8), 1e-9));
  // Red 200 in sRGB is 0.578 linear (JPEG may move it by a step or two).
  EXPECT_NEAR(stack.image.at(ObservationStack::ObservationChannel(0), 2, 2), 0.578, 0.02);
  // A count that does not match the lines, named by file.
  WriteText(lp / "dome.lp", "4\nimg0.jpg 0 0 1\nimg1.jpg 0.6 0 0.8\nimg2.jpg 0 0.6 0.8\n");
  const Result<ImportResult> wrong = ImportCapture(lp, options);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.status().ToString().find("dome.lp"), std::string::npos) << wrong.status().ToString();
  EXPECT_NE(wrong.status().ToString().find("says 4 images but lists 3"), std::string::npos) << wrong.status().ToString();
}

// RTIBuilder's project layout: the .lp in assembly-files/ names its images by absolute Windows
// paths into jpeg-exports/ beside it, with CRLF line ends; a name may hold spaces.
TEST_F(CaptureImportTest, AnRtiBuilderProjectsLpFindsItsImagesBesideIt) {
  const fs::path project = dir_ / "rti project";
  fs::create_directories(project / "assembly-files");
  fs::create_directories(project / "jpeg-exports");
  for (const char* name : {"IMG 0001.jpg", "IMG 0002.jpg", "IMG 0003.jpg"}) {
    cv::imwrite((project / "jpeg-exports" / name).string(), cv::Mat(6, 5, CV_8UC3, cv::Scalar(100, 150, 200)));
  }
  WriteText(project / "assembly-files" / "project.lp",
            "3\r\nC:\\RTI\\project\\jpeg-exports\\IMG 0001.jpg 0 0 1\r\n"
            "C:\\RTI\\project\\jpeg-exports\\IMG 0002.jpg\t0.6 0 0.8\r\n"
            "C:\\RTI\\project\\jpeg-exports\\IMG 0003.jpg 0 0.6 0.8\r\n");
  ImportOptions options;
  options.scale = 1.0;
  const Result<ImportResult> imported = ImportCapture(project / "assembly-files", options);
  ASSERT_TRUE(imported.ok()) << imported.status().ToString();
  EXPECT_EQ(imported->images, 3);
  EXPECT_TRUE(imported->stack.observations[3].emitters[0].DirectionFrom({0, 0, 0}).isApprox(Eigen::Vector3d(0.6, 0, 0.8), 1e-9));
  // An image found nowhere is named as the file lists it.
  fs::remove(project / "jpeg-exports" / "IMG 0002.jpg");
  const Result<ImportResult> missing = ImportCapture(project / "assembly-files", options);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().ToString().find("IMG 0002.jpg"), std::string::npos) << missing.status().ToString();
  // A line without three numbers after its name is refused naming the file and line.
  WriteText(project / "assembly-files" / "project.lp", "1\r\nIMG 0001.jpg 0 0\r\n");
  const Result<ImportResult> short_line = ImportCapture(project / "assembly-files", options);
  ASSERT_FALSE(short_line.ok());
  EXPECT_NE(short_line.status().ToString().find("project.lp:2"), std::string::npos) << short_line.status().ToString();
}

TEST_F(CaptureImportTest, ANormalMapReadsInTheStackFrame) {
  cv::Mat png(2, 2, CV_8UC3, cv::Scalar(0, 0, 0));
  // (n + 1)/2 of n = (0, 0.6, 0.8) (y up), stored as B, G, R; pixel (1, 1) none.
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 2; ++x) {
      if (x == 1 && y == 1) continue;
      png.at<cv::Vec3b>(y, x) =
          cv::Vec3b(static_cast<uint8_t>(std::lround(0.9 * 255)), static_cast<uint8_t>(std::lround(0.8 * 255)),
                    static_cast<uint8_t>(std::lround(0.5 * 255)));
    }
  }
  cv::imwrite((dir_ / "normals.png").string(), png);
  const Result<Image> normals = ReadNormalMap(dir_ / "normals.png");
  ASSERT_TRUE(normals.ok()) << normals.status().ToString();
  EXPECT_NEAR(normals->at(0, 0, 0), 0, 0.01);
  EXPECT_NEAR(normals->at(1, 0, 0), -0.6, 0.01);  // y negated
  EXPECT_NEAR(normals->at(2, 0, 0), 0.8, 0.01);
  EXPECT_TRUE(std::isnan(normals->at(0, 1, 1)));
}

TEST(CaptureOptionsTest, LayoutsEncodingsAndFlashOffsetsAreParsedOrRefusedNamingTheOption) {
  EXPECT_EQ(*ParseLayout("lp", "--layout"), Layout::kLightPositions);
  const Result<Layout> dome = ParseLayout("dome", "--layout");
  ASSERT_FALSE(dome.ok());
  EXPECT_NE(dome.status().ToString().find("--layout dome"), std::string::npos) << dome.status().ToString();
  const Result<Eigen::Vector3d> offset = ParseFlashOffset("0.8,-0.5,0", "--flash-offset");
  ASSERT_TRUE(offset.ok()) << offset.status().ToString();
  EXPECT_EQ(*offset, Eigen::Vector3d(0.8, -0.5, 0));
  for (const char* bad : {"0.8,0", "0.8;0;0", "1,2,3x", "nan,0,0"}) {
    const Result<Eigen::Vector3d> refused = ParseFlashOffset(bad, "--flash-offset");
    ASSERT_FALSE(refused.ok()) << bad;
    EXPECT_EQ(refused.status().subject(), std::string("--flash-offset ") + bad);
  }
  EXPECT_FALSE(ParseEncoding("gamma:0", "--encoding").ok());
}

}  // namespace
}  // namespace loom::photos
