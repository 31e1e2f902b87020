#include "calibration/projector_columns.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <utility>

#include <Eigen/Dense>

#include "calibration/structured_light.h"

namespace loom::calibration {
namespace {

using scan::Step;
using scan::StepKind;

constexpr int kCornerRadiusPx = 4;
constexpr int kMinDecodedAround = 8;

// The column at a subpixel position from a plane through the decodable pixels around it.
std::optional<double> ColumnAt(const Image& columns, const Eigen::Vector2d& pixel) {
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  int count = 0;
  const int cx = static_cast<int>(std::lround(pixel.x())), cy = static_cast<int>(std::lround(pixel.y()));
  for (int y = std::max(0, cy - kCornerRadiusPx); y <= std::min(columns.height() - 1, cy + kCornerRadiusPx); ++y) {
    for (int x = std::max(0, cx - kCornerRadiusPx); x <= std::min(columns.width() - 1, cx + kCornerRadiusPx); ++x) {
      const float value = columns.at(0, y, x);
      if (std::isnan(value)) continue;
      const Eigen::Vector3d row(1, x - pixel.x(), y - pixel.y());
      normal += row * row.transpose();
      rhs += row * value;
      ++count;
    }
  }
  if (count < kMinDecodedAround) return std::nullopt;
  const Eigen::Vector3d plane = normal.ldlt().solve(rhs);
  return std::isfinite(plane[0]) ? std::optional<double>(plane[0]) : std::nullopt;
}

}  // namespace

std::vector<double> StructuredLightAngles(const scan::Plan& plan, scan::ScanObject object) {
  std::vector<double> angles;
  for (const Step& step : plan.steps) {
    if (step.kind == StepKind::kStructuredLight && step.object == object &&
        std::find(angles.begin(), angles.end(), step.turntable_deg) == angles.end()) {
      angles.push_back(step.turntable_deg);
    }
  }
  return angles;
}

Result<Image> DecodeScanColumns(const ScanRadiance& scan, const CameraModel& camera, scan::ScanObject object,
                                double turntable_deg) {
  const RigModel& rig = scan.rig();
  if (!rig.projector) {
    return FailedPreconditionError("rig '" + rig.name + "'", "the scan has structured light but the rig describes no projector");
  }
  std::vector<scan::ViewId> ids;
  std::vector<std::string> names;
  for (const Step& step : scan.plan().steps) {
    if (step.kind != StepKind::kStructuredLight || step.object != object || step.turntable_deg != turntable_deg) continue;
    ids.push_back({step.index, camera.name});
    names.push_back(step.projector_pattern);
  }
  LOOM_ASSIGN_OR_RETURN(std::vector<RadianceView> views, scan.Views(ids));
  std::map<std::string, Image> patterns;
  for (size_t k = 0; k < ids.size(); ++k) patterns[names[k]] = std::move(views[k].radiance);
  DecodeOptions decode;
  decode.projector_width = rig.projector->width;
  decode.phase_steps = 0;
  while (patterns.contains("phase_x_" + std::to_string(decode.phase_steps))) ++decode.phase_steps;
  if (decode.phase_steps < 3) {
    return NotFoundError("structured light",
                         "needs at least 3 phase_x patterns, the scan has " + std::to_string(decode.phase_steps));
  }
  return DecodeProjectorColumns(patterns, decode);
}

Result<std::vector<ProjectorCorrespondence>> TargetCornerColumns(const ScanRadiance& scan, const CalibrationTargetModel& target,
                                                                 const TargetPlacement& placement) {
  const RigModel& rig = scan.rig();
  const Eigen::Matrix3d yaw = Eigen::AngleAxisd(DegToRad(placement.yaw_deg), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d offset(placement.offset_mm.x(), placement.offset_mm.y(), 0);
  std::vector<ProjectorCorrespondence> correspondences;
  for (double angle : StructuredLightAngles(scan.plan(), scan::ScanObject::kTarget)) {
    const Rigid3d rig_from_sample = rig.turntable.RigFromSample(angle);
    for (const CameraModel& camera : rig.cameras) {
      LOOM_ASSIGN_OR_RETURN(const Image columns, DecodeScanColumns(scan, camera, scan::ScanObject::kTarget, angle));
      for (const Eigen::Vector3d& corner : target.CornersInBoard()) {
        const Eigen::Vector3d in_rig = rig_from_sample * (yaw * (target.SampleFromBoard() * corner) + offset);
        Eigen::Vector2d pixel;
        if (!camera.Project(camera.cam_from_rig * in_rig, &pixel)) continue;
        if (const std::optional<double> column = ColumnAt(columns, pixel)) correspondences.push_back({in_rig, *column});
      }
    }
  }
  return correspondences;
}

Result<std::vector<FlatBoardView>> FlatBoardRays(const ScanRadiance& scan, int max_rays_per_camera) {
  const RigModel& rig = scan.rig();
  const std::vector<std::pair<scan::ScanObject, double>> boards = {
      {scan::ScanObject::kWhiteTile, 0.0}, {scan::ScanObject::kWhiteTileOnSpacer, rig.white_reference.spacer_mm}};
  std::vector<double> angles;
  for (const auto& [object, height] : boards) {
    const std::vector<double> at = StructuredLightAngles(scan.plan(), object);
    if (at.empty()) return std::vector<FlatBoardView>();  // no spacer step: no boards at all
    angles.push_back(at.front());
  }
  std::vector<FlatBoardView> views;
  for (size_t b = 0; b < boards.size(); ++b) {
    const auto& [object, height] = boards[b];
    const double angle = angles[b];
    FlatBoardView view{std::string(scan::ScanObjectName(object)), height, {}};
    for (int c = 0; c < static_cast<int>(rig.cameras.size()); ++c) {
      const CameraModel& camera = rig.cameras[c];
      LOOM_ASSIGN_OR_RETURN(const Image columns, DecodeScanColumns(scan, camera, object, angle));
      const int stride =
          std::max(1, static_cast<int>(std::ceil(std::sqrt(double(camera.width) * camera.height / max_rays_per_camera))));
      // The board lies still at `angle`; rays in the rig frame are what the fit needs.
      const Rigid3d rig_from_cam = camera.cam_from_rig.inverse();
      for (int y = stride / 2; y < camera.height; y += stride) {
        for (int x = stride / 2; x < camera.width; x += stride) {
          const float column = columns.at(0, y, x);
          if (std::isnan(column)) continue;
          view.rays.push_back({c, rig_from_cam.translation(), rig_from_cam.rotation() * camera.Unproject({x, y}), column});
        }
      }
    }
    views.push_back(std::move(view));
  }
  return views;
}

}  // namespace loom::calibration
