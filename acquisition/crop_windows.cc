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

// The window of `camera` that holds every point of `bound` (rig frame) that it sees, grown by the
// margin, aligned and clipped to the sensor; `what` names what it must see in errors.
Result<scan::Roi> WindowSeeing(const CameraModel& camera, const std::vector<Eigen::Vector3d>& bound, int margin_px,
                               int alignment_px, const std::string& what) {
  double x_min = std::numeric_limits<double>::infinity(), y_min = x_min;
  double x_max = -x_min, y_max = -x_min;
  for (const Eigen::Vector3d& p : bound) {
    Eigen::Vector2d pixel;
    if (!camera.Project(camera.cam_from_rig * p, &pixel)) continue;
    x_min = std::min(x_min, pixel.x()), x_max = std::max(x_max, pixel.x());
    y_min = std::min(y_min, pixel.y()), y_max = std::max(y_max, pixel.y());
  }
  if (!std::isfinite(x_min)) {
    return InvalidArgumentError("camera '" + camera.name + "'", "has " + what + " behind it: no window sees it");
  }
  // Clamped to the sensor first: points near a camera's plane project arbitrarily far out.
  const int a = alignment_px;
  const auto down = [a](double v, int size) { return static_cast<int>(std::floor(std::clamp(v, 0.0, 1.0 * size) / a)) * a; };
  const auto up = [a](double v, int size) {
    return std::min(size, static_cast<int>(std::ceil(std::clamp(v, 0.0, 1.0 * size) / a)) * a);
  };
  const int x0 = down(x_min - margin_px, camera.width), y0 = down(y_min - margin_px, camera.height);
  const int x1 = up(x_max + 1 + margin_px, camera.width), y1 = up(y_max + 1 + margin_px, camera.height);
  if (!(x1 > x0 && y1 > y0)) return InvalidArgumentError("camera '" + camera.name + "'", "does not see " + what);
  return scan::Roi{x0, y0, x1 - x0, y1 - y0};
}

// The corners of the box [lo, hi] (sample frame).
std::vector<Eigen::Vector3d> BoxCorners(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  std::vector<Eigen::Vector3d> corners;
  for (int k = 0; k < 8; ++k) {
    corners.emplace_back(k & 1 ? hi.x() : lo.x(), k & 2 ? hi.y() : lo.y(), k & 4 ? hi.z() : lo.z());
  }
  return corners;
}

// Points of a sphere every 10° of latitude and longitude: the window that holds their images
// holds the sphere's to within a few pixels of its radius (r (1 − cos 5°)), which the margin covers.
std::vector<Eigen::Vector3d> SpherePoints(const Eigen::Vector3d& centre, double radius) {
  std::vector<Eigen::Vector3d> points;
  for (int latitude = -90; latitude <= 90; latitude += 10) {
    for (int longitude = 0; longitude < 360; longitude += 10) {
      const double theta = DegToRad(latitude), phi = DegToRad(longitude);
      points.push_back(
          centre + radius * Eigen::Vector3d(std::cos(theta) * std::cos(phi), std::cos(theta) * std::sin(phi), std::sin(theta)));
    }
  }
  return points;
}

