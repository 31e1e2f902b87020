#include "calibration/geometry.h"

#include <algorithm>
#include <cmath>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "calibration/board.h"
#include "calibration/opencv_pose.h"
#include "core/log.h"

namespace loom::calibration {
namespace {

constexpr int kIntrinsicParams = 8;  // fx fy cx cy k1 k2 p1 p2

Eigen::Matrix3d Rz(double deg) { return Eigen::AngleAxisd(DegToRad(deg), Eigen::Vector3d::UnitZ()).toRotationMatrix(); }

// The target corner in the sample frame (before the operator's placement) and the turntable's
// rotation of that view: the rig-frame point is Rz(θ) · (Rz(yaw) · corner + offset).
struct CornerResidual {
  Eigen::Vector3d corner_in_sample;
  Eigen::Matrix3d rig_from_sample;
  Eigen::Vector2d observed;

  // placement: offset x, y (mm), yaw (rad).
  template <typename T>
  bool operator()(const T* pose, const T* intrinsics, const T* placement, T* residual) const {
    using std::cos, std::sin;
    const T c = cos(placement[2]), s = sin(placement[2]);
    const T in_sample[3] = {c * corner_in_sample.x() - s * corner_in_sample.y() + placement[0],
                            s * corner_in_sample.x() + c * corner_in_sample.y() + placement[1], T(corner_in_sample.z())};
    T in_rig[3];
    for (int i = 0; i < 3; ++i) {
      in_rig[i] = T(rig_from_sample(i, 0)) * in_sample[0] + T(rig_from_sample(i, 1)) * in_sample[1] +
                  T(rig_from_sample(i, 2)) * in_sample[2];
    }
    T in_cam[3];
    ceres::AngleAxisRotatePoint(pose, in_rig, in_cam);
    for (int i = 0; i < 3; ++i) in_cam[i] += pose[3 + i];
    // OpenCV's pinhole + distortion (k1 k2 p1 p2), pixel centres at integers.
    const T x = in_cam[0] / in_cam[2], y = in_cam[1] / in_cam[2];
    const T r2 = x * x + y * y;
    const T radial = T(1) + intrinsics[4] * r2 + intrinsics[5] * r2 * r2;
    const T xd = x * radial + T(2) * intrinsics[6] * x * y + intrinsics[7] * (r2 + T(2) * x * x);
    const T yd = y * radial + intrinsics[6] * (r2 + T(2) * y * y) + T(2) * intrinsics[7] * x * y;
    residual[0] = intrinsics[0] * xd + intrinsics[2] - T(observed.x());
    residual[1] = intrinsics[1] * yd + intrinsics[3] - T(observed.y());
    return true;
  }
};

struct CameraBlock {
  double pose[6];  // angle-axis, translation (mm)
  double intrinsics[kIntrinsicParams];
};

CameraBlock ToBlock(const Rigid3d& cam_from_rig, const Eigen::Matrix3d& K, const Eigen::Matrix<double, 5, 1>& d) {
  CameraBlock block;
  const Eigen::AngleAxisd rotation(cam_from_rig.rotation());
  const Eigen::Vector3d aa = rotation.angle() * rotation.axis();
  for (int i = 0; i < 3; ++i) block.pose[i] = aa[i], block.pose[3 + i] = cam_from_rig.translation()[i];
  const double intrinsics[kIntrinsicParams] = {K(0, 0), K(1, 1), K(0, 2), K(1, 2), d[0], d[1], d[2], d[3]};
  std::copy(intrinsics, intrinsics + kIntrinsicParams, block.intrinsics);
  return block;
}

Rigid3d PoseOf(const CameraBlock& block) {
  const Eigen::Vector3d aa(block.pose[0], block.pose[1], block.pose[2]);
  const Eigen::Matrix3d rotation =
      aa.norm() > 0 ? Eigen::AngleAxisd(aa.norm(), aa.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
  return MakeRigid(rotation, Eigen::Vector3d(block.pose[3], block.pose[4], block.pose[5]));
}

// Step 1 for one view: OpenCV's poses of the board from the camera's prior intrinsics. A
// planar board seen nearly orthographically has two poses that explain it about equally
// (mirrored tilts): both are returned.
std::vector<Rigid3d> CamFromBoardCandidates(const CameraModel& camera, const CalibrationTargetModel& target,
                                            const TargetView& view) {
  std::vector<cv::Point3d> object;
  for (const Eigen::Vector3d& p : target.CornersInBoard()) object.emplace_back(p.x(), p.y(), p.z());
  std::vector<cv::Point2d> image;
  for (const Eigen::Vector2d& c : view.corners) image.emplace_back(c.x(), c.y());
  cv::Mat K, distortion;
  cv::eigen2cv(camera.K, K);
  cv::eigen2cv(Eigen::Matrix<double, 5, 1>(camera.distortion), distortion);
  std::vector<cv::Mat> rvecs, tvecs;
  cv::solvePnPGeneric(object, image, K, distortion, rvecs, tvecs, false, cv::SOLVEPNP_IPPE);
  std::vector<Rigid3d> poses;
  for (size_t i = 0; i < rvecs.size(); ++i) poses.push_back(RigidFromOpenCv(rvecs[i], tvecs[i]));
  return poses;
}

CornerResidual ResidualOf(const TargetView& view, const Eigen::Vector3d& corner_in_sample, int corner) {
  return {corner_in_sample, Rz(view.turntable_deg), view.corners[corner]};
}

// The target's corners in the sample frame, in CornersInBoard order.
std::vector<Eigen::Vector3d> InSample(const CalibrationTargetModel& target) {
  std::vector<Eigen::Vector3d> in_sample;
  for (const Eigen::Vector3d& p : target.CornersInBoard()) in_sample.push_back(target.SampleFromBoard() * p);
  return in_sample;
}

// One residual per corner of every view, on its camera's block and the shared placement.
// `loss_scale_px` > 0: a Cauchy loss of that scale on each.
void AddCornerResiduals(const std::vector<TargetView>& views, const std::vector<Eigen::Vector3d>& in_sample,
                        std::vector<CameraBlock>* blocks, double* placement, ceres::Problem* problem, double loss_scale_px = 0) {
  for (const TargetView& view : views) {
    CameraBlock& block = blocks->at(view.camera);
    for (size_t k = 0; k < in_sample.size(); ++k) {
      problem->AddResidualBlock(new ceres::AutoDiffCostFunction<CornerResidual, 2, 6, kIntrinsicParams, 3>(
                                    new CornerResidual(ResidualOf(view, in_sample[k], static_cast<int>(k)))),
                                loss_scale_px > 0 ? new ceres::CauchyLoss(loss_scale_px) : nullptr, block.pose, block.intrinsics,
                                placement);
    }
  }
}

Status Solve(const std::string& what, ceres::Problem* problem) {
  ceres::Solver::Options options;
  options.max_num_iterations = 200;
  options.function_tolerance = 1e-12;
  options.parameter_tolerance = 1e-12;
  ceres::Solver::Summary summary;
  ceres::Solve(options, problem, &summary);
  if (!summary.IsSolutionUsable()) return InternalError(what, summary.BriefReport());
  return Status::Ok();
}

// Radiance → 8-bit grey, the 99th percentile of the finite values at 240.
cv::Mat ToGrey(const Image& radiance) {
  std::vector<float> finite;
  for (float v : radiance.channel(0)) {
    if (std::isfinite(v)) finite.push_back(v);
  }
  float top = 1;
  if (!finite.empty()) {
    const auto at = finite.begin() + static_cast<long>(0.99 * (finite.size() - 1));
    std::nth_element(finite.begin(), at, finite.end());
    top = std::max(*at, 1e-12f);
  }
  cv::Mat grey(radiance.height(), radiance.width(), CV_8U);
  for (int y = 0; y < radiance.height(); ++y) {
    for (int x = 0; x < radiance.width(); ++x) {
      const float v = radiance.at(0, y, x);
      grey.at<uint8_t>(y, x) = static_cast<uint8_t>(std::clamp(std::isfinite(v) ? 240.0f * v / top : 255.0f, 0.0f, 255.0f));
    }
  }
  return grey;
}

// The part of a view's sensor that its frames read.
cv::Rect WindowRect(const RadianceView& view) {
  const scan::Roi& w = view.window;
  const cv::Rect window(w.x, w.y, w.width > 0 ? w.width : view.radiance.width() - w.x,
                        w.height > 0 ? w.height : view.radiance.height() - w.y);
  return window & cv::Rect(0, 0, view.radiance.width(), view.radiance.height());
}

Eigen::Vector2d Centroid(const std::vector<Eigen::Vector2d>& points) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& p : points) sum += p;
  return sum / static_cast<double>(points.size());
}

// The detected corners in the order (of the four a rows × cols grid can be read in) whose
// shape matches `expected` best. Shape, not position: a camera a few mm from its nominal
// place sees the whole board shifted by tens of pixels.
std::vector<Eigen::Vector2d> OrderLike(const std::vector<Eigen::Vector2d>& found, const std::vector<Eigen::Vector2d>& expected,
                                       int cols, int rows) {
  const Eigen::Vector2d shift = Centroid(expected) - Centroid(found);
  std::vector<Eigen::Vector2d> best;
  double best_distance = INFINITY;
  for (int flip = 0; flip < 4; ++flip) {
    std::vector<Eigen::Vector2d> ordered(found.size());
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c < cols; ++c) {
        const int rr = (flip & 1) ? rows - 1 - r : r, cc = (flip & 2) ? cols - 1 - c : c;
        ordered[r * cols + c] = found[rr * cols + cc];
      }
    }
    double distance = 0;
    for (size_t k = 0; k < found.size(); ++k) distance += (ordered[k] + shift - expected[k]).norm();
    if (distance < best_distance) best_distance = distance, best = std::move(ordered);
  }
  return best;
}

