#pragma once
// The whole-stack fit's stages (fitting/solve/stack_fitter.h: FitStack runs them in order), each
// in its own file, and what they share: a pixel's outcome, the photometric-stereo starts, fits
// from a start. Internal to loom_fitting_solve.

#include <array>
#include <functional>
#include <optional>
#include <vector>

#include "core/image.h"
#include "core/observation_stack.h"
#include "core/status.h"
#include "fitting/model/stack_pixels.h"
#include "fitting/solve/batch_refiner.h"
#include "fitting/solve/internal/normal_frame.h"
#include "fitting/solve/lambert_fit.h"
#include "fitting/solve/pixel_fitter.h"
#include "fitting/solve/stack_fitter.h"

namespace loom::fitting::internal {

// Per pixel, its photometric-stereo normal and albedo (fitting/solve/lambert_fit.h), where the fit starts from
// them: the turn of its observations onto that normal. Empty: every pixel as the stack has it.
class NormalStarts {
 public:
  NormalStarts() = default;
  explicit NormalStarts(std::vector<std::optional<LambertPixel>> pixels) : pixels_(std::move(pixels)) {}
  std::optional<Eigen::Matrix3d> Turn(int i) const {
    if (pixels_.empty() || !pixels_[i]) return std::nullopt;
    return internal::TurnOntoZ(pixels_[i]->normal);
  }
  const std::optional<LambertPixel>& Pixel(int i) const { return pixels_[i]; }
  bool empty() const { return pixels_.empty(); }

 private:
  std::vector<std::optional<LambertPixel>> pixels_;
};

// One pixel's fit; `fitted` false (and the start kept) when it has too few usable observations.
struct PixelOutcome {
  WardParams<double> params;
  double cost = 0;  // the fit's (robust) cost
  double rms = 0;   // RelativeRms
  int iterations = 0;
  int observations = 0;
  bool fitted = false;
  std::optional<ParamSigma> sigma;  // the refiner's
};

// The material's F0 (fixed_f0 unset), as Pantora has one: a sparse grid of pixels fitted at F0
// 1 from their starts with the method's own solver, then fitted again together with one F0 that
// they share (FitPixelsSharingF0), from each of kF0Starts. Fitting F0 per pixel or per k-means
// cluster and taking the median scattered it (tac7's noise-free fabric 1985, F0 0.26: the
// clusters' median made the fit 10× worse than F0 held at 1), and so did a search over F0 that
// refitted the pixels independently at each value tried: each value's fits fell into other
// basins.
struct MaterialF0 {
  double f0 = 1;
  double cost = 0;
  std::vector<std::array<double, 4>> fits;  // per start: F0 started from, F0 reached, cost, iterations
};

// What the stages share (stack_stages.cc).
WardParams<double> NeutralStart();  // a pixel without a cluster, never fitted: a finite start
WardParams<double> NanParams();     // a pixel not fitted, in every parameter
double HalfVectorSpacing(const StackPixels& pixels);
// Where a retry's grid search looks (GridStartsAround): around the pixel's photometric-stereo
// normal (`turn` takes it onto z) where it has one, and on dense stacks around the stack's own
// normal as well.
struct GridFrames {
  std::optional<Eigen::Matrix3d> turn;
  bool also_stack_normal = false;
};
std::vector<WardParams<double>> GridStartsAround(
    const GridFrames& frames, const std::vector<PixelObservation>& observations,
    const std::function<std::vector<WardParams<double>>(const std::vector<PixelObservation>&)>& search);
double RelativeRms(const WardParams<double>& params, const std::vector<PixelObservation>& observations);
Result<PixelFitResult> FitFromStarts(const std::vector<PixelObservation>& observations,
                                     const std::vector<WardParams<double>>& starts, const PixelFitOptions& options);
PixelOutcome FitFromStart(const std::vector<PixelObservation>& observations, const WardParams<double>& start,
                          const PixelFitOptions& fit);
std::vector<int> EmittersPerObservation(const ObservationStack& stack);
RefineOptions RefinerOptions(const PixelFitOptions& fit, const StackFitOptions& options);
PixelOutcome OutcomeOf(const RefinedPixel& r);
std::vector<int> SparseGrid(int width, int height, int count);
Image MapsOf(const std::vector<PixelOutcome>& outcomes, const PixelClusters& clusters, const ObservationStack& stack);
void Summarise(const std::vector<PixelOutcome>& outcomes, StackFitSummary& summary);

// Steps 1–3: every cluster's fit (stack_clusters.cc).
Status FitClusters(const StackPixels& pixels, const PixelClusters& clusters, const StackFitOptions& options,
                   const NormalStarts& normals, const std::function<void(int)>& progress, StackFitSummary& summary);

// The material's F0 (stack_f0.cc).
WardParams<double> AtF0(WardParams<double> p, double f0);
Result<MaterialF0> SearchF0(const StackPixels& pixels, const ObservationStack& stack,
                            const std::function<WardParams<double>(int, double)>& start_at, const StackFitOptions& options);

// The stack's noise level (stack_noise.cc).
double RetryThreshold(const std::vector<PixelOutcome>& outcomes, const StackFitOptions& options);
Result<std::optional<double>> ProbeNoiseRms(const StackPixels& pixels, const ObservationStack& stack,
                                            const std::function<WardParams<double>(int)>& start_of, RefineOptions refine);

// Step 4 on the refiner (stack_first_fits.cc).
Result<std::vector<PixelOutcome>> RefineAll(const StackPixels& pixels, const ObservationStack& stack,
                                            const std::function<WardParams<double>(int)>& start_of, const RefineOptions& refine,
                                            const std::function<void(int)>& progress, int& nodes_replaced);

// Step 5 (stack_retries.cc).
bool WorseThanLambertian(const PixelOutcome& outcome, const NormalStarts& normals, int i);
PixelOutcome RetryFromGrid(const std::vector<PixelObservation>& observations, const PixelOutcome& first,
                           const PixelFitOptions& fit, const StackFitOptions& options, const GridFrames& frames,
                           const std::optional<LambertPixel>& lambertian);
Result<std::vector<int>> PropagateFromNeighbours(const StackPixels& pixels, const ObservationStack& stack, std::vector<int> retry,
                                                 const RefineOptions& refine, const StackFitOptions& options, double threshold,
                                                 const std::function<WardParams<double>(int)>& start_of,
                                                 std::vector<PixelOutcome>& outcomes, int& propagated);
Result<int> RefineRetries(const StackPixels& pixels, const ObservationStack& stack, const std::vector<int>& retry,
                          const RefineOptions& refine, const StackFitOptions& options, double threshold,
                          const std::function<WardParams<double>(int)>& start_of, const NormalStarts& normals, bool dense,
                          const std::function<void(int)>& progress, std::vector<PixelOutcome>& outcomes);

// The smoothing pass (stack_smoothing.cc).
double SmoothingWeightAt(double weight, double variance_ratio);
Status SmoothingPass(const StackPixels& pixels, const ObservationStack& stack, RefineOptions refine, const RefinePrior& smoothing,
                     const Image* guide, const std::function<void(int)>& progress, std::vector<PixelOutcome>& outcomes);

// Unseen peaks (stack_held_normals.cc).
int HoldNormalsOfUnseenPeaks(const StackPixels& pixels, const NormalStarts& normals, PixelFitOptions fit,
                             const StackFitOptions& options, std::vector<PixelOutcome>& outcomes);

}  // namespace loom::fitting::internal
