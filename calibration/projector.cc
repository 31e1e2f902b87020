#include "calibration/projector.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "calibration/internal/provenance.h"
#include "core/config.h"
#include "core/file_io.h"
#include "core/log.h"

namespace loom::calibration {
namespace {

namespace fs = std::filesystem;

constexpr int kSchemaVersion = 1;
constexpr char kModel[] = "pinhole projector, no distortion; column = fx * X/Z + cx in proj_from_rig's frame";
constexpr int kMinCorrespondences = 12;
constexpr double kMinBoardSeparationMm = 5;
constexpr int kMinBoardRaysPerCamera = 200;
// A board ray further than this from the first fit's plane and projector (in robust standard
// deviations) saw something else: the board's edge or side, or a shadow.
constexpr double kBoardOutlierSigmas = 4;
constexpr double kMinBoardOutlierPx = 0.2;
// The boards' fx and cx replace the prior's only when they pin them down this well (1σ). A
// board seen over a small part of the projector's field cannot: on the simulated tac7-mini
// (cameras seeing 32 mm of the projector's 210 mm field) σ is 0.16 % and 1.2 px; with cameras
// seeing 96 mm, 0.019 % and 0.08 px (projector.h).
constexpr double kMaxFocalSigmaPercent = 0.1;
constexpr double kMaxCxSigmaPx = 0.5;

// pose: angle-axis, translation (mm) of proj_from_rig; intrinsics: fx, cx.
template <typename T>
T ColumnOf(const T* pose, const T* intrinsics, const T* in_rig) {
  T in_projector[3];
  ceres::AngleAxisRotatePoint(pose, in_rig, in_projector);
  for (int i = 0; i < 3; ++i) in_projector[i] += pose[3 + i];
  return intrinsics[0] * in_projector[0] / in_projector[2] + intrinsics[1];
}

struct CornerResidual {
  Eigen::Vector3d point;
  double column;

  template <typename T>
  bool operator()(const T* pose, const T* intrinsics, T* residual) const {
    const T in_rig[3] = {T(point.x()), T(point.y()), T(point.z())};
    residual[0] = ColumnOf(pose, intrinsics, in_rig) - T(column);
    return true;
  }
};

// plane: height, slope x, slope y of z = height + slope · (x, y).
template <typename T>
void OnPlane(const FlatBoardRay& ray, const T* plane, T* point) {
  const Eigen::Vector3d& o = ray.origin_mm;
  const Eigen::Vector3d& d = ray.direction;
  const T t =
      (plane[0] + plane[1] * T(o.x()) + plane[2] * T(o.y()) - T(o.z())) / (T(d.z()) - plane[1] * T(d.x()) - plane[2] * T(d.y()));
  for (int i = 0; i < 3; ++i) point[i] = T(o[i]) + t * T(d[i]);
}

struct BoardResidual {
  FlatBoardRay ray;

  template <typename T>
  bool operator()(const T* pose, const T* intrinsics, const T* plane, T* residual) const {
    T point[3];
    OnPlane(ray, plane, point);
    residual[0] = ColumnOf(pose, intrinsics, point) - T(ray.column);
    return true;
  }
};

// Holds the centre's position along the prior's y axis (which no column sees), weakly.
struct CentreAlongYPrior {
  Eigen::Vector3d prior_centre;
  Eigen::Vector3d y_axis;  // rig frame

