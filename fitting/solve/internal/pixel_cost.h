#pragma once
// The per-pixel cost of pixel_fitter.cc, exposed for ceres::GradientChecker in tests and for
// bench/fit_bench.cc. Two implementations of the same residuals:
//  - analytic: hand-derived Jacobians of the GD10 lobe (pixel_cost.cc) — what the fitter uses;
//  - autodiff: ceres::Jet through WardLobe — the reference the analytic one is tested against,
//    and the baseline the bench measures it against.
// Block order: n_s (3, ambient: the fitter puts it on a SphereManifold), a_d (3), a_s (3),
// σ (2), α (1), F0 (1); one residual per observation: (predicted − measured) · inverse_scale.
// None may have NaN radiance. The autodiff cost keeps a pointer: `observations` must outlive it.
#include <ceres/cost_function.h>
#include <ceres/dynamic_autodiff_cost_function.h>

#include "fitting/solve/pixel_fitter.h"

namespace loom::fitting::internal {

inline constexpr int kParameterBlockSizes[] = {3, 3, 3, 2, 1, 1};

ceres::CostFunction* MakeAnalyticPixelCost(const std::vector<PixelObservation>& observations, double inverse_scale);

// Huber's loss on each residual of `inner` (owned), inside the cost: r̃ = r where |r| ≤ a, else
// sign(r) √(2a|r| − a²), so that ½ Σ r̃² = ½ Σ ρ(r²) with ρ ceres::HuberLoss(a). A ceres::LossFunction
// cannot do this here: it robustifies a residual block's whole squared norm, and the fitter puts
// all of a pixel's observations in one block (one outlier would then reweight them all, and a
// pixel whose total exceeds a² is fitted by plain least squares).
ceres::CostFunction* MakeRobustPixelCost(ceres::CostFunction* inner, double huber_scale);

// `inner` (owned) over b = a_s·F0 in a_s's block, the specular reflectance at normal incidence:
// (n_s, a_d, b, σ, α, F0), F0 > 0. Where pixels share one F0 (FitPixelsSharingF0), a step in F0
// with a_s held moves every pixel's whole highlight; with b held it moves only what grazing light
// sees (the Schlick term), which is what F0 is fitted from (docs/benchmarks.md, "One F0 per
// material": the best start's cost the same or lower, far starts ending near it where they had
// stopped at up to 550,000× it, in 0.3–1.2× the time).
ceres::CostFunction* MakeSpecularAtNormalIncidenceCost(ceres::CostFunction* inner);

constexpr int kStride = 4;  // Jet derivatives per pass; 4 keeps the Jets in registers

struct AutodiffPixelResidual {
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

inline ceres::CostFunction* MakeAutodiffPixelCost(const std::vector<PixelObservation>& observations, double inverse_scale) {
  auto* cost = new ceres::DynamicAutoDiffCostFunction<AutodiffPixelResidual, kStride>(
      new AutodiffPixelResidual{&observations, inverse_scale});
  for (int size : kParameterBlockSizes) cost->AddParameterBlock(size);
  cost->SetNumResiduals(static_cast<int>(observations.size()));
  return cost;
}

}  // namespace loom::fitting::internal
