#include "core/heightmap.h"

#include <algorithm>
#include <cmath>

#include "core/check.h"

namespace loom {

Heightmap::Heightmap(std::vector<float> heights_mm, int width, int height, double pixel_mm)
    : heights_mm_(std::move(heights_mm)), width_(width), height_(height), pixel_mm_(pixel_mm) {
  LOOM_CHECK(heights_mm_.size() == static_cast<size_t>(width) * height) << "heightmap size";
  LOOM_CHECK(pixel_mm > 0) << "heightmap pixel size";
  // The holder (height 0) surrounds the grid, so the highest point is at least 0.
  max_height_mm_ = std::max(0.0f, heights_mm_.empty() ? 0.0f : *std::max_element(heights_mm_.begin(), heights_mm_.end()));
}

double Heightmap::HeightAt(double x_mm, double y_mm) const {
  const double gx = x_mm / pixel_mm_ + width_ / 2.0 - 0.5;
  const double gy = y_mm / pixel_mm_ + height_ / 2.0 - 0.5;
  const int x0 = static_cast<int>(std::floor(gx));
  const int y0 = static_cast<int>(std::floor(gy));
  const double fx = gx - x0;
  const double fy = gy - y0;
  const auto at = [&](int x, int y) -> double {
    if (x < 0 || y < 0 || x >= width_ || y >= height_) return 0.0;
    return heights_mm_[static_cast<size_t>(y) * width_ + x];
  };
  return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) + fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

bool Heightmap::Shadowed(const Eigen::Vector3d& p, const Eigen::Vector3d& light) const {
  const Eigen::Vector3d s = (light - p).normalized();
  if (s.z() <= 0) return true;
  const double t_max = (max_height_mm_ - p.z()) / s.z();
  const double horizontal = std::max(s.head<2>().norm(), 1e-9);
  const double dt = 0.5 * pixel_mm_ / horizontal;
  for (double t = std::min(dt, t_max) * 0.5; t < t_max; t += dt) {
    const Eigen::Vector3d q = p + t * s;
    if (q.z() < HeightAt(q.x(), q.y()) - 1e-4) return true;
  }
  return false;
}

}  // namespace loom
