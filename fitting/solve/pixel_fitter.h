#pragma once
// The per-pixel Ceres fitter: one pixel's observations → its 13 GD10 Ward parameters.
//
// An observation is a radiance with the geometry that made it, in the pixel's local geometric
// frame (x tangent, y bitangent, z geometric normal): the view direction, the colour weights
// the camera records of RGB albedo (panchromatic or through a filter), and one or more light
// samples (one for an LED, several for a segment of the linear light), each a direction and the
// irradiance it brings (I / d², the cosine left to the model):
//
//   L = Σ_j E_j · (w·a_d / π + w·a_s · F(l_j·h) D(h)) · (n_s·l_j)
//
// Parameter blocks: n_s (unit, on ceres::SphereManifold<3>), a_d and a_s in [0, kMaxAlbedo]
// (unbounded above, a tiny σ lets a_s run off to thousands on a pixel whose highlight falls
// between the observations), (σx, σy) in
// [kMinSigma, kMaxSigma], α (free; wrapped to (−π/2, π/2] after), F0 ∈ [0, 1]. Residuals are
// radiances relative to the pixel's mean observed radiance, each under a Huber loss, so a shadowed or
// mis-registered observation cannot drag the fit (internal/pixel_cost.h: MakeRobustPixelCost). Observations with NaN radiance are
// skipped. Derivatives: hand-derived (fitting/solve/pixel_cost.cc), one residual block per pixel (the formulation measured
// fastest); checked by ceres::GradientChecker and against ceres::Jet in tests. Reentrant: fit different pixels on different
// threads.

#include <optional>
#include <vector>

#include "core/status.h"
#include "fitting/model/observation.h"
#include "fitting/model/ward_gd10.h"

namespace loom::fitting {

inline constexpr double kMaxAlbedo = 1.0;
// The least F0 a shared fit reaches: water's 0.02, the lowest of real dielectrics (the simulator
// draws F0 from [0.02, 1]).
inline constexpr double kMinSharedF0 = 0.02;

struct PixelFitOptions {
  int max_iterations = 50;   // per start
  double huber_scale = 0.5;  // of the residual, in units of the pixel's mean radiance
  bool multi_start = true;   // also start from 3 more anisotropy angles (α local minima)
  // F0 held at this value instead of fitted. Away from grazing angles the observations fix
  // only a_s · F(l·h) ≈ a_s · F0, so Pantora fits one F0 per material; so can we.
  std::optional<double> fixed_f0;
  // The start's shading normal held, the rest fitted: where the observations do not see the
  // lobe's peak, the normal is the diffuse term's to say (stack_fitter.cc).
  bool hold_normal = false;
  // ceres::Jet derivatives instead of the hand-derived ones: same fit, slower; the baseline
  // bench/fit_bench.cc measures the analytic Jacobians against.
  bool automatic_derivatives = false;
  // The narrowest lobe a fit may reach, in [kMinSigma, kMaxSigma): stack_fitter.h raises it where
  // the observations sample the half-vectors too coarsely to resolve a narrower one. A start
  // below it starts at it.
  double min_sigma = kMinSigma;
  // Check(): every problem, each naming the field.
  Status Check() const;
};

struct PixelFitResult {
  WardParams<double> params;
  double cost = 0;  // Ceres' final cost (½ Σ ρ(r²)) of the best start
  int observations_used = 0;
  int iterations = 0;  // over all starts
  bool converged = false;
};

// Every parameter finite: what a fit may start from. Ceres aborts the process (a CHECK) on a
// start it cannot move from, so the fitters refuse or skip any other start before Ceres sees it.
bool AllFinite(const WardParams<double>& params);

// Fits from `initial` (and, with multi_start, from α + 45°, 90°, 135°; α + 90° is the start
// with σx and σy swapped): the start with the lowest cost wins. Fewer than 13 usable observations,
// or a start with a non-finite parameter, is an error.
Result<PixelFitResult> FitPixel(const std::vector<PixelObservation>& observations, const WardParams<double>& initial,
                                const PixelFitOptions& options = {});

// Several pixels fitted at once with one F0 that all of them share (Pantora's one F0 per
// material), each from its start (its a_s·F0 kept) and F0 from f0_start: one Ceres problem
// (sparse normal equations). A pixel with fewer than 13 usable observations is left out (its entry empty);
// none with enough is an error. The result's per-pixel costs are 0: `cost` is the whole
// problem's, solved on one thread (Ceres' multi-threaded sums depend on scheduling, so F0 would
// differ in its last bits between runs); options.fixed_f0 is not used. Each pixel's
// specular is fitted as b = a_s·F0 (internal/pixel_cost.h) with b ≤ kMaxAlbedo, so a result's
// a_s may exceed kMaxAlbedo where F0 < 1; F0 ∈ [kMinSharedF0, 1].
struct SharedF0Fit {
  double f0 = 1;
  double cost = 0;  // ½ Σ ρ(r²) over every pixel
  int iterations = 0;
  std::vector<std::optional<PixelFitResult>> pixels;
};
Result<SharedF0Fit> FitPixelsSharingF0(const std::vector<std::vector<PixelObservation>>& pixels,
                                       const std::vector<WardParams<double>>& starts, double f0_start,
                                       const PixelFitOptions& options);

// A neutral start from the observations alone: n_s = z, a_d from the mean radiance as if
// Lambertian, a small grey a_s, σ = 0.2, α = 0, F0 = 1.
WardParams<double> GenericInitialParams(const std::vector<PixelObservation>& observations);

// Starts chosen by search, the `count` best first: 13 normals (up to 20° tilt) × 28 lobe shapes (σ from 0.03 to 0.3,
// isotropic and anisotropic at 4 angles), each scored with its least-squares non-negative
// albedos (the model is linear in them), F0 = `f0`. About 360 shapes; for pixels and clusters
// where a neighbour's parameters are no start: a narrow highlight far from the start's lobe
// gives no gradient, and the fit falls into a_s = 0 (grid_start.cc).
std::vector<WardParams<double>> GridInitialParams(const std::vector<PixelObservation>& observations, double f0, int count);

}  // namespace loom::fitting
