#pragma once
// The per-pixel cost of pixel_fitter.cc, exposed for ceres::GradientChecker in tests.
#include <ceres/dynamic_autodiff_cost_function.h>

#include "fitting/pixel_fitter.h"

namespace loom::fitting::internal {

constexpr int kStride = 4;  // Jet derivatives per pass; 4 keeps the Jets in registers

// Block order: n_s (3), a_d (3), a_s (3), σ (2), α (1), F0 (1).
struct PixelResidual {
  const std::vector<PixelObservation>* observations;
  double inverse_scale;

  template <typename T>
  bool operator()(T const* const* blocks, T* residuals) const {
    WardParams<T> params;
    params.n_s = Vec3<T>(blocks[0][0], blocks[0][1], blocks[0][2]);
    params.a_d = Vec3<T>(blocks[1][0], blocks[1][1], blocks[1][2]);
    params.a_s = Vec3<T>(blocks[2][0], blocks[2][1], blocks[2][2]);
    params.sigma_x = blocks[3][0];
    params.sigma_y = blocks[3][1];
    params.alpha = blocks[4][0];
    params.f0 = blocks[5][0];
    const WardLobe<T> lobe(params);
    for (size_t k = 0; k < observations->size(); ++k) {
      const PixelObservation& o = (*observations)[k];
      residuals[k] = (PredictRadiance(lobe, o) - T(o.radiance)) * T(inverse_scale);
    }
    return true;
  }
};

// Parameter blocks n_s (3), a_d (3), a_s (3), σ (2), α (1), F0 (1); one residual per
// observation. `observations` must outlive the cost function.
inline ceres::CostFunction* MakePixelCost(const std::vector<PixelObservation>& observations, double inverse_scale) {
  auto* cost = new ceres::DynamicAutoDiffCostFunction<PixelResidual, kStride>(new PixelResidual{&observations, inverse_scale});
  for (int size : {3, 3, 3, 2, 1, 1}) cost->AddParameterBlock(size);
  cost->SetNumResiduals(static_cast<int>(observations.size()));
  return cost;
}

}  // namespace loom::fitting::internal
