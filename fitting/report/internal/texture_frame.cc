#include "fitting/report/internal/texture_frame.h"

#include <algorithm>
#include <cmath>

#include "fitting/model/svbrdf_maps.h"
#include "fitting/report/internal/png.h"

namespace loom::fitting::internal {

double GgxAlphaOfWardSigma(double sigma) { return std::clamp(std::sqrt(2.0) * sigma, 1e-4, 1.0); }

Eigen::Vector3d ToTangentSpace(const Eigen::Vector3d& in_sample) { return {in_sample.x(), -in_sample.y(), in_sample.z()}; }

cv::Vec3b UnitVectorRgb(const Eigen::Vector3d& v) {
  return {Unit8((v.z() + 1) / 2), Unit8((v.y() + 1) / 2), Unit8((v.x() + 1) / 2)};
}

double MaxSpecularF0(const Image& maps) {
  double max_f0 = 0;
  for (int y = 0; y < maps.height(); ++y) {
    for (int x = 0; x < maps.width(); ++x) {
      const WardParams<double> p = GetParams(maps, x, y);
      max_f0 = std::max(max_f0, p.a_s.maxCoeff() * p.f0);
    }
  }
  return max_f0;
}

}  // namespace loom::fitting::internal
