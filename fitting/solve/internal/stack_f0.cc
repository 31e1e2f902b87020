// The material's F0, fitted on a sparse grid of pixels that share it.
#include "fitting/solve/internal/stack_stages.h"

#include <array>
#include <cmath>
#include <limits>
#include <numeric>

#include "core/parallel.h"

namespace loom::fitting::internal {

namespace {

// Pixels that SearchF0 fits with one shared F0: on a 630² material about 1/3,000 of them.
constexpr int kF0ProbePixels = 128;
// F0s that SearchF0's joint fit starts from; the lowest cost wins. The fit moves F0 smoothly,
// but across a material's pixels the cost of F0 can have more than one dip.
constexpr std::array<double, 3> kF0Starts = {1.0, 0.3, 0.08};
// The share of them, the best fitted at F0 1, that the joint fit takes.
constexpr double kF0BestFittedShare = 0.5;

// Each pixel fitted at F0 1 from start(k) with the method's own solver: its fit and its cost
// (the highest double where it could not be fitted).
Result<std::pair<std::vector<WardParams<double>>, std::vector<double>>> FitAtF0One(
    const std::vector<std::vector<PixelObservation>>& observations, const ObservationStack& stack,
    const std::function<WardParams<double>(int)>& start, const StackFitOptions& options) {
  const int count = static_cast<int>(observations.size());
  PixelFitOptions at_one = options.pixel_fit;
  at_one.fixed_f0 = 1.0;
  std::vector<WardParams<double>> fitted(count);
  std::vector<double> costs(count, std::numeric_limits<double>::max());
  if (options.solver == PixelSolver::kBatchRefiner) {
    RefineOptions refine = RefinerOptions(at_one, options);
    refine.uncertainty = false;
    const RefineProblem problem{.pixels = count,
                                .lights_per_observation = EmittersPerObservation(stack),
                                .observations = [&](int k, std::vector<PixelObservation>& into) { into = observations[k]; },
                                .start = start,
                                .prior_mean = {}};
    LOOM_ASSIGN_OR_RETURN(const std::vector<RefinedPixel> refined, RefinePixels(problem, refine));
    for (int k = 0; k < count; ++k) {
      fitted[k] = refined[k].params;
      if (refined[k].fitted) costs[k] = refined[k].cost;
    }
  } else {
    ParallelFor(count, options.threads, [&](int k) {
      const PixelOutcome outcome = FitFromStart(observations[k], start(k), at_one);
      fitted[k] = outcome.params;
      if (outcome.fitted) costs[k] = outcome.cost;
    });
  }
  return std::pair{std::move(fitted), std::move(costs)};
}

}  // namespace

// `p` at another F0, a_s·F0 kept (within the albedo's bound).
WardParams<double> AtF0(WardParams<double> p, double f0) {
  p.a_s = (p.a_s * (p.f0 / f0)).cwiseMin(kMaxAlbedo);
  p.f0 = f0;
  return p;
}

Result<MaterialF0> SearchF0(const StackPixels& pixels, const ObservationStack& stack,
                            const std::function<WardParams<double>(int, double)>& start_at, const StackFitOptions& options) {
  const int width = pixels.width();
  const std::vector<int> probe = SparseGrid(width, pixels.height(), kF0ProbePixels);
  const int count = static_cast<int>(probe.size());
  std::vector<std::vector<PixelObservation>> observations(count);
  ParallelFor(count, options.threads, [&](int k) { observations[k] = pixels.Observations(probe[k] % width, probe[k] / width); });
  LOOM_ASSIGN_OR_RETURN(const auto first, FitAtF0One(
                                              observations, stack, [&](int k) { return start_at(probe[k], 1.0); }, options));
  const std::vector<WardParams<double>>& fitted = first.first;
  const std::vector<double>& costs = first.second;
  // The best-fitted share: a pixel left in a wrong basin costs far more than the rest and tells
  // nothing of F0.
  std::vector<int> order(count);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return costs[a] < costs[b]; });
  order.resize(static_cast<size_t>(std::ceil(kF0BestFittedShare * count)));
  std::vector<std::vector<PixelObservation>> kept;
  std::vector<WardParams<double>> starts;  // at F0 1: each joint fit keeps their a_s·F0
  for (int k : order) kept.push_back(std::move(observations[k])), starts.push_back(fitted[k]);
  // The starts side by side: each joint fit runs on one thread (FitPixelsSharingF0), so that F0
  // and every map fitted at it are the same on any thread count.
  std::vector<SharedF0Fit> joints(kF0Starts.size());
  std::vector<Status> failures(kF0Starts.size(), Status::Ok());
  ParallelFor(static_cast<int>(kF0Starts.size()), options.threads, [&](int s) {
    Result<SharedF0Fit> joint = FitPixelsSharingF0(kept, starts, kF0Starts[s], options.pixel_fit);
    if (!joint.ok()) {
      failures[s] = joint.status();
      return;
    }
    joints[s] = std::move(*joint);
  });
  MaterialF0 material;
  for (size_t s = 0; s < kF0Starts.size(); ++s) {
    LOOM_RETURN_IF_ERROR(failures[s]);
    const SharedF0Fit& joint = joints[s];
    if (material.fits.empty() || joint.cost < material.cost) material.f0 = joint.f0, material.cost = joint.cost;
    material.fits.push_back({kF0Starts[s], joint.f0, joint.cost, static_cast<double>(joint.iterations)});
  }
  return material;
}

}  // namespace loom::fitting::internal
