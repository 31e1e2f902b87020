#pragma once
// What every fitter and the CNN's re-rendering share: one observation of a pixel, in the pixel's
// local geometric frame (x tangent, y bitangent, z geometric normal): its radiance, the view
// direction, the colour weights the camera records of RGB albedo, and its light samples (one for
// an LED, several for a segment of the linear light), each a direction and the irradiance it
// brings (I / d², the cosine left to the model); and the model's prediction of it.

#include <vector>

#include <Eigen/Core>

#include "fitting/model/ward_gd10.h"

namespace loom::fitting {

struct LightSample {
  Eigen::Vector3d l_local;  // unit, towards the light
  double irradiance = 0;    // I / d² at the pixel, radiance units
};

struct PixelObservation {
  double radiance = 0;                                 // NaN: masked (unseen, shadowed)
  Eigen::Vector3d v_local = Eigen::Vector3d::UnitZ();  // unit, towards the camera
  Eigen::Vector3d rgb_weights = Eigen::Vector3d::Constant(1.0 / 3);
  std::vector<LightSample> lights;
  int source = -1;  // the stack observation it came from (−1: not from a stack)
};

// The model's prediction for one observation.
template <typename T>
T PredictRadiance(const WardLobe<T>& lobe, const PixelObservation& observation) {
  const Vec3<T> v = observation.v_local.cast<T>();
  const Vec3<T> w = observation.rgb_weights.cast<T>();
  const T diffuse_albedo = w.dot(lobe.params().a_d);
  const T specular_albedo = w.dot(lobe.params().a_s);
  T radiance = T(0);
  for (const LightSample& light : observation.lights) {
    const WardTerms<T> terms = lobe.Terms(light.l_local.cast<T>(), v);
    radiance += T(light.irradiance) * (diffuse_albedo * terms.diffuse + specular_albedo * terms.specular) * terms.cos_l;
  }
  return radiance;
}

}  // namespace loom::fitting
