#pragma once
// The batched refiner's inner loop (fitting/solve/batch_refiner.h): for kLanes pixels at once, the
// GD10 model's radiance of every observation, its hand-derived gradient (the formulas of
// fitting/solve/pixel_cost.cc) and the Huber-weighted normal equations JᵀWJ, JᵀWr of the pixel's
// relative residuals — the same residuals and robust loss as the Ceres cost (pixel_fitter.h).
//
// Memory is structure-of-arrays with the lane innermost (element [i * kLanes + lane]), so that
// every loop over lanes is a vector loop (AVX2 or AVX-512, chosen at run time; exp() inlined).
// refine_kernel.cc is compiled with -ffast-math for that, which is
// why nothing here may hold NaN: a masked observation has weight 0 and radiance 0, an empty
// light slot irradiance 0.
//
// Parameters: 13 per lane in WardParams' order (n_s 3, a_d 3, a_s 3, σx, σy, α, F0). The
// Jacobian has 12 columns: n_s moves in the plane of a per-lane tangent basis (2), then a_d,
// a_s, σx, σy, α, F0.

#include <vector>

namespace loom::fitting::internal {

inline constexpr int kLanes = 8;
inline constexpr int kAmbientParams = 13;
inline constexpr int kTangentParams = 12;
inline constexpr int kNormalEntries = kTangentParams * (kTangentParams + 1) / 2;  // upper triangle
// The sums over observations (JᵀWJ and the like) run a chunk of this many observations at a time,
// while its gradients are in the L1 cache (32 × 12 × 8 doubles: 24 KiB). Summed once over all of
// a 900-observation pixel's stored gradients (0.7 MiB), they streamed from L3 and took half the
// kernel on point-lit stacks (perf).
inline constexpr int kChunkObservations = 32;
// A bound on the relative rounding error of a modelled radiance summed in float (~1e-7 for one
// unit in the last place), used as a bound on the cost's: kRadianceResolution ·
// sqrt(Σ (ψ(r) L)²), the roundings of different observations being independent. The kernel
// tests check it bounds the difference from Ceres' double-precision cost.
inline constexpr double kRadianceResolution = 1e-6;

// Upper-triangle index of (i, j), i ≤ j, row by row.
constexpr int NormalIndex(int i, int j) { return i * kTangentParams - i * (i - 1) / 2 + (j - i); }

// The observations of kLanes pixels in one layout: observation k owns light slots
// [first_slot[k], first_slot[k + 1]); a pixel fills as many of them as it has light samples.
struct LaneData {
  int observations = 0;
  std::vector<int> first_slot;  // observations + 1
  // Per observation × lane.
  std::vector<double> radiance, weight;  // weight 0: masked (the radiance is then 0)
  std::vector<double> vx, vy, vz;        // towards the camera, local frame
  std::vector<double> wr, wg, wb;        // colour weights
  // Per light slot × lane: what does not depend on the parameters. Single precision: the sums
  // over light samples run in float (refine_kernel.cc says why). The direction to the light,
  // 1 / (l·h)² and Schlick's (1 − l·h)⁵ follow from h and v (refine_kernel.cc: GeometryOf).
  std::vector<float> hx, hy, hz;  // normalize(l + v)
  std::vector<float> irradiance;  // 0: empty slot
  // The kernel's scratch: per observation of a chunk of kChunkObservations × lane, the gradient
  // (12 each) and the weights of the sums over observations. Written by EvaluateLanes (hence
  // mutable): one LaneData per thread.
  mutable std::vector<double> gradients, weights, weighted_residuals, inlier_weights, meat_weights;

  // Sizes every array for `slots_per_observation`, all lanes empty.
  explicit LaneData(const std::vector<int>& slots_per_observation);
  // Empties one lane: weight and irradiance 0 (directions stay finite: the constructor's or a
  // previous pixel's).
  void ClearLane(int lane);
  // Copies one lane's observations into lane `to_lane` of `to` (same layout).
  void CopyLane(int lane, LaneData& to, int to_lane) const;
  int slots() const { return first_slot.back(); }
};

// Per-lane inputs of one evaluation.
struct LaneInputs {
  alignas(64) double params[kAmbientParams][kLanes];
  alignas(64) double tangent[2][3][kLanes];  // orthonormal, ⟂ n_s
  alignas(64) double inverse_scale[kLanes];  // 1 / the pixel's mean observed radiance
  // Lanes with leverage 1 scale each observation's meat term by 1 / (1 − h), h = W gᵀ H⁻¹ g
  // its leverage (HC2), H⁻¹ = bread_inverse (upper triangle: the inverse of JᵀWJ); 0 leaves
  // the meat as is.
  alignas(64) double leverage[kLanes];
  alignas(64) double bread_inverse[kNormalEntries][kLanes];
  double huber_scale = 0.5;
  // false: JᵀWr and JᵀWJ are left at 0 (a batch evaluated only for its pixels' uncertainty, whose
  // steps are done, needs its bread and meat alone).
  bool normal_equations = true;
};

// Per-lane outputs: ½ Σ ρ(r²) (Ceres' cost), JᵀWr, JᵀWJ (upper triangle) for the LM steps, and
// for the uncertainty's sandwich covariance its bread Σ ψ'(r) g gᵀ (the inliers' JᵀJ: Huber's
// ψ' is 0 beyond the threshold) and its meat Σ ψ(r)² g gᵀ / (1 − h) — those two only when some
// lane has leverage set (zero otherwise).
struct LaneEquations {
  alignas(64) double cost[kLanes];
  alignas(64) double squares[kLanes];  // Σ r² (no loss): the fit's relative RMS
  // How far the cost may be from its exact value, from the single-precision sums over light
  // samples (kRadianceResolution of each modelled radiance): a smaller change is not resolved.
  alignas(64) double cost_resolution[kLanes];
  alignas(64) double jtr[kTangentParams][kLanes];
  alignas(64) double jtj[kNormalEntries][kLanes];
  alignas(64) double bread[kNormalEntries][kLanes];
  alignas(64) double meat[kNormalEntries][kLanes];
};

// Evaluates every lane (idle lanes too: their data is empty and their result ignored).
void EvaluateLanes(const LaneData& data, const LaneInputs& inputs, LaneEquations& out);

// For the grid search: per observation k and lane, the model's colour-independent sums
// diffuse[k * kLanes + lane] = Σ E (n·l) / π and specular[...] = Σ E F D (n·l) (0 where the
// camera is below the shading normal's horizon), from which the albedos follow linearly.
void SumTermsLanes(const LaneData& data, const LaneInputs& inputs, double* diffuse, double* specular);

// Which instruction set EvaluateLanes runs with on this machine ("avx512", "avx2", "baseline").
const char* RefineKernelIsa();

}  // namespace loom::fitting::internal