  template <typename T>
  bool operator()(const T* pose, T* residual) const {
    // centre = −Rᵀ t
    const T minus_t[3] = {-pose[3], -pose[4], -pose[5]};
    const T inverse[3] = {-pose[0], -pose[1], -pose[2]};
    T centre[3];
    ceres::AngleAxisRotatePoint(inverse, minus_t, centre);
    residual[0] = (centre[0] - T(prior_centre.x())) * T(y_axis.x()) + (centre[1] - T(prior_centre.y())) * T(y_axis.y()) +
                  (centre[2] - T(prior_centre.z())) * T(y_axis.z());
    return true;
  }
};

Rigid3d PoseToRigid(const double* pose) {
  Eigen::Matrix3d rotation;
  ceres::AngleAxisToRotationMatrix(pose, ceres::ColumnMajorAdapter3x3(rotation.data()));
  return MakeRigid(rotation, Eigen::Vector3d(pose[3], pose[4], pose[5]));
}

void RigidToPose(const Rigid3d& rigid, double* pose) {
  const Eigen::Matrix3d rotation = rigid.rotation();
  ceres::RotationMatrixToAngleAxis(ceres::ColumnMajorAdapter3x3(rotation.data()), pose);
  for (int i = 0; i < 3; ++i) pose[3 + i] = rigid.translation()[i];
}

Status CheckBoards(const std::vector<FlatBoardView>& boards) {
  if (boards.empty()) return Status::Ok();
  double lowest = boards.front().nominal_height_mm, highest = lowest;
  for (const FlatBoardView& board : boards) {
    lowest = std::min(lowest, board.nominal_height_mm);
    highest = std::max(highest, board.nominal_height_mm);
    std::map<int, int> rays_per_camera;
    for (const FlatBoardRay& ray : board.rays) ++rays_per_camera[ray.camera];
    int cameras = 0;
    for (const auto& [camera, rays] : rays_per_camera) cameras += rays >= kMinBoardRaysPerCamera;
    if (cameras < 2) {
      return FailedPreconditionError("projector board '" + board.name + "'",
                                     "decoded in " + std::to_string(cameras) + " camera(s) at " +
                                         std::to_string(kMinBoardRaysPerCamera) +
                                         " pixels or more: two must see it to place its plane");
    }
  }
  if (highest - lowest < kMinBoardSeparationMm) {
    std::ostringstream message;
    message << "their nominal heights span " << highest - lowest << " mm: at least " << kMinBoardSeparationMm
            << " mm are needed to separate focal length from distance";
    return FailedPreconditionError("projector boards", message.str());
  }
  return Status::Ok();
}

// The fit's parameters: Ceres optimises them in place.
struct ProjectorParameters {
  double pose[6];
  double intrinsics[2];
  std::vector<std::array<double, 3>> planes;

  double Column(const Eigen::Vector3d& in_rig) const { return ColumnOf(pose, intrinsics, in_rig.data()); }
  double Column(const FlatBoardRay& ray, int board) const {
    double point[3];
    OnPlane(ray, planes[board].data(), point);
    return ColumnOf(pose, intrinsics, point);
  }
};

// Sum of squared column residuals over a board's kept rays, and how many.
struct BoardResiduals {
  double sum2 = 0;
  int rays = 0;
};

BoardResiduals ResidualsOf(const FlatBoardView& board, const std::vector<bool>& kept, const ProjectorParameters& parameters,
                           int index) {
  BoardResiduals residuals;
  for (size_t r = 0; r < board.rays.size(); ++r) {
    if (!kept[r]) continue;
    const double error = parameters.Column(board.rays[r], index) - board.rays[r].column;
    residuals.sum2 += error * error;
    ++residuals.rays;
  }
  return residuals;
}

// The standard deviations of fx and cx after a fit, from the Jacobian at the solution scaled by
// the board columns' residual variance; infinite where the Jacobian is rank deficient (boards at
// one height: nothing separates focal length from distance).
Result<Eigen::Vector2d> IntrinsicsSigma(ceres::Problem* problem, double* intrinsics, double residual_rms) {
  ceres::Covariance::Options options;
  options.algorithm_type = ceres::DENSE_SVD;
  options.null_space_rank = 0;  // the weak directions are what this measures: drop none
  ceres::Covariance covariance(options);
  const std::vector<std::pair<const double*, const double*>> blocks = {{intrinsics, intrinsics}};
  if (!covariance.Compute(blocks, problem)) {
    return Eigen::Vector2d(Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity()));
  }
  Eigen::Matrix2d block;
  covariance.GetCovarianceBlock(intrinsics, intrinsics, block.data());
  return Eigen::Vector2d(Eigen::Vector2d(std::sqrt(block(0, 0)), std::sqrt(block(1, 1))) * residual_rms);
}

// Fits `parameters` to the corners and the kept board rays; with hold_intrinsics, fx and cx stay.
// Returns the standard deviations of fx and cx when they were fitted (else zeros).
Result<Eigen::Vector2d> Solve(const ProjectorModel& prior, const ProjectorObservations& observed,
                              const std::vector<std::vector<bool>>& kept, bool hold_intrinsics, ProjectorParameters* parameters) {
  ceres::Problem problem;
  for (const ProjectorCorrespondence& p : observed.corners) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CornerResidual, 1, 6, 2>(new CornerResidual{p.point_mm, p.column}),
                             new ceres::CauchyLoss(1.0), parameters->pose, parameters->intrinsics);
  }
  for (size_t b = 0; b < observed.boards.size(); ++b) {
    for (size_t r = 0; r < observed.boards[b].rays.size(); ++r) {
      if (!kept[b][r]) continue;
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<BoardResidual, 1, 6, 2, 3>(new BoardResidual{observed.boards[b].rays[r]}),
          new ceres::CauchyLoss(1.0), parameters->pose, parameters->intrinsics, parameters->planes[b].data());
    }
  }
  const Rigid3d rig_from_prior = prior.proj_from_rig.inverse();
  problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CentreAlongYPrior, 1, 6>(
                               new CentreAlongYPrior{rig_from_prior.translation(), rig_from_prior.linear().col(1)}),
                           nullptr, parameters->pose);
  if (hold_intrinsics) problem.SetParameterBlockConstant(parameters->intrinsics);
  ceres::Solver::Options options;
  options.max_num_iterations = 200;
  options.function_tolerance = 1e-12;
  options.parameter_tolerance = 1e-12;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable()) return InternalError("projector fit", summary.BriefReport());
  if (hold_intrinsics) return Eigen::Vector2d(Eigen::Vector2d::Zero());
  BoardResiduals all;
  for (size_t b = 0; b < observed.boards.size(); ++b) {
    const BoardResiduals board = ResidualsOf(observed.boards[b], kept[b], *parameters, static_cast<int>(b));
    all.sum2 += board.sum2;
    all.rays += board.rays;
  }
  return IntrinsicsSigma(&problem, parameters->intrinsics, std::sqrt(all.sum2 / std::max(all.rays, 1)));
}

