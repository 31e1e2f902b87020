// LightGeometryAt against PointEmitter's own one-at-a-time arithmetic.

#include "fitting/model/internal/light_samples.h"

#include <gtest/gtest.h>

#include "core/geometry.h"

namespace loom::fitting::internal {
namespace {

// A strip of 19 emitters (more than one 512-bit vector, and a remainder), one of them facing
// away from the pixel, one with a falloff of 2 and one with a falloff of 1.5 (std::pow's path).
std::vector<PointEmitter> Emitters() {
  std::vector<PointEmitter> emitters;
  for (int i = 0; i < 19; ++i) {
    PointEmitter e;
    e.position_mm = {-90.0 + 10 * i, 20.0, 300.0};
    e.axis = Eigen::Vector3d(0.1 * (i % 3), -0.05, -1).normalized();
    e.intensity = 1e6 * (1 + 0.1 * i);
    emitters.push_back(e);
  }
  emitters[4].axis = Eigen::Vector3d::UnitZ();  // away from the sample
  emitters[7].falloff_exponent = 2;
  emitters[11].falloff_exponent = 1.5;
  return emitters;
}

TEST(LightGeometryTest, EveryEmittersDirectionAndIrradianceAreWhatTheEmitterGivesOneAtATime) {
  const std::vector<PointEmitter> emitters = Emitters();
  const Eigen::Vector3d p(3.5, -2.25, 0.4);
  const Eigen::Matrix3d local_from_sample =
      WorldFromLocal(Eigen::Vector3d(0.2, -0.1, 1).normalized(), Eigen::Vector3d::UnitX()).transpose();
  LightGeometry geometry;
  LightGeometryAt(EmitterArrays(emitters), p, local_from_sample, geometry);
  ASSERT_EQ(geometry.irradiance.size(), emitters.size());
  for (size_t i = 0; i < emitters.size(); ++i) {
    const Eigen::Vector3d to_light = emitters[i].position_mm - p;
    const Eigen::Vector3d l = to_light.normalized();
    const double irradiance = emitters[i].IntensityTowards(p) / to_light.squaredNorm();
    const Eigen::Vector3d l_local = local_from_sample * l;
    EXPECT_NEAR(geometry.irradiance[i], irradiance, 1e-14 * std::abs(irradiance) + 1e-300) << "emitter " << i;
    EXPECT_NEAR(geometry.lx[i], l_local.x(), 1e-15) << "emitter " << i;
    EXPECT_NEAR(geometry.ly[i], l_local.y(), 1e-15) << "emitter " << i;
    EXPECT_NEAR(geometry.lz[i], l_local.z(), 1e-15) << "emitter " << i;
  }
  EXPECT_EQ(geometry.irradiance[4], 0);  // facing away
  EXPECT_GT(geometry.irradiance[11], 0);
}

}  // namespace
}  // namespace loom::fitting::internal
