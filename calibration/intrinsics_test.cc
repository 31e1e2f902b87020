// Intrinsics from ordinary photos: the 13 chessboard photos OpenCV ships (testdata/opencv-left).
#include "calibration/intrinsics.h"
#include "core/testing/build_tree.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "calibration/calibration_yaml.h"
#include "calibration/photo_intrinsics.h"

namespace loom::calibration {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> LeftPhotos() {
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(fs::path(loom::testing::SourceDir()) / "calibration/testdata/opencv-left")) {
    if (entry.path().extension() == ".jpg") files.push_back(entry.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// OpenCV's own sample recipe (samples/cpp/calibration.cpp): the classic detector, cornerSubPix
// in an 11×11 window, calibrateCamera with default flags. The reference our pipeline must match.
double OpenCvSampleRms(const std::vector<std::string>& files, double square_mm) {
  std::vector<std::vector<cv::Point2f>> image_points;
  cv::Size size;
  for (const std::string& file : files) {
    const cv::Mat grey = cv::imread(file, cv::IMREAD_GRAYSCALE);
    size = grey.size();
    std::vector<cv::Point2f> corners;
    if (!cv::findChessboardCorners(grey, {9, 6}, corners, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) continue;
    cv::cornerSubPix(grey, corners, {11, 11}, {-1, -1}, {cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 0.0001});
    image_points.push_back(corners);
  }
  std::vector<cv::Point3f> board;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 9; ++c) board.emplace_back(c * square_mm, r * square_mm, 0);
  }
  std::vector<std::vector<cv::Point3f>> object_points(image_points.size(), board);
  cv::Mat K, distortion;
  std::vector<cv::Mat> rvecs, tvecs;
  return cv::calibrateCamera(object_points, image_points, size, K, distortion, rvecs, tvecs);
}

TEST(IntrinsicsTest, FindsTheBoardInAllThirteenOpenCvPhotosWithOpenCvsRms) {
  const std::vector<std::string> files = LeftPhotos();
  ASSERT_EQ(files.size(), 13u);
  const BoardSpec board = *ParseBoardSpec("chessboard:9x6:25");
  const Result<DetectedViews> detected = DetectBoardInFiles(files, board);
  ASSERT_TRUE(detected.ok()) << detected.status().ToString();
  EXPECT_EQ(detected->views.size(), 13u);
  EXPECT_TRUE(detected->skipped.empty());
  EXPECT_EQ(detected->width, 640);
  EXPECT_EQ(detected->height, 480);
  const Result<Intrinsics> intrinsics = CalibrateIntrinsics(board, detected->views, detected->width, detected->height);
  ASSERT_TRUE(intrinsics.ok()) << intrinsics.status().ToString();
  const double reference = OpenCvSampleRms(files, 25);
  // Our detector (the sector-based one) is at least as accurate as the classic recipe.
  EXPECT_LT(intrinsics->rms_px, reference * 1.2) << "reference " << reference;
  EXPECT_GT(intrinsics->rms_px, 0.02);
  ASSERT_EQ(intrinsics->per_view_rms_px.size(), 13u);
  // A 640×480 webcam: focal length ~530 px, principal point near the centre.
  EXPECT_NEAR(intrinsics->K(0, 0), 535, 25);
  EXPECT_NEAR(intrinsics->K(1, 1), intrinsics->K(0, 0), 5);
  EXPECT_NEAR(intrinsics->K(0, 2), 320, 30);
  EXPECT_NEAR(intrinsics->K(1, 2), 240, 30);
  std::cout << "rms " << intrinsics->rms_px << " px (OpenCV sample recipe " << reference << " px), f " << intrinsics->K(0, 0)
            << " px\n";
}

TEST(IntrinsicsTest, AnImageWithoutTheBoardIsSkippedAndTooFewViewsAreAnError) {
  const fs::path blank = fs::path(::testing::TempDir()) / "blank.png";
  cv::imwrite(blank.string(), cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)));
  const BoardSpec board = *ParseBoardSpec("chessboard:9x6:25");
  std::vector<std::string> files = {LeftPhotos()[0], blank.string(), LeftPhotos()[1]};
  const Result<DetectedViews> detected = DetectBoardInFiles(files, board);
  ASSERT_TRUE(detected.ok());
  EXPECT_EQ(detected->views.size(), 2u);
  EXPECT_EQ(detected->skipped, std::vector<std::string>{blank.string()});
  const Result<Intrinsics> intrinsics = CalibrateIntrinsics(board, detected->views, 640, 480);
  ASSERT_FALSE(intrinsics.ok());
  EXPECT_NE(intrinsics.status().message().find("2 views"), std::string::npos) << intrinsics.status().ToString();
}