// Step 1: of the cam_from_rig that every view's board poses imply, the one that explains all
// the camera's views best.
CameraBlock InitialBlock(const CameraModel& camera, const CalibrationTargetModel& target,
                         const std::vector<Eigen::Vector3d>& in_sample, const std::vector<const TargetView*>& views) {
  const double no_placement[3] = {0, 0, 0};
  CameraBlock best = ToBlock(camera.cam_from_rig, camera.K, camera.distortion);
  double best_cost = INFINITY;
  for (const TargetView* view : views) {
    const Rigid3d rig_from_board = MakeRigid(Rz(view->turntable_deg), Eigen::Vector3d::Zero()) * target.SampleFromBoard();
    for (const Rigid3d& cam_from_board : CamFromBoardCandidates(camera, target, *view)) {
      const CameraBlock candidate = ToBlock(cam_from_board * rig_from_board.inverse(), camera.K, camera.distortion);
      double cost = 0;
      for (const TargetView* other : views) {
        for (size_t k = 0; k < in_sample.size(); ++k) {
          double r[2];
          ResidualOf(*other, in_sample[k], static_cast<int>(k))(candidate.pose, candidate.intrinsics, no_placement, r);
          cost += r[0] * r[0] + r[1] * r[1];
        }
      }
      if (cost < best_cost) best_cost = cost, best = candidate;
    }
  }
  return best;
}

}  // namespace

