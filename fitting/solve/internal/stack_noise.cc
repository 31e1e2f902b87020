// The stack's noise level: what the retries' threshold and the prior's weight are set by.
#include "fitting/solve/internal/stack_stages.h"

#include <algorithm>

namespace loom::fitting::internal {

namespace {

// A fit is poor when its residual is well above the stack's noise level, which the best-fitted
// tenth of the pixels shows (the median does not: from poor starts half the pixels may miss).
// Noise-free stacks fit to < 1 % there and the floor decides; a reconstructed stack's camera
// noise and pixel integration leave ~12 %.
// The stack's noise level: the relative RMS that a tenth of the fitted pixels are at or below.
// None without fitted pixels.
std::optional<double> NoiseRms(std::vector<double> rms) {
  if (rms.empty()) return std::nullopt;
  const auto tenth = rms.begin() + static_cast<std::ptrdiff_t>(rms.size() / 10);
  std::nth_element(rms.begin(), tenth, rms.end());
  return *tenth;
}

}  // namespace

double RetryThreshold(const std::vector<PixelOutcome>& outcomes, const StackFitOptions& options) {
  std::vector<double> rms;
  for (const PixelOutcome& o : outcomes) {
    if (o.fitted) rms.push_back(o.rms);
  }
  const std::optional<double> noise = NoiseRms(std::move(rms));
  return noise ? std::max(options.retry_above_rms, options.retry_above_noise_rms * *noise) : options.retry_above_rms;
}

// pixels refined from their starts without the prior: a biased fit would overstate it (on a
// noise-free tac7 stack the prior's pull alone left a third of the pixels above 0.1). None
// where no probed pixel has enough usable observations.
Result<std::optional<double>> ProbeNoiseRms(const StackPixels& pixels, const ObservationStack& stack,
                                            const std::function<WardParams<double>(int)>& start_of, RefineOptions refine) {
  constexpr int kProbePixels = 1024;
  const int width = pixels.width();
  const std::vector<int> probe = SparseGrid(width, pixels.height(), kProbePixels);
  refine.prior.weight = 0;
  refine.uncertainty = false;
  const RefineProblem problem{.pixels = static_cast<int>(probe.size()),
                              .lights_per_observation = EmittersPerObservation(stack),
                              .observations =
                                  [&](int k, std::vector<PixelObservation>& into) {
                                    pixels.ObservationsInto(probe[k] % width, probe[k] / width, nullptr, into);
                                  },
                              .start = [&](int k) { return start_of(probe[k]); },
                              .prior_mean = {}};
  LOOM_ASSIGN_OR_RETURN(const std::vector<RefinedPixel> refined, RefinePixels(problem, refine));
  std::vector<double> rms;
  for (const RefinedPixel& r : refined) {
    if (r.fitted) rms.push_back(r.rms);
  }
  return NoiseRms(std::move(rms));
}

}  // namespace loom::fitting::internal
