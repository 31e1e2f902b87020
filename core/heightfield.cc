#include "core/heightfield.h"

#include <algorithm>
#include <cmath>

namespace loom {

std::vector<double> BlurHeights(const std::vector<double>& in, int width, int height, double sigma_px) {
  if (sigma_px <= 0) return in;
  const int radius = static_cast<int>(std::ceil(3 * sigma_px));
  std::vector<double> kernel(2 * radius + 1);
  double total = 0;
  for (int k = -radius; k <= radius; ++k) total += kernel[k + radius] = std::exp(-0.5 * k * k / (sigma_px * sigma_px));
  for (double& w : kernel) w /= total;
  std::vector<double> tmp(in.size()), out(in.size());
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double sum = 0;
      for (int k = -radius; k <= radius; ++k) sum += kernel[k + radius] * in[y * width + std::clamp(x + k, 0, width - 1)];
      tmp[y * width + x] = sum;
    }
  }
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double sum = 0;
      for (int k = -radius; k <= radius; ++k) sum += kernel[k + radius] * tmp[std::clamp(y + k, 0, height - 1) * width + x];
      out[y * width + x] = sum;
    }
  }
  return out;
}

Eigen::Vector3d HeightfieldNormal(const std::vector<double>& h, int width, int height, int x, int y, double pixel_mm) {
  const auto at = [&](int xx, int yy) { return h[std::clamp(yy, 0, height - 1) * width + std::clamp(xx, 0, width - 1)]; };
  const double dx = (at(x + 1, y) - at(x - 1, y)) / (2 * pixel_mm);
  const double dy = (at(x, y + 1) - at(x, y - 1)) / (2 * pixel_mm);
  return Eigen::Vector3d(-dx, -dy, 1).normalized();
}

std::vector<Eigen::Vector3d> GeometricNormals(const std::vector<double>& heights, int width, int height, double pixel_mm,
                                              double blur_mm) {
  const std::vector<double> coarse = BlurHeights(heights, width, height, blur_mm / pixel_mm);
  std::vector<Eigen::Vector3d> normals(heights.size());
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) normals[y * width + x] = HeightfieldNormal(coarse, width, height, x, y, pixel_mm);
  }
  return normals;
}

}  // namespace loom
