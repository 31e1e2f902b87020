#include "calibration/opencv_library.h"

#include <opencv2/core/utility.hpp>

namespace loom::calibration {

LinkedLibrary OpenCvLibrary() { return {"OpenCV", cv::getVersionString()}; }

}  // namespace loom::calibration