std::optional<std::vector<Eigen::Vector2d>> FindTargetCorners(const RadianceView& view, const CalibrationTargetModel& target) {
  const BoardSpec board{"chessboard", target.inner_cols, target.inner_rows, target.square_mm};
  const cv::Rect window = WindowRect(view);
  return FindBoardCorners(ToGrey(view.radiance)(window), board, Eigen::Vector2d(window.x, window.y));
}

Result<DetectedTargetViews> DetectTargetViews(const ScanRadiance& scan, const CalibrationTargetModel& target) {
  const RigModel& rig = scan.rig();
  DetectedTargetViews detected;
  std::vector<scan::ViewId> ids;
  for (const scan::Step& step : scan.plan().steps) {
    if (step.kind != scan::StepKind::kTarget) continue;
    for (const std::string& camera_name : step.cameras) ids.push_back({step.index, camera_name});
  }
  LOOM_ASSIGN_OR_RETURN(const std::vector<RadianceView> views, scan.Views(ids));
  for (size_t k = 0; k < ids.size(); ++k) {
    const RadianceView& view = views[k];
    const scan::ViewId& id = ids[k];
    const std::optional<std::vector<Eigen::Vector2d>> corners = FindTargetCorners(view, target);
    if (!corners) {
      LOOM_LOG(Warning) << id.ToString() << ": target not found, view skipped";
      detected.skipped.push_back(id);
      continue;
    }
    const CameraModel& camera = rig.cameras[view.camera];
    const Rigid3d cam_from_board =
        camera.cam_from_rig * rig.turntable.RigFromSample(view.state.turntable_deg) * target.SampleFromBoard();
    std::vector<Eigen::Vector2d> expected;
    for (const Eigen::Vector3d& p : target.CornersInBoard()) {
      Eigen::Vector2d pixel(0, 0);
      camera.Project(cam_from_board * p, &pixel);
      expected.push_back(pixel);
    }
    detected.views.push_back(
        {view.camera, view.state.turntable_deg, id, OrderLike(*corners, expected, target.inner_cols, target.inner_rows)});
  }
  return detected;
}

