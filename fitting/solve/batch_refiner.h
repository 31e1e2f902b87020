#pragma once
// The batched refiner: Levenberg–Marquardt over many pixels at once, the fast replacement for
// one Ceres solve per pixel (pixel_fitter.h stays the reference).
//
// It minimises the same cost as FitPixel: ½ Σ ρ(r²) over a pixel's usable observations, r the
// predicted minus the observed radiance relative to the pixel's mean, ρ Huber's loss;
// a_d, a_s ∈ [0, kMaxAlbedo], σ ∈ [kMinSigma, kMaxSigma], F0 ∈ [0, 1] or held fixed, n_s on the
// unit sphere, α free (wrapped to (−π/2, π/2] after). Observations with NaN radiance or no
// light are skipped, and a pixel with fewer than 13 usable ones keeps its start (`fitted` false).
//
// How: the model and its hand-derived Jacobian are evaluated for 8 pixels per call
// (internal/refine_kernel.h: structure-of-arrays, vectorised across pixels); each pixel then takes
// its own LM step — a 12 × 12 normal-equation solve with Ceres' trust-region rules for damping
// (but for a shorter retreat after a rejected step and faster growth after a well-predicted one:
// batch_refiner.cc says why), its own convergence test (Ceres' function, gradient and parameter
// tolerances), and bounds held by an active set (a parameter at a bound that the gradient pushes
// out is frozen for the step) plus projection. A pixel that finishes hands its lane to the next
// one.
//
// Optionally the objective adds a Gaussian prior toward the start (the CNN's prediction) or
// another estimate (RefineProblem::prior_mean: e.g. the neighbours' parameters):
// ½ Σ_i ((x_i − start_i) / (prior_sigma_i · √(1/prior_weight)))², a MAP fit rather than a free
// one; see RefinePrior.
//
// Uncertainty: at the solution, the sandwich covariance H⁻¹ (Σ ψ(r)² g gᵀ / (1 − h)) H⁻¹ ·
// m/(m − p), H = Σ ψ'(r) g gᵀ (+ the prior), h each observation's leverage (HC2), which holds
// when the noise differs between observations (a scan's does: highlights are noisier) and when
// few observations fix a parameter (a highlight's do the normal and σ); its 1σ per parameter
// goes into RefinedPixel::sigma.
// Thread-safety: RefinePixels runs its own workers; `observations` and `start` are called from
// them concurrently and must be safe for that.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/status.h"
#include "fitting/model/strip_quadrature.h"  // MergeLightSamples
#include "fitting/solve/pixel_fitter.h"