// Drops the board rays the fit leaves far out (robust σ from the median absolute residual).
void DropBoardOutliers(const ProjectorObservations& observed, const ProjectorParameters& parameters,
                       std::vector<std::vector<bool>>* kept) {
  for (size_t b = 0; b < observed.boards.size(); ++b) {
    const std::vector<FlatBoardRay>& rays = observed.boards[b].rays;
    std::vector<double> residuals;
    for (const FlatBoardRay& ray : rays) residuals.push_back(std::abs(parameters.Column(ray, static_cast<int>(b)) - ray.column));
    std::vector<double> sorted = residuals;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double limit = std::max(kMinBoardOutlierPx, kBoardOutlierSigmas * 1.4826 * sorted[sorted.size() / 2]);
    for (size_t r = 0; r < rays.size(); ++r) (*kept)[b][r] = residuals[r] <= limit;
  }
}

FlatBoardFit DescribeBoard(const FlatBoardView& board, const std::vector<bool>& kept, const ProjectorParameters& parameters,
                           int index) {
  const std::array<double, 3>& plane = parameters.planes[index];
  FlatBoardFit fit;
  fit.name = board.name;
  fit.height_mm = plane[0];
  fit.tilt_deg = RadToDeg(std::atan(std::hypot(plane[1], plane[2])));
  const BoardResiduals residuals = ResidualsOf(board, kept, parameters, index);
  fit.rays = residuals.rays;
  fit.rms_columns = fit.rays > 0 ? std::sqrt(residuals.sum2 / fit.rays) : 0;
  return fit;
}

// With boards: drops the rays the first fit cannot explain, fits fx and cx too, and keeps them
// where the boards pin them down; else fits again with the prior's.
Status FitLens(const ProjectorModel& prior, const ProjectorObservations& observed, ProjectorParameters* parameters,
               std::vector<std::vector<bool>>* kept, ProjectorCalibration* result) {
  DropBoardOutliers(observed, *parameters, kept);
  const ProjectorParameters before = *parameters;
  LOOM_ASSIGN_OR_RETURN(const Eigen::Vector2d sigma, Solve(prior, observed, *kept, false, parameters));
  result->focal_sigma_percent = 100 * sigma[0] / parameters->intrinsics[0];
  result->cx_sigma_px = sigma[1];
  result->intrinsics_fitted = result->focal_sigma_percent <= kMaxFocalSigmaPercent && result->cx_sigma_px <= kMaxCxSigmaPx;
  if (result->intrinsics_fitted) return Status::Ok();
  *parameters = before;
  parameters->intrinsics[0] = prior.K(0, 0);
  parameters->intrinsics[1] = prior.K(0, 2);
  return Solve(prior, observed, *kept, true, parameters).status();
}

