#include "core/geometry.h"

#include <gtest/gtest.h>

namespace loom {
namespace {

TEST(GeometryTest, SphericalRoundTrip) {
  for (double theta : {0.1, 0.7, 1.5, 2.9}) {
    for (double phi : {-3.0, -1.0, 0.0, 2.0, 3.1}) {
      const Eigen::Vector3d d = DirectionFromSpherical(theta, phi);
      EXPECT_NEAR(d.norm(), 1.0, 1e-15);
      const SphericalAngles a = SphericalFromDirection(3.0 * d);
      EXPECT_NEAR(a.theta, theta, 1e-12);
      EXPECT_NEAR(a.phi, phi, 1e-12);
    }
  }
}

TEST(GeometryTest, ComposedTransformsReadRightToLeft) {
  const Rigid3d rig_from_sample = RotationAboutAxis({10, 0, 0}, {0, 0, 1}, DegToRad(90));
  const Rigid3d cam_from_rig = MakeRigid(Eigen::Matrix3d::Identity(), {0, 0, 500});
  const Rigid3d cam_from_sample = cam_from_rig * rig_from_sample;
  // (11, 0, 0) is 1 mm from the axis at x = 10: rotating 90° about z moves it to (10, 1, 0).
  const Eigen::Vector3d p_in_cam = cam_from_sample * Eigen::Vector3d(11, 0, 0);
  EXPECT_TRUE(p_in_cam.isApprox(Eigen::Vector3d(10, 1, 500), 1e-12)) << p_in_cam.transpose();
  EXPECT_TRUE(IsRigid(cam_from_sample));
  EXPECT_TRUE((cam_from_sample.inverse() * p_in_cam).isApprox(Eigen::Vector3d(11, 0, 0), 1e-12));
}

TEST(GeometryTest, IsRigidRejectsScaleAndReflection) {
  Rigid3d scaled = Rigid3d::Identity();
  scaled.linear() *= 2.0;
  EXPECT_FALSE(IsRigid(scaled));
  Rigid3d mirrored = Rigid3d::Identity();
  mirrored.linear()(0, 0) = -1.0;
  EXPECT_FALSE(IsRigid(mirrored));
}

TEST(GeometryTest, LocalFrameIsOrthonormalAndFollowsHint) {
  const Eigen::Vector3d normal(0.2, -0.1, 1.0);
  const Eigen::Matrix3d world_from_local = WorldFromLocal(normal, {1, 0, 0});
  EXPECT_TRUE((world_from_local.transpose() * world_from_local).isIdentity(1e-12));
  EXPECT_NEAR(world_from_local.determinant(), 1.0, 1e-12);
  EXPECT_TRUE(world_from_local.col(2).isApprox(normal.normalized()));
  EXPECT_GT(world_from_local.col(0).x(), 0.9);  // tangent stays close to the hint
  // A hint parallel to the normal still gives a valid frame.
  const Eigen::Matrix3d fallback = WorldFromLocal({0, 0, 1}, {0, 0, 5});
  EXPECT_TRUE((fallback.transpose() * fallback).isIdentity(1e-12));
}

TEST(GeometryTest, CosinePowerIsPowsFalloff) {
  for (double c : {0.0, 1e-300, 0.013, 0.5, 0.7071067811865476, 0.999, 1.0}) {
    EXPECT_EQ(CosinePower(c, 1), std::pow(c, 1.0)) << c;
    EXPECT_NEAR(CosinePower(c, 2), std::pow(c, 2.0), 1e-16) << c;
    for (double n : {0.0, 0.5, 3.0, 7.25}) EXPECT_EQ(CosinePower(c, n), std::pow(c, n)) << c << "^" << n;
  }
}

}  // namespace
}  // namespace loom
