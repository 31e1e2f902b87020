#include "calibration/intrinsics.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calibration/opencv_pose.h"
#include "core/log.h"

namespace loom::calibration {

Result<Intrinsics> CalibrateIntrinsics(const BoardSpec& board, const std::vector<BoardView>& views, int width, int height) {
  if (views.size() < 3) {
    return FailedPreconditionError("board " + board.ToString(),
                                   "found in " + std::to_string(views.size()) + " views; intrinsics need at least 3");
  }
  std::vector<cv::Point3f> object;
  for (const Eigen::Vector3d& p : board.CornersInBoard()) object.emplace_back(p.x(), p.y(), p.z());
  std::vector<std::vector<cv::Point3f>> objects(views.size(), object);
  std::vector<std::vector<cv::Point2f>> images;
  for (const BoardView& view : views) {
    std::vector<cv::Point2f> corners;
    for (const Eigen::Vector2d& c : view.corners) corners.emplace_back(c.x(), c.y());
    images.push_back(std::move(corners));
  }
  cv::Mat K, distortion, std_intrinsics, std_extrinsics, per_view;
  std::vector<cv::Mat> rvecs, tvecs;
  const double rms = cv::calibrateCamera(objects, images, cv::Size(width, height), K, distortion, rvecs, tvecs, std_intrinsics,
                                         std_extrinsics, per_view);
  Intrinsics result;
  result.width = width;
  result.height = height;
  cv::cv2eigen(K, result.K);
  for (int i = 0; i < 5; ++i) result.distortion[i] = distortion.at<double>(i);
  result.rms_px = rms;
  for (int i = 0; i < per_view.rows; ++i) result.per_view_rms_px.push_back(per_view.at<double>(i));
  for (size_t i = 0; i < views.size(); ++i) result.cam_from_board.push_back(RigidFromOpenCv(rvecs[i], tvecs[i]));
  return result;
}

Result<DetectedViews> DetectBoardInFiles(const std::vector<std::string>& files, const BoardSpec& board) {
  DetectedViews detected;
  for (const std::string& file : files) {
    const cv::Mat grey = cv::imread(file, cv::IMREAD_GRAYSCALE);
    if (grey.empty()) return IoError(file, "cannot be read as an image");
    if (detected.width == 0) {
      detected.width = grey.cols;
      detected.height = grey.rows;
    } else if (grey.cols != detected.width || grey.rows != detected.height) {
      return InvalidArgumentError(file, "is " + std::to_string(grey.cols) + "x" + std::to_string(grey.rows) +
                                            ", the first image was " + std::to_string(detected.width) + "x" +
                                            std::to_string(detected.height) + ": one camera, one size");
    }
    if (auto corners = FindBoardCorners(grey, board)) {
      detected.views.push_back({file, std::move(*corners)});
    } else {
      LOOM_LOG(Warning) << file << ": board " << board.ToString() << " not found, skipped";
      detected.skipped.push_back(file);
    }
  }
  return detected;
}

}  // namespace loom::calibration
