#include "fitting/io/internal/geometric_frame.h"

#include <Eigen/Geometry>
#include <algorithm>

#include "fitting/model/svbrdf_maps.h"

namespace loom::fitting::internal {

Eigen::Matrix3d SampleFromLocal(const Image& maps, int x, int y, double pixel_mm) {
  const std::optional<int> height = maps.FindChannel(kHeightChannel);
  if (!height) return Eigen::Matrix3d::Identity();
  // 0 across a map one pixel thin.
  const auto slope = [&](int i0, int j0, int i1, int j1, int span) {
    return span > 0 ? (maps.at(*height, j1, i1) - maps.at(*height, j0, i0)) / (span * pixel_mm) : 0.0;
  };
  const int x0 = std::max(x - 1, 0), x1 = std::min(x + 1, maps.width() - 1);
  const int y0 = std::max(y - 1, 0), y1 = std::min(y + 1, maps.height() - 1);
  const double dx = slope(x0, y, x1, y, x1 - x0);
  const double dy = slope(x, y0, x, y1, y1 - y0);
  const Eigen::Vector3d n = Eigen::Vector3d(-dx, -dy, 1).normalized();
  const Eigen::Vector3d t = (Eigen::Vector3d::UnitX() - n.x() * n).normalized();
  Eigen::Matrix3d frame;
  frame << t, n.cross(t), n;
  return frame;
}

}  // namespace loom::fitting::internal