void DescribeBoards(const ProjectorObservations& observed, const std::vector<std::vector<bool>>& kept,
                    const ProjectorParameters& parameters, ProjectorCalibration* result) {
  for (size_t b = 0; b < observed.boards.size(); ++b) {
    const FlatBoardView& board = observed.boards[b];
    result->boards.push_back(DescribeBoard(board, kept[b], parameters, static_cast<int>(b)));
    if (std::abs(result->boards.back().height_mm - board.nominal_height_mm) > kMinBoardSeparationMm) {
      LOOM_LOG(Warning) << "projector board '" << board.name << "' found at " << result->boards.back().height_mm
                        << " mm, not near its nominal " << board.nominal_height_mm << " mm: was it placed as asked?";
    }
  }
}

// The fit's columns at the corners against the decoded ones and against the prior's.
void DescribeCorners(const ProjectorModel& prior, const ProjectorObservations& observed, const ProjectorParameters& parameters,
                     ProjectorCalibration* result) {
  ProjectorParameters at_prior = parameters;
  RigidToPose(prior.proj_from_rig, at_prior.pose);
  at_prior.intrinsics[0] = prior.K(0, 0);
  at_prior.intrinsics[1] = prior.K(0, 2);
  double sum2 = 0;
  for (const ProjectorCorrespondence& p : observed.corners) {
    const double column = parameters.Column(p.point_mm);
    sum2 += (column - p.column) * (column - p.column);
    result->column_change_px = std::max(result->column_change_px, std::abs(column - at_prior.Column(p.point_mm)));
  }
  result->correspondences = static_cast<int>(observed.corners.size());
  result->rms_columns = std::sqrt(sum2 / observed.corners.size());
}

}  // namespace

Result<ProjectorCalibration> CalibrateProjector(const ProjectorModel& prior, const ProjectorObservations& observed) {
  if (static_cast<int>(observed.corners.size()) < kMinCorrespondences) {
    return FailedPreconditionError("projector", "decoded at " + std::to_string(observed.corners.size()) +
                                                    " target corners: at least " + std::to_string(kMinCorrespondences) +
                                                    " are needed");
  }
  LOOM_RETURN_IF_ERROR(CheckBoards(observed.boards));
  ProjectorParameters parameters;
  RigidToPose(prior.proj_from_rig, parameters.pose);
  parameters.intrinsics[0] = prior.K(0, 0);
  parameters.intrinsics[1] = prior.K(0, 2);
  std::vector<std::vector<bool>> kept;
  for (const FlatBoardView& board : observed.boards) {
    parameters.planes.push_back({board.nominal_height_mm, 0, 0});
    kept.emplace_back(board.rays.size(), true);
  }
  ProjectorCalibration result;
  LOOM_RETURN_IF_ERROR(Solve(prior, observed, kept, observed.boards.empty(), &parameters).status());
  if (!observed.boards.empty()) LOOM_RETURN_IF_ERROR(FitLens(prior, observed, &parameters, &kept, &result));
  result.projector = prior;
  result.projector.proj_from_rig = PoseToRigid(parameters.pose);
  result.projector.K(0, 0) = parameters.intrinsics[0];
  result.projector.K(0, 2) = parameters.intrinsics[1];
  result.focal_change_percent = 100 * (parameters.intrinsics[0] / prior.K(0, 0) - 1);
  result.cx_change_px = parameters.intrinsics[1] - prior.K(0, 2);
  DescribeBoards(observed, kept, parameters, &result);
  DescribeCorners(prior, observed, parameters, &result);
  result.rotation_change_deg =
      RadToDeg(Eigen::AngleAxisd(result.projector.proj_from_rig.rotation() * prior.proj_from_rig.rotation().transpose()).angle());
  result.centre_change_mm =
      (result.projector.proj_from_rig.inverse().translation() - prior.proj_from_rig.inverse().translation()).norm();
  return result;
}

