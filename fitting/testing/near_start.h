#pragma once
// Test and benchmark helper: a start where a CNN might put a pixel's fit — normal ~3° off,
// albedos ±15 %, σ ±25 %, α ±10° from the truth — kept within the fit's bounds. Header-only.

#include <algorithm>
#include <random>

#include "fitting/solve/pixel_fitter.h"

namespace loom::fitting::testing {

inline WardParams<double> NearStart(const WardParams<double>& truth, std::mt19937& rng) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  WardParams<double> s = truth;
  s.n_s = (truth.n_s + 0.05 * Eigen::Vector3d(gauss(rng), gauss(rng), 0)).normalized();
  s.a_d = (truth.a_d.array() * (1 + 0.15 * gauss(rng))).matrix().cwiseMin(kMaxAlbedo);
  s.a_s = (truth.a_s.array() * (1 + 0.15 * gauss(rng))).matrix().cwiseMin(kMaxAlbedo);
  s.sigma_x = std::clamp(s.sigma_x * (1 + 0.25 * gauss(rng)), kMinSigma, kMaxSigma);
  s.sigma_y = std::clamp(s.sigma_y * (1 + 0.25 * gauss(rng)), kMinSigma, kMaxSigma);
  s.alpha += 0.17 * gauss(rng);
  return s;
}

}  // namespace loom::fitting::testing
