// The refiner's smoothing pass toward each pixel's neighbours' median lobe.
#include "fitting/solve/internal/stack_stages.h"

#include <algorithm>
#include <cmath>

#include "core/parallel.h"
#include "fitting/solve/internal/neighbour_lobes.h"

namespace loom::fitting::internal {

namespace {

// `p` as the same lobe written the way `like` is: σx and σy in the same order (swapping them turns
// α by 90°). Without this the prior would pull a pixel with σx < σy toward its neighbours' σx > σy
// across the whole parameter space (it did: the σ map came out 14× noisier).
WardParams<double> InTheConventionOf(WardParams<double> p, const WardParams<double>& like) {
  if ((p.sigma_x < p.sigma_y) != (like.sigma_x < like.sigma_y)) {
    std::swap(p.sigma_x, p.sigma_y);
    p.alpha += kPi / 2;
  }
  return p;
}

// What the smoothing pass pulls a pixel toward, and starts it from: its neighbourhood's median
// lobe (NeighbourLobes: a_s, σ, α, F0) with the pixel's own normal and diffuse albedo. Those two are what every
// observation pins down, and they carry the material's real texture (yarn colours, the weave's
// slopes): on the training fabric (docs/benchmarks.md) pulling them toward the median too gave
// a_d NRMSE 0.140 and n_s 0.081 against 0.088 and 0.045, and leaving them free let a_d take up
// what the smoothed lobe no longer explained. Starting from the median rather than the first fit
// lets a speckled pixel leave the basin its noise put it in (σ map noise 1.7× → 1.2× the truth's).
WardParams<double> SmoothingTarget(const WardParams<double>& lobe, const WardParams<double>& own) {
  WardParams<double> target = InTheConventionOf(lobe, own);
  target.n_s = own.n_s;
  target.a_d = own.a_d;
  return target;
}

// The 1σ of a smoothed pixel: the data's (the free fit's) and the smoothing's shift from the free
// fit, added in quadrature. The smoothing prior's own curvature would count the neighbours' noisy
// fits as knowledge (the main job's stated 1σ of a_s·F0 covered 4 % of the true errors with it);
// the data's alone leave out the bias the shift may add (on a noisy simulated stack σx and the
// normal covered 49–57 %; with the shift 64–76 %, and a_s, whose shift is mostly a correction,
// 83–91 %: conservative). StackFitterTest's coverage test holds it.
ParamSigma WithTheShift(ParamSigma s, const WardParams<double>& free, const WardParams<double>& smoothed) {
  const double turn = std::acos(std::clamp(free.n_s.normalized().dot(smoothed.n_s.normalized()), -1.0, 1.0));
  s.normal_deg = std::hypot(s.normal_deg, RadToDeg(turn));
  for (int c = 0; c < 3; ++c) {
    s.a_d[c] = std::hypot(s.a_d[c], free.a_d[c] - smoothed.a_d[c]);
    s.a_s[c] = std::hypot(s.a_s[c], free.a_s[c] - smoothed.a_s[c]);
  }
  s.sigma_x = std::hypot(s.sigma_x, free.sigma_x - smoothed.sigma_x);
  s.sigma_y = std::hypot(s.sigma_y, free.sigma_y - smoothed.sigma_y);
  s.alpha_deg = std::hypot(s.alpha_deg, RadToDeg(AngleBetweenLobes(free.alpha, smoothed.alpha)));
  return s;
}

}  // namespace

// The smoothing prior's weight on a stack whose noise variance is `variance_ratio` times the one
// the weight was picked at: scaled as the CNN prior's is (StackFitOptions::
// prior_reference_noise_rms). Below a hundredth of it the pass would move a pixel by under a
// hundredth of what it moves one at the picked noise, so it is not run (0): a noise-free stack,
// whose data are exact, costs no second pass.
double SmoothingWeightAt(double weight, double variance_ratio) { return variance_ratio >= 0.01 ? weight * variance_ratio : 0; }

// The smoothing pass: every fitted pixel again, from and toward SmoothingTarget; the pixel
// keeps what its data say where they say it. `guide` (the CNN's maps, or nullptr) tells the
// neighbours on the pixel's yarn from the others for the target's α (internal/neighbour_lobes.h).
Status SmoothingPass(const StackPixels& pixels, const ObservationStack& stack, RefineOptions refine, const RefinePrior& smoothing,
                     const Image* guide, const std::function<void(int)>& progress, std::vector<PixelOutcome>& outcomes) {
  const int width = pixels.width();
  std::vector<WardParams<double>> fits(outcomes.size());
  for (size_t i = 0; i < outcomes.size(); ++i) fits[i] = outcomes[i].fitted ? outcomes[i].params : NanParams();
  const std::vector<WardParams<double>> lobes = internal::NeighbourLobes(fits, width, pixels.height(), guide);
  std::vector<WardParams<double>> targets(outcomes.size());
  for (size_t i = 0; i < outcomes.size(); ++i) targets[i] = SmoothingTarget(lobes[i], outcomes[i].params);
  refine.prior = smoothing;
  refine.uncertainty = false;  // each pixel states the free fit's, widened by its shift (below)
  const RefineProblem problem{
      static_cast<int>(outcomes.size()), EmittersPerObservation(stack),
      [&](int i, std::vector<PixelObservation>& into) { pixels.ObservationsInto(i % width, i / width, nullptr, into); },
      [&](int i) { return targets[i]; }, [&](int i) { return targets[i]; }};
  LOOM_ASSIGN_OR_RETURN(const std::vector<RefinedPixel> refined, RefinePixels(problem, refine, progress));
  ParallelFor(static_cast<int>(outcomes.size()), refine.threads, [&](int i) {
    if (!outcomes[i].fitted || !refined[i].fitted) return;
    const int iterations = outcomes[i].iterations + refined[i].iterations;
    const std::optional<ParamSigma> data_sigma = outcomes[i].sigma;
    const WardParams<double> free = outcomes[i].params;
    outcomes[i] = OutcomeOf(refined[i]);
    outcomes[i].sigma = data_sigma ? std::optional(WithTheShift(*data_sigma, free, outcomes[i].params)) : std::nullopt;
    outcomes[i].iterations = iterations;
  });
  return {};
}

}  // namespace loom::fitting::internal
