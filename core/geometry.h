#pragma once
// Geometry helpers on Eigen. Naming convention for transforms (COLMAP's): `b_from_a` maps
// coordinates in frame a to frame b, so they compose like matrices read right to left:
//
//   Rigid3d cam_from_sample = cam_from_rig * rig_from_sample;
//   Eigen::Vector3d p_in_cam = cam_from_sample * p_in_sample;
//
// Frames used across loom: `rig` (scanner frame, z up through the turntable axis, mm),
// `sample` (turntable-fixed, rotates with it), `cam` (OpenCV camera: x right, y down, z forward),
// `local` (per surface point: x = tangent, y = bitangent, z = normal).
// Angles are radians unless the name ends in _deg. Lengths in mm in the rig, sample and camera
// frames.

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace loom {

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;

using Rigid3d = Eigen::Isometry3d;

inline constexpr double kPi = 3.14159265358979323846;

constexpr double DegToRad(double deg) { return deg * (kPi / 180.0); }
constexpr double RadToDeg(double rad) { return rad * (180.0 / kPi); }

// cos^n of a light's falloff. The rigs' exponents are 1 (std::pow(c, 1) is c exactly, at a
// twentieth of the cost: pow was a tenth of a simulated scan) or other small integers.
inline double CosinePower(double c, double n) {
  if (n == 1) return c;
  if (n == 2) return c * c;
  return std::pow(c, n);
}

// b_from_a with the given rotation and translation (p_in_b = R * p_in_a + t).
Rigid3d MakeRigid(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);

// True if the linear part is a rotation (orthonormal, det +1) within `tolerance`.
bool IsRigid(const Rigid3d& transform, double tolerance = 1e-9);

// Unit direction for polar angle theta (from +z) and azimuth phi (from +x towards +y).
Eigen::Vector3d DirectionFromSpherical(double theta, double phi);

struct SphericalAngles {
  double theta = 0.0;  // polar angle from +z, [0, π]
  double phi = 0.0;    // azimuth from +x towards +y, (−π, π]
};
// Angles of a non-zero vector (need not be unit).
SphericalAngles SphericalFromDirection(const Eigen::Vector3d& direction);

// world_from_local for a surface point: columns are the tangent, bitangent and normal.
// The tangent is `tangent_hint` made orthogonal to `normal` (Gram-Schmidt); when the hint is
// (nearly) parallel to the normal, another axis is used. `normal` need not be unit.
Eigen::Matrix3d WorldFromLocal(const Eigen::Vector3d& normal, const Eigen::Vector3d& tangent_hint);

// Rotation by `angle` (right-handed) about the axis through `point_on_axis` with direction
// `axis_direction` (need not be unit), e.g. the turntable: rig_from_sample at a table angle.
Rigid3d RotationAboutAxis(const Eigen::Vector3d& point_on_axis, const Eigen::Vector3d& axis_direction, double angle);

}  // namespace loom
