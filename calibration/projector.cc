#include "calibration/projector.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "calibration/internal/provenance.h"
#include "core/config.h"
#include "core/file_io.h"

namespace loom::calibration {
namespace {

namespace fs = std::filesystem;

constexpr int kSchemaVersion = 1;
constexpr char kModel[] = "pinhole projector, no distortion; column = fx * X/Z + cx in proj_from_rig's frame";
constexpr int kMinCorrespondences = 12;

// pose: angle-axis, translation (mm) of proj_from_rig.
struct ColumnResidual {
  Eigen::Vector3d point;
  double column;
  double fx, cx;

  template <typename T>
  bool operator()(const T* pose, T* residual) const {
    const T in_rig[3] = {T(point.x()), T(point.y()), T(point.z())};
    T in_projector[3];
    ceres::AngleAxisRotatePoint(pose, in_rig, in_projector);
    for (int i = 0; i < 3; ++i) in_projector[i] += pose[3 + i];
    residual[0] = T(fx) * in_projector[0] / in_projector[2] + T(cx) - T(column);
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


}  // namespace

Result<ProjectorCalibration> CalibrateProjector(const ProjectorModel& prior, const std::vector<ProjectorCorrespondence>& points) {
  if (static_cast<int>(points.size()) < kMinCorrespondences) {
    return FailedPreconditionError("projector", "decoded at " + std::to_string(points.size()) + " target corners: at least " +
                                                    std::to_string(kMinCorrespondences) + " are needed");
  }
  double pose[6];
  RigidToPose(prior.proj_from_rig, pose);
  ceres::Problem problem;
  for (const ProjectorCorrespondence& p : points) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ColumnResidual, 1, 6>(
                                 new ColumnResidual{p.point_mm, p.column, prior.K(0, 0), prior.K(0, 2)}),
                             new ceres::CauchyLoss(1.0), pose);
  }
  const Rigid3d rig_from_prior = prior.proj_from_rig.inverse();
  problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CentreAlongYPrior, 1, 6>(
                               new CentreAlongYPrior{rig_from_prior.translation(), rig_from_prior.linear().col(1)}),
                           nullptr, pose);
  ceres::Solver::Options options;
  options.max_num_iterations = 200;
  options.function_tolerance = 1e-12;
  options.parameter_tolerance = 1e-12;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable()) return InternalError("projector pose fit", summary.BriefReport());
  ProjectorCalibration result;
  result.projector = prior;
  result.projector.proj_from_rig = PoseToRigid(pose);
  result.correspondences = static_cast<int>(points.size());
  const auto column_of = [](const ProjectorModel& projector, const Eigen::Vector3d& p) {
    const Eigen::Vector3d q = projector.proj_from_rig * p;
    return projector.K(0, 0) * q.x() / q.z() + projector.K(0, 2);
  };
  double sum2 = 0;
  for (const ProjectorCorrespondence& p : points) {
    const double error = column_of(result.projector, p.point_mm) - p.column;
    sum2 += error * error;
    result.column_change_px = std::max(result.column_change_px, std::abs(column_of(result.projector, p.point_mm) - column_of(prior, p.point_mm)));
  }
  result.rms_columns = std::sqrt(sum2 / points.size());
  result.rotation_change_deg =
      RadToDeg(Eigen::AngleAxisd(result.projector.proj_from_rig.rotation() * prior.proj_from_rig.rotation().transpose()).angle());
  result.centre_change_mm = (result.projector.proj_from_rig.inverse().translation() - rig_from_prior.translation()).norm();
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
  out << YAML::Key << "centre_change_mm" << YAML::Value << calibration.centre_change_mm << YAML::EndMap;
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
                                                   std::to_string(rig->projector->width) + "x" + std::to_string(rig->projector->height));
  }
  const Rigid3d proj_from_rig = MakeRigid(rotation, translation);
  if (!IsRigid(proj_from_rig, 1e-6)) return InvalidArgumentError(path.string(), "proj_from_rig.rotation is not a rotation");
  rig->projector->K = k;
  rig->projector->proj_from_rig = proj_from_rig;
  return true;
}

}  // namespace loom::calibration