namespace {

// Step 2 on the views given.
Result<RigGeometry> Adjust(const RigModel& nominal, const CalibrationTargetModel& target, const std::vector<TargetView>& views,
                           const GeometryOptions& options) {
  const std::vector<Eigen::Vector3d> board = target.CornersInBoard();
  const std::vector<Eigen::Vector3d> in_sample = InSample(target);
  const int cameras = static_cast<int>(nominal.cameras.size());
  std::vector<std::vector<const TargetView*>> by_camera(cameras);
  for (const TargetView& view : views) {
    if (view.camera < 0 || view.camera >= cameras || view.corners.size() != board.size()) {
      return InvalidArgumentError("target view " + view.view.ToString(), "not a view of the rig's target by one of its cameras");
    }
    by_camera[view.camera].push_back(&view);
  }
  RigGeometry geometry;
  std::vector<CameraBlock> blocks;
  for (int c = 0; c < cameras; ++c) {
    const CameraModel& camera = nominal.cameras[c];
    if (static_cast<int>(by_camera[c].size()) < options.min_views_per_camera) {
      return FailedPreconditionError("camera " + camera.name, "saw the target in " + std::to_string(by_camera[c].size()) +
                                                                  " views; calibration needs at least " +
                                                                  std::to_string(options.min_views_per_camera));
    }
    blocks.push_back(InitialBlock(camera, target, in_sample, by_camera[c]));
  }

  double placement[3] = {0, 0, 0};
  ceres::Problem problem;
  AddCornerResiduals(views, in_sample, &blocks, placement, &problem);
  // The target's yaw is the rig frame's: held at 0, it makes the target's rows the rig's x.
  problem.SetManifold(placement, new ceres::SubsetManifold(3, {2}));
  if (!options.fit_intrinsics) {
    for (CameraBlock& block : blocks) problem.SetParameterBlockConstant(block.intrinsics);
  }
  LOOM_RETURN_IF_ERROR(Solve("bundle adjustment", &problem));

  geometry.target.offset_mm = Eigen::Vector2d(placement[0], placement[1]);
  double squares = 0;
  int corners = 0;
  for (int c = 0; c < cameras; ++c) {
    CameraGeometry& result = geometry.cameras.emplace_back();
    const CameraBlock& block = blocks[c];
    result.name = nominal.cameras[c].name;
    result.cam_from_rig = PoseOf(block);
    Intrinsics& intrinsics = result.intrinsics;
    intrinsics.width = nominal.cameras[c].width;
    intrinsics.height = nominal.cameras[c].height;
    intrinsics.K << block.intrinsics[0], 0, block.intrinsics[2], 0, block.intrinsics[1], block.intrinsics[3], 0, 0, 1;
    intrinsics.distortion << block.intrinsics[4], block.intrinsics[5], block.intrinsics[6], block.intrinsics[7], 0;
    double camera_squares = 0;
    for (const TargetView* view : by_camera[c]) {
      double view_squares = 0;
      for (size_t k = 0; k < board.size(); ++k) {
        double r[2];
        ResidualOf(*view, in_sample[k], static_cast<int>(k))(block.pose, block.intrinsics, placement, r);
        view_squares += r[0] * r[0] + r[1] * r[1];
      }
      intrinsics.per_view_rms_px.push_back(std::sqrt(view_squares / board.size()));
      result.view_sources.push_back(view->view.ToString());
      camera_squares += view_squares;
    }
    intrinsics.rms_px = std::sqrt(camera_squares / (board.size() * by_camera[c].size()));
    squares += camera_squares;
    corners += static_cast<int>(board.size() * by_camera[c].size());
  }
  geometry.rms_px = std::sqrt(squares / corners);
  return geometry;
}

}  // namespace

RigModel ApplyGeometry(const RigModel& nominal, const RigGeometry& geometry) {
  RigModel rig = nominal;
  for (size_t c = 0; c < rig.cameras.size() && c < geometry.cameras.size(); ++c) {
    rig.cameras[c].K = geometry.cameras[c].intrinsics.K;
    rig.cameras[c].distortion = geometry.cameras[c].intrinsics.distortion;
    rig.cameras[c].cam_from_rig = geometry.cameras[c].cam_from_rig;
  }
  rig.turntable = TurntableModel{};  // the rig frame is the turntable's
  return rig;
}