// Where a calibration object can lie (sample frame), grown by the placement tolerance: points
// whose images bound the object's; none for an object that gets no window.
Result<std::vector<Eigen::Vector3d>> ObjectBound(const RigModel& rig, scan::ScanObject object, double placement_mm) {
  const Eigen::Vector3d grow = Eigen::Vector3d::Constant(placement_mm);
  const std::string missing =
      "the calibration plan places the " + std::string(ScanObjectName(object)) + ", which the rig's geometry";
  switch (object) {
    case scan::ScanObject::kTarget: {
      if (!rig.calibration_target)
        return InvalidArgumentError("rig '" + rig.name + "'", missing + " has no calibration_target: for");
      // The board and its white margin of one square, tilted about x.
      const CalibrationTargetModel& target = *rig.calibration_target;
      const double half_u = (target.inner_cols + 1) / 2.0 * target.square_mm + target.square_mm;
      const double half_v = (target.inner_rows + 1) / 2.0 * target.square_mm + target.square_mm;
      Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
      for (const double u : {-half_u, half_u}) {
        for (const double v : {-half_v, half_v}) {
          const Eigen::Vector3d corner = target.SampleFromBoard() * Eigen::Vector3d(u, v, 0);
          lo = lo.cwiseMin(corner), hi = hi.cwiseMax(corner);
        }
      }
      lo.z() = 0;  // the wedge stands on the holder
      return BoxCorners(lo - grow, hi + grow);
    }
    case scan::ScanObject::kChromeSphere: {
      if (!rig.light_probe) return InvalidArgumentError("rig '" + rig.name + "'", missing + " has no light_probe: for");
      const double r = rig.light_probe->radius_mm;
      return SpherePoints({0, 0, r}, r + placement_mm);
    }
    case scan::ScanObject::kColourChart: {
      const ColourChartModel& chart = rig.colour_chart;
      Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
      const Eigen::Vector3d half(chart.PitchMm() / 2, chart.PitchMm() / 2, 0);
      for (int patch = 0; patch < ColourChartModel::kPatches; ++patch) {
        const Eigen::Vector3d centre(chart.PatchCentre(patch).x(), chart.PatchCentre(patch).y(), 0);
        lo = lo.cwiseMin(centre - half), hi = hi.cwiseMax(centre + half);
      }
      return BoxCorners(lo - grow, hi + grow);
    }
    default:
      return std::vector<Eigen::Vector3d>();
  }
}

}  // namespace

Result<std::map<std::string, scan::Roi>> CropWindows(const RigModel& rig, const CropOptions& options) {
  LOOM_RETURN_IF_ERROR(options.Check());
  const std::vector<Eigen::Vector3d> bound = CropBoundInRig(rig, options);
  std::map<std::string, scan::Roi> windows;
  for (const CameraModel& camera : rig.cameras) {
    LOOM_ASSIGN_OR_RETURN(windows[camera.name],
                          WindowSeeing(camera, bound, options.margin_px, options.alignment_px,
                                       "the " + std::to_string(options.size_mm) + " mm crop of the sample"));
  }
  return windows;
}

Status ObjectWindowOptions::Check() const {
  std::vector<std::string> problems;
  if (!(placement_mm >= 0) || !std::isfinite(placement_mm)) problems.push_back("placement_mm must be ≥ 0");
  if (margin_px < 0) problems.push_back("margin_px must be ≥ 0");
  if (alignment_px < 1) problems.push_back("alignment_px must be ≥ 1");
  return ProblemsStatus("ObjectWindowOptions", problems);
}

Result<scan::Plan> WithObjectWindows(scan::Plan plan, const RigModel& rig, const ObjectWindowOptions& options) {
  LOOM_RETURN_IF_ERROR(options.Check());
  for (scan::Step& step : plan.steps) {
    LOOM_ASSIGN_OR_RETURN(std::vector<Eigen::Vector3d> bound, ObjectBound(rig, step.object, options.placement_mm));
    if (bound.empty()) continue;
    const Rigid3d rig_from_sample = rig.turntable.RigFromSample(step.turntable_deg);
    for (Eigen::Vector3d& point : bound) point = rig_from_sample * point;
    for (const std::string& name : step.cameras) {
      const CameraModel* camera = rig.FindCamera(name);
      if (camera == nullptr)
        return NotFoundError("camera '" + name + "'", "step " + std::to_string(step.index) + " uses it; the rig has none");
      LOOM_ASSIGN_OR_RETURN(step.windows[name], WindowSeeing(*camera, bound, options.margin_px, options.alignment_px,
                                                             "the " + std::string(ScanObjectName(step.object))));
    }
  }
  return plan;
}

}  // namespace loom::acquisition
