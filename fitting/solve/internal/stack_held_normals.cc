// Pixels whose lobe peaks where no observation sees it, on photometric stereo's normal.
#include "fitting/solve/internal/stack_stages.h"

#include <atomic>

#include "core/parallel.h"
#include "fitting/solve/internal/peak_coverage.h"

namespace loom::fitting::internal {

// Every fitted pixel whose lobe peaks where no observation sees it, refitted on its
// photometric-stereo normal, held (StackFitOptions::hold_normals_of_unseen_peaks). Returns how many
// keep the held fit.
int HoldNormalsOfUnseenPeaks(const StackPixels& pixels, const NormalStarts& normals, PixelFitOptions fit,
                             const StackFitOptions& options, std::vector<PixelOutcome>& outcomes) {
  if (normals.empty() || !options.hold_normals_of_unseen_peaks) return 0;
  fit.hold_normal = true;
  std::atomic<int> held = 0;
  ParallelFor(static_cast<int>(outcomes.size()), options.threads, [&](int i) {
    const std::optional<LambertPixel>& lambertian = normals.Pixel(i);
    if (!outcomes[i].fitted || !lambertian) return;
    const std::vector<PixelObservation> observations = pixels.Observations(i % pixels.width(), i / pixels.width());
    if (internal::PeakCoverage(lambertian->normal, observations) >= 0 &&
        internal::PeakCoverage(outcomes[i].params.n_s, observations) >= 0) {
      return;
    }
    WardParams<double> start = outcomes[i].params;
    start.n_s = lambertian->normal;
    PixelOutcome refit = FitFromStart(observations, start, fit);
    if (!refit.fitted || refit.rms > outcomes[i].rms * options.held_normal_max_rms_ratio) return;
    refit.iterations += outcomes[i].iterations;
    // The refiner's uncertainty stays the free fit's: the data fix the held normal no better
    // than they fixed the free one, and the other parameters about as well.
    refit.sigma = outcomes[i].sigma;
    outcomes[i] = refit;
    ++held;
  });
  return held;
}

}  // namespace loom::fitting::internal
