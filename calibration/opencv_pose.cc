#include "calibration/opencv_pose.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace loom::calibration {

Rigid3d RigidFromOpenCv(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  cv::cv2eigen(R, rotation);
  cv::cv2eigen(tvec, translation);
  return MakeRigid(rotation, translation);
}

}  // namespace loom::calibration
