#pragma once
// OpenCV's pose of an object (a Rodrigues vector and a translation, as calibrateCamera and
// solvePnP give them) as a Rigid3d (camera from object).
#include "core/geometry.h"

namespace cv {
class Mat;
}

namespace loom::calibration {
Rigid3d RigidFromOpenCv(const cv::Mat& rvec, const cv::Mat& tvec);
}