Status GeometryOptions::Check() const {
  std::vector<std::string> problems;
  if (min_views_per_camera < 1) problems.push_back("min_views_per_camera must be ≥ 1");
  if (!(reject_view_above_px > 0 && std::isfinite(reject_view_above_px))) {
    problems.push_back("reject_view_above_px must be > 0 and finite");
  }
  return ProblemsStatus("GeometryOptions", problems);
}

Result<RigGeometry> CalibrateRigGeometry(const RigModel& nominal, const CalibrationTargetModel& target,
                                         const std::vector<TargetView>& views, const GeometryOptions& options) {
  LOOM_RETURN_IF_ERROR(options.Check());
  std::vector<TargetView> kept = views;
  std::vector<scan::ViewId> rejected;
  for (;;) {
    LOOM_ASSIGN_OR_RETURN(RigGeometry geometry, Adjust(nominal, target, kept, options));
    // The worst view alone: one misdetection drags the others' residuals up with it.
    const RigModel rig = ApplyGeometry(nominal, geometry);
    size_t worst = 0;
    double worst_rms = -1;
    for (size_t v = 0; v < kept.size(); ++v) {
      const double rms = ReprojectionRms(rig, target, geometry.target, {kept[v]});
      if (rms > worst_rms) worst_rms = rms, worst = v;
    }
    if (worst_rms <= options.reject_view_above_px) {
      geometry.rejected = rejected;
      return geometry;
    }
    LOOM_LOG(Warning) << kept[worst].view.ToString() << ": target " << worst_rms
                      << " px RMS from where the calibration puts it, view rejected";
    rejected.push_back(kept[worst].view);
    kept.erase(kept.begin() + static_cast<long>(worst));
  }
}

double ReprojectionRms(const RigModel& rig, const CalibrationTargetModel& target, const TargetPlacement& placement,
                       const std::vector<TargetView>& views) {
  const std::vector<Eigen::Vector3d> board = target.CornersInBoard();
  const Eigen::Matrix3d yaw = Rz(placement.yaw_deg);
  const Eigen::Vector3d offset(placement.offset_mm.x(), placement.offset_mm.y(), 0);
  double squares = 0;
  int count = 0;
  for (const TargetView& view : views) {
    const CameraModel& camera = rig.cameras.at(view.camera);
    const Rigid3d cam_from_sample = camera.cam_from_rig * rig.turntable.RigFromSample(view.turntable_deg);
    for (size_t k = 0; k < board.size(); ++k) {
      const Eigen::Vector3d p = yaw * (target.SampleFromBoard() * board[k]) + offset;
      Eigen::Vector2d pixel;
      if (!camera.Project(cam_from_sample * p, &pixel)) continue;
      squares += (pixel - view.corners[k]).squaredNorm();
      ++count;
    }
  }
  return count ? std::sqrt(squares / count) : 0;
}

Result<TargetPlacement> FitTargetPlacement(const RigModel& rig, const CalibrationTargetModel& target,
                                           const std::vector<TargetView>& views) {
  if (views.empty()) return InvalidArgumentError("target views", "none to place the target from");
  std::vector<CameraBlock> blocks;
  for (const CameraModel& camera : rig.cameras) blocks.push_back(ToBlock(camera.cam_from_rig, camera.K, camera.distortion));
  double placement[3] = {0, 0, 0};
  // Least squares first, then robustly from there: a camera that moved since `rig` was
  // calibrated is far off wherever the target lies, and must not drag the placement that the
  // cameras still in place agree on.
  for (const double loss_scale_px : {0.0, 1.0}) {
    ceres::Problem problem;
    AddCornerResiduals(views, InSample(target), &blocks, placement, &problem, loss_scale_px);
    for (CameraBlock& block : blocks) {
      if (problem.HasParameterBlock(block.pose)) {
        problem.SetParameterBlockConstant(block.pose);
        problem.SetParameterBlockConstant(block.intrinsics);
      }
    }
    LOOM_RETURN_IF_ERROR(Solve("target placement", &problem));
  }
  return TargetPlacement{Eigen::Vector2d(placement[0], placement[1]), RadToDeg(placement[2])};
}

}  // namespace loom::calibration
