#include "acquisition/crop_windows.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/geometry.h"

namespace loom::acquisition {

Status CropOptions::Check() const {
  std::vector<std::string> problems;
  if (!(size_mm > 0) || !std::isfinite(size_mm)) problems.push_back("size_mm must be > 0");
  if (!(relief_mm >= 0) || !std::isfinite(relief_mm)) problems.push_back("relief_mm must be ≥ 0");
  if (margin_px < 0) problems.push_back("margin_px must be ≥ 0");
  if (alignment_px < 1) problems.push_back("alignment_px must be ≥ 1");
  return ProblemsStatus("CropOptions", problems);
}

namespace {

// The crop at every turntable angle sweeps the disc through its corners: its rim, at the
// holder and at the top of the relief, bounds where it can appear (the disc's inside projects
// within its rim's hull).
std::vector<Eigen::Vector3d> CropBoundInRig(const RigModel& rig, const CropOptions& options) {
  constexpr int kRimPoints = 72;
  constexpr int kAngles = 24;  // the turntable's axis may be off the sample's as built
  const double radius = options.size_mm / std::sqrt(2.0);
  std::vector<Eigen::Vector3d> points;
  for (int a = 0; a < kAngles; ++a) {
    const Rigid3d rig_from_sample = rig.turntable.RigFromSample(360.0 * a / kAngles);
    for (int k = 0; k < kRimPoints; ++k) {
      const double phi = 2 * kPi * k / kRimPoints;
      for (double z : {0.0, options.relief_mm}) {
        points.push_back(rig_from_sample * Eigen::Vector3d(radius * std::cos(phi), radius * std::sin(phi), z));
      }
    }
  }
  return points;
}

}  // namespace

Result<std::map<std::string, scan::Roi>> CropWindows(const RigModel& rig, const CropOptions& options) {
  LOOM_RETURN_IF_ERROR(options.Check());
  const std::vector<Eigen::Vector3d> bound = CropBoundInRig(rig, options);
  std::map<std::string, scan::Roi> windows;
  for (const CameraModel& camera : rig.cameras) {
    double x_min = std::numeric_limits<double>::infinity(), y_min = x_min;
    double x_max = -x_min, y_max = -x_min;
    for (const Eigen::Vector3d& p : bound) {
      Eigen::Vector2d pixel;
      if (!camera.Project(camera.cam_from_rig * p, &pixel)) continue;
      x_min = std::min(x_min, pixel.x()), x_max = std::max(x_max, pixel.x());
      y_min = std::min(y_min, pixel.y()), y_max = std::max(y_max, pixel.y());
    }
    if (!std::isfinite(x_min)) {
      return InvalidArgumentError("camera '" + camera.name + "'", "has the sample behind it: no window sees the crop");
    }
    // Clamped to the sensor first: points near a camera's plane project arbitrarily far out.
    const int a = options.alignment_px;
    const auto down = [a](double v, int size) { return static_cast<int>(std::floor(std::clamp(v, 0.0, 1.0 * size) / a)) * a; };
    const auto up = [a](double v, int size) {
      return std::min(size, static_cast<int>(std::ceil(std::clamp(v, 0.0, 1.0 * size) / a)) * a);
    };
    const int x0 = down(x_min - options.margin_px, camera.width), y0 = down(y_min - options.margin_px, camera.height);
    const int x1 = up(x_max + 1 + options.margin_px, camera.width), y1 = up(y_max + 1 + options.margin_px, camera.height);
    if (!(x1 > x0 && y1 > y0)) {
      return InvalidArgumentError("camera '" + camera.name + "'",
                                  "does not see the " + std::to_string(options.size_mm) + " mm crop of the sample");
    }
    windows[camera.name] = {x0, y0, x1 - x0, y1 - y0};
  }
  return windows;
}

}  // namespace loom::acquisition