TEST(IntrinsicsTest, PhotosFoundByAGlobCalibrateACameraAndAGlobWithoutFilesIsNamed) {
  const std::string dir = loom::testing::SourceDir() + "/calibration/testdata/opencv-left/";
  const BoardSpec board = *ParseBoardSpec("chessboard:9x6:25");
  const Result<CameraCalibration> calibration = CalibrateFromPhotos(dir + "left0[1-5].jpg", board, "cam7");
  ASSERT_TRUE(calibration.ok()) << calibration.status().ToString();
  EXPECT_EQ(calibration->name, "cam7");
  EXPECT_EQ(calibration->from, dir + "left0[1-5].jpg");
  ASSERT_EQ(calibration->view_sources.size(), 5u);
  EXPECT_EQ(calibration->view_sources.front(), dir + "left01.jpg");  // sorted
  EXPECT_LT(calibration->intrinsics.rms_px, 1.0);
  std::ostringstream report;
  ReportPhotoCalibration(report, *calibration);
  EXPECT_NE(report.str().find("board found in 5 of 5 images"), std::string::npos) << report.str();
  EXPECT_NE(report.str().find("worst view: " + dir + "left0"), std::string::npos) << report.str();

  const Result<CameraCalibration> none = CalibrateFromPhotos(dir + "*.png", board, "cam7");
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.status().ToString().find("images '" + dir + "*.png': matches no file"), std::string::npos)
      << none.status().ToString();
}

TEST(IntrinsicsTest, AnUnreadableFileIsAnErrorNamingIt) {
  const fs::path bad = fs::path(::testing::TempDir()) / "not-an-image.jpg";
  std::ofstream(bad) << "JFIF? no";
  const Result<DetectedViews> detected = DetectBoardInFiles({bad.string()}, *ParseBoardSpec("chessboard:9x6:25"));
  ASSERT_FALSE(detected.ok());
  EXPECT_EQ(detected.status().subject(), bad.string());
}

TEST(IntrinsicsTest, TheCalibrationFileRoundTrips) {
  CameraCalibration calibration;
  calibration.name = "cam2";
  calibration.intrinsics.width = 640;
  calibration.intrinsics.height = 480;
  calibration.intrinsics.K << 530.25, 0, 321.5, 0, 531, 239.75, 0, 0, 1;
  calibration.intrinsics.distortion << -0.25, 0.1, 0.001, -0.002, 0.01;
  calibration.intrinsics.rms_px = 0.21;
  calibration.intrinsics.per_view_rms_px = {0.2, 0.22};
  calibration.view_sources = {"a.jpg", "b.jpg"};
  calibration.skipped = {"c.jpg"};
  calibration.cam_from_rig =
      MakeRigid(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix(), Eigen::Vector3d(1, -2, 600));
  calibration.from = "photos/*.jpg";
  calibration.board = "chessboard:9x6:25";
  const fs::path path = fs::path(::testing::TempDir()) / "cam2.yaml";
  ASSERT_TRUE(WriteCameraCalibration(path, calibration).ok());
  const Result<CameraCalibration> back = ReadCameraCalibration(path);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_TRUE(back->intrinsics.K.isApprox(calibration.intrinsics.K, 1e-12));
  EXPECT_TRUE(back->intrinsics.distortion.isApprox(calibration.intrinsics.distortion, 1e-12));
  EXPECT_TRUE(back->cam_from_rig->isApprox(*calibration.cam_from_rig, 1e-9));
  EXPECT_EQ(back->view_sources, calibration.view_sources);
  EXPECT_EQ(back->skipped, calibration.skipped);
  EXPECT_EQ(back->intrinsics.per_view_rms_px, calibration.intrinsics.per_view_rms_px);
}

}  // namespace
}  // namespace loom::calibration