Status WriteProjectorCalibration(const fs::path& directory, const ProjectorCalibration& calibration, const std::string& from) {
  const ProjectorModel& p = calibration.projector;
  YAML::Emitter out;
  out.SetDoublePrecision(17);  // doubles round-trip exactly
  out << YAML::BeginMap;
  out << YAML::Key << "schema_version" << YAML::Value << kSchemaVersion;
  out << YAML::Key << "device" << YAML::Value << "projector";
  out << YAML::Key << "name" << YAML::Value << "projector";
  out << YAML::Key << "model" << YAML::Value << kModel;
  out << YAML::Key << "image_size_px" << YAML::Value << YAML::Flow << std::vector<int>{p.width, p.height};
  out << YAML::Key << "K_px" << YAML::Value;
  internal::EmitMatrix(out, p.K);
  out << YAML::Key << "proj_from_rig" << YAML::Value << YAML::BeginMap << YAML::Key << "rotation" << YAML::Value;
  internal::EmitMatrix(out, p.proj_from_rig.linear());
  const Eigen::Vector3d t = p.proj_from_rig.translation();
  out << YAML::Key << "translation_mm" << YAML::Value << YAML::Flow << std::vector<double>{t.x(), t.y(), t.z()} << YAML::EndMap;
  out << YAML::Key << "quality" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "rms_columns" << YAML::Value << calibration.rms_columns;
  out << YAML::Key << "correspondences" << YAML::Value << calibration.correspondences;
  out << YAML::Key << "column_change_px" << YAML::Value << calibration.column_change_px;
  out << YAML::Key << "rotation_change_deg" << YAML::Value << calibration.rotation_change_deg;
  out << YAML::Key << "centre_change_mm" << YAML::Value << calibration.centre_change_mm;
  out << YAML::Key << "intrinsics" << YAML::Value
      << (calibration.intrinsics_fitted
              ? "fx and cx fitted to the boards' columns; fy, cy the rig YAML's (columns do not see them)"
          : calibration.boards.empty()
              ? "the rig YAML's (the scan has no white tile on a spacer under the patterns)"
              : "the rig YAML's (the boards do not pin fx and cx down: the cameras see too little of the projector's field)");
  out << YAML::Key << "focal_sigma_percent" << YAML::Value << calibration.focal_sigma_percent;
  out << YAML::Key << "cx_sigma_px" << YAML::Value << calibration.cx_sigma_px;
  out << YAML::Key << "focal_change_percent" << YAML::Value << calibration.focal_change_percent;
  out << YAML::Key << "cx_change_px" << YAML::Value << calibration.cx_change_px;
  out << YAML::Key << "boards" << YAML::Value << YAML::BeginSeq;
  for (const FlatBoardFit& board : calibration.boards) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << board.name << YAML::Key << "height_mm"
        << YAML::Value << board.height_mm << YAML::Key << "tilt_deg" << YAML::Value << board.tilt_deg << YAML::Key << "rays"
        << YAML::Value << board.rays << YAML::Key << "rms_columns" << YAML::Value << board.rms_columns << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  internal::EmitSource(out, from);
  out << YAML::EndMap;
  return WriteFileAtomically(directory / "projector.yaml", std::string(out.c_str()) + "\n");
}

Result<bool> ApplyProjectorCalibration(const fs::path& directory, RigModel* rig) {
  const fs::path path = directory / "projector.yaml";
  if (!fs::exists(path)) return false;
  if (!rig->projector) return InvalidArgumentError(path.string(), "rig '" + rig->name + "' has no projector");
  LOOM_ASSIGN_OR_RETURN(const ConfigDocument doc, ConfigDocument::LoadFile(path, kSchemaVersion));
  const ConfigNode root = doc.root();
  internal::ReadHeader(root, "projector", kModel);
  std::vector<int> size;
  Eigen::Matrix3d k, rotation;
  Eigen::Vector3d translation;
  root.Required("image_size_px", &size);
  root.Required("K_px", &k);
  const ConfigNode pose = root.Child("proj_from_rig");
  pose.Required("rotation", &rotation);
  pose.Required("translation_mm", &translation);
  root.Ignore("quality");  // how well it fitted: for people
  internal::ReadSource(root);
  LOOM_RETURN_IF_ERROR(doc.Finish());
  if (size.size() != 2 || size[0] != rig->projector->width || size[1] != rig->projector->height) {
    return InvalidArgumentError(path.string(), "is for another projector resolution than rig '" + rig->name + "''s " +
                                                   std::to_string(rig->projector->width) + "x" +
                                                   std::to_string(rig->projector->height));
  }
  const Rigid3d proj_from_rig = MakeRigid(rotation, translation);
  if (!IsRigid(proj_from_rig, 1e-6)) return InvalidArgumentError(path.string(), "proj_from_rig.rotation is not a rotation");
  rig->projector->K = k;
  rig->projector->proj_from_rig = proj_from_rig;
  return true;
}

}  // namespace loom::calibration
