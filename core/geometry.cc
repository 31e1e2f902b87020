#include "core/geometry.h"

#include <algorithm>
#include <cmath>

#include "core/check.h"

namespace loom {

Rigid3d MakeRigid(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation) {
  Rigid3d b_from_a = Rigid3d::Identity();
  b_from_a.linear() = rotation;
  b_from_a.translation() = translation;
  return b_from_a;
}

bool IsRigid(const Rigid3d& transform, double tolerance) {
  const Eigen::Matrix3d r = transform.linear();
  return (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= tolerance &&
         std::abs(r.determinant() - 1.0) <= tolerance;
}

Eigen::Vector3d DirectionFromSpherical(double theta, double phi) {
  const double s = std::sin(theta);
  return {s * std::cos(phi), s * std::sin(phi), std::cos(theta)};
}

SphericalAngles SphericalFromDirection(const Eigen::Vector3d& direction) {
  const double norm = direction.norm();
  LOOM_CHECK(norm > 0.0) << "direction of a zero vector";
  return {std::acos(std::clamp(direction.z() / norm, -1.0, 1.0)), std::atan2(direction.y(), direction.x())};
}

Eigen::Matrix3d WorldFromLocal(const Eigen::Vector3d& normal, const Eigen::Vector3d& tangent_hint) {
  LOOM_CHECK(normal.norm() > 0.0) << "frame from a zero normal";
  const Eigen::Vector3d n = normal.normalized();
  Eigen::Vector3d t = tangent_hint - tangent_hint.dot(n) * n;
  if (t.norm() < 1e-9 * std::max(1.0, tangent_hint.norm())) {
    // The hint is parallel to the normal: fall back to the axis least aligned with it.
    Eigen::Vector3d axis = Eigen::Vector3d::Zero();
    int least = 0;
    n.cwiseAbs().minCoeff(&least);
    axis[least] = 1.0;
    t = axis - axis.dot(n) * n;
  }
  t.normalize();
  Eigen::Matrix3d world_from_local;
  world_from_local.col(0) = t;
  world_from_local.col(1) = n.cross(t);
  world_from_local.col(2) = n;
  return world_from_local;
}

Rigid3d RotationAboutAxis(const Eigen::Vector3d& point_on_axis, const Eigen::Vector3d& axis_direction, double angle) {
  LOOM_CHECK(axis_direction.norm() > 0.0) << "rotation about a zero axis";
  const Eigen::Matrix3d r = Eigen::AngleAxisd(angle, axis_direction.normalized()).toRotationMatrix();
  // p' = R (p − c) + c
  return MakeRigid(r, point_on_axis - r * point_on_axis);
}

}  // namespace loom