namespace loom::fitting {

// A Gaussian prior toward each pixel's start, in the parameters' own units: the 1σ of the start
// as an estimate of the truth (for a CNN: its measured error). weight 0 turns it off; weight w
// scales every term by w (as if the σ's were divided by √w).
// The defaults are the shipped tac7-mini CNN's errors (its test RMSE, configs/models/tac7-mini),
// but for a_d: on reconstructed stacks the network's diffuse albedo is off by more than its test
// error says (NRMSE 0.10 against 0.06), while every observation pins a_d down, so its prior is
// loose.
struct RefinePrior {
  double weight = 0;
  double normal_deg = 6;
  double diffuse_albedo = 0.3;    // a_d, each channel
  double specular_albedo = 0.09;  // a_s, each channel
  double sigma = 0.05;            // σx, σy
  double alpha_deg = 30;
};

struct RefineOptions {
  int max_iterations = 30;            // LM steps (accepted or not) per pixel
  double huber_scale = 0.5;           // as PixelFitOptions::huber_scale
  std::optional<double> fixed_f0;     // F0 held at this value instead of fitted
  double function_tolerance = 1e-6;   // |Δcost| / cost of an accepted step; Ceres' default
  double gradient_tolerance = 1e-10;  // max-norm of the projected gradient; Ceres' default
  double parameter_tolerance = 1e-8;  // |step| / (|x| + tol); Ceres' default
  RefinePrior prior;
  double min_sigma = kMinSigma;  // the narrowest lobe (PixelFitOptions::min_sigma)
  // Light samples an observation is evaluated with, at most (0: all): a linear light's emitters
  // beyond this are merged along the strip (MergeLightSamples). The cost of a fit is about
  // proportional to the samples; docs/benchmarks.md has what each count costs in accuracy.
  int max_lights_per_observation = 0;
  // Coarse to fine: with a count > 0, each pixel first converges with every observation's light
  // samples merged into at most this many, then finishes from there with all of them (or
  // max_lights_per_observation). The answer is the full model's minimum, as the finishing pass
  // decides convergence; only the way there is cheaper (docs/benchmarks.md). 0: one pass.
  int coarse_lights_per_observation = 0;
  // The 1σ of each refined pixel (RefinedPixel::sigma): one more evaluation per pixel, and a copy
  // of its data. Off, sigma stays zero.
  bool uncertainty = true;
  int threads = 0;       // 0: one per core
  Status Check() const;  // every problem, naming the field
};

// 1σ of a refined pixel's parameters (NaN where the data and prior leave one undetermined).
struct ParamSigma {
  double normal_deg = 0;  // of the angle between the fitted and the true normal
  Eigen::Vector3d a_d = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_s = Eigen::Vector3d::Zero();
  double sigma_x = 0, sigma_y = 0;
  double alpha_deg = 0;
};

struct RefinedPixel {
  WardParams<double> params;
  double cost = 0;  // ½ Σ ρ(r²) of the data, as Ceres' final cost (the prior not included)
  double rms = 0;   // √(Σ r² / m): the RMS residual relative to the pixel's mean radiance
  int observations_used = 0;
  int iterations = 0;
  bool fitted = false;  // false: too few usable observations; params = start
  bool converged = false;
  ParamSigma sigma;
};

// The pixels to refine. `observations(i, into)` writes pixel i's observations into `into`,
// replacing what it holds (a previous pixel's: its memory may be reused, as
// StackPixels::ObservationsInto or a copy assignment do); an observation's slot in the batch
// layout is its `source` (≥ 0, as StackPixels sets it) or else its position in the list.
// `lights_per_observation[slot]` bounds the light samples any pixel has there.
struct RefineProblem {
  int pixels = 0;
  std::vector<int> lights_per_observation;
  std::function<void(int pixel, std::vector<PixelObservation>& into)> observations;
  std::function<WardParams<double>(int pixel)> start;
  // Where RefineOptions::prior pulls pixel i (empty: its start).
  std::function<WardParams<double>(int pixel)> prior_mean;
};

// GridInitialParams (pixel_fitter.h) on the refiner's kernel: the same candidates, each scored
// with its least-squares albedos, 8 per vectorised call; a strip's emitters merged into at most
// `max_lights` samples (0: all; the scalar search takes every 4th). For the refiner's retries.
// normals_kept > 0: coarse to fine, the normals ranked by their best isotropic lobe and every
// lobe shape tried at the best `normals_kept` of them only.
std::vector<WardParams<double>> GridStarts(const std::vector<PixelObservation>& observations, double f0, int count,
                                           int max_lights = 8, int normals_kept = 0);

// lights_per_observation for pixels given as lists (tests, benchmarks): per slot, the most any
// of them has.
std::vector<int> LightsPerObservation(const std::vector<std::vector<PixelObservation>>& pixels);

// Refines every pixel; `progress(done)` is called on the calling thread now and then. A pixel's
// `iterations` count both passes of a coarse-to-fine refinement.
Result<std::vector<RefinedPixel>> RefinePixels(const RefineProblem& problem, const RefineOptions& options,
                                               const std::function<void(int done)>& progress = {});

// The instruction set the refiner's kernel runs with here (e.g. "x86-64-v3 (AVX2, FMA)").
std::string RefinerInstructionSet();

}  // namespace loom::fitting
