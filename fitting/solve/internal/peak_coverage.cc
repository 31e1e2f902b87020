#include "fitting/solve/internal/peak_coverage.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "core/geometry.h"

namespace loom::fitting::internal {
namespace {

// Half-vectors at more than this from the normal are not projected: the gnomonic projection
// sends them toward infinity, and a lobe's peak is never that far from where it is seen.
constexpr double kMinCosine = 0.1;

Eigen::Vector3d BrightestHalfVector(const PixelObservation& o) {
  const auto brightest = std::max_element(o.lights.begin(), o.lights.end(),
                                          [](const LightSample& a, const LightSample& b) { return a.irradiance < b.irradiance; });
  return (brightest->l_local + o.v_local).normalized();
}

}  // namespace

double PeakCoverage(const Eigen::Vector3d& normal, const std::vector<PixelObservation>& observations) {
  // The gnomonic projection onto the plane tangent at the normal keeps great circles straight,
  // so the cone's edge is the projected points' convex hull, and the normal is its origin.
  const Eigen::Vector3d n = normal.normalized();
  const Eigen::Vector3d t = n.unitOrthogonal(), b = n.cross(t);
  std::vector<cv::Point2f> projected;
  for (const PixelObservation& o : observations) {
    if (o.lights.empty() || !std::isfinite(o.radiance)) continue;
    const Eigen::Vector3d h = BrightestHalfVector(o);
    const double c = h.dot(n);
    if (c > kMinCosine) projected.emplace_back(static_cast<float>(h.dot(t) / c), static_cast<float>(h.dot(b) / c));
  }
  if (projected.size() < 3) return -kPi / 2;
  std::vector<cv::Point2f> hull;
  cv::convexHull(projected, hull);
  if (hull.size() < 3) return -kPi / 2;  // every half-vector on one great circle
  return std::atan(cv::pointPolygonTest(hull, cv::Point2f(0, 0), true));
}

}  // namespace loom::fitting::internal
