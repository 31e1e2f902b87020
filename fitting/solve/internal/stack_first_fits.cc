// Step 4 on the refiner: every pixel from its start, with the strips' nodes placed again where a lobe moved.
#include "fitting/solve/internal/stack_stages.h"

#include <algorithm>
#include <numeric>

#include "core/parallel.h"

namespace loom::fitting::internal {

namespace {

// Light samples per observation where the strips are integrated by nodes (StripQuadrature).
std::vector<int> NodesPerObservation(const ObservationStack& stack, const StackPixels& pixels) {
  std::vector<int> lights = EmittersPerObservation(stack);
  for (size_t k = 0; k < lights.size(); ++k) {
    if (stack.observations[k].group == ObservationGroup::kLinearLight) lights[k] = pixels.strip_quadrature().Nodes();
  }
  return lights;
}

// Of `candidates`, the pixels whose fit ended with a lobe outside the strip spans their nodes were
// placed for (at placed_at(i)): their quadrature no longer holds there.
std::vector<int> PixelsOutsideTheirNodes(const StackPixels& pixels, const std::vector<int>& candidates,
                                         const std::function<WardParams<double>(int)>& placed_at,
                                         const std::vector<PixelOutcome>& outcomes, int threads) {
  const int width = pixels.width();
  const StripQuadratureOptions& quadrature = pixels.strip_quadrature();
  std::vector<char> outside(candidates.size(), 0);
  ParallelFor(static_cast<int>(candidates.size()), threads, [&](int c) {
    const int i = candidates[c];
    if (!outcomes[i].fitted) return;
    const auto placed = pixels.LobeSpans(i % width, i / width, placed_at(i), quadrature.lobe_fraction);
    const auto ended = pixels.LobeSpans(i % width, i / width, outcomes[i].params, quadrature.moved_fraction);
    for (size_t k = 0; k < placed.size() && !outside[c]; ++k) outside[c] = !StripNodesCover(placed[k], ended[k], quadrature);
  });
  std::vector<int> moved;
  for (size_t c = 0; c < candidates.size(); ++c) {
    if (outside[c]) moved.push_back(candidates[c]);
  }
  return moved;
}

// Rounds of placing a pixel's nodes again where its fit ended, at most: a lobe that keeps moving
// out of them after that keeps its last fit.
constexpr int kNodePlacementRounds = 3;

}  // namespace

// Step 4 on the refiner: every pixel from start_of(i). Where the strips are integrated by nodes
// around each pixel's lobe, the pixels whose lobe moved out of their nodes' span are refined
// again from where they ended, with nodes placed there; `nodes_replaced` counts them (a pixel
// once however many rounds it took).
Result<std::vector<PixelOutcome>> RefineAll(const StackPixels& pixels, const ObservationStack& stack,
                                            const std::function<WardParams<double>(int)>& start_of, const RefineOptions& refine,
                                            const std::function<void(int)>& progress, int& nodes_replaced) {
  const int width = pixels.width();
  const int count = width * pixels.height();
  const bool nodes = pixels.integrates_strips();
  const RefineProblem problem{
      .pixels = count,
      .lights_per_observation = nodes ? NodesPerObservation(stack, pixels) : EmittersPerObservation(stack),
      .observations =
          [&](int i, std::vector<PixelObservation>& into) {
            const WardParams<double> lobe = start_of(i);
            pixels.ObservationsInto(i % width, i / width, &lobe, into);
          },
      .start = start_of,
      .prior_mean = {}};
  LOOM_ASSIGN_OR_RETURN(const std::vector<RefinedPixel> refined, RefinePixels(problem, refine, progress));
  std::vector<PixelOutcome> outcomes;
  for (const RefinedPixel& r : refined) outcomes.push_back(OutcomeOf(r));
  nodes_replaced = 0;
  if (!nodes) return outcomes;
  std::vector<int> moved(count);
  std::iota(moved.begin(), moved.end(), 0);
  std::vector<WardParams<double>> placed_at(count);
  for (int i = 0; i < count; ++i) placed_at[i] = start_of(i);
  std::vector<char> replaced(count, 0);
  for (int round = 0; round < kNodePlacementRounds; ++round) {
    moved = PixelsOutsideTheirNodes(
        pixels, moved, [&](int i) { return placed_at[i]; }, outcomes, refine.threads);
    if (moved.empty()) break;
    for (int i : moved) placed_at[i] = outcomes[i].params, replaced[i] = 1;
    const RefineProblem again{.pixels = static_cast<int>(moved.size()),
                              .lights_per_observation = problem.lights_per_observation,
                              .observations =
                                  [&](int k, std::vector<PixelObservation>& into) {
                                    pixels.ObservationsInto(moved[k] % width, moved[k] / width, &placed_at[moved[k]], into);
                                  },
                              .start = [&](int k) { return placed_at[moved[k]]; },
                              .prior_mean = [&](int k) { return start_of(moved[k]); }};
    LOOM_ASSIGN_OR_RETURN(const std::vector<RefinedPixel> refitted, RefinePixels(again, refine));
    for (size_t k = 0; k < moved.size(); ++k) {
      const int iterations = outcomes[moved[k]].iterations + refitted[k].iterations;
      outcomes[moved[k]] = OutcomeOf(refitted[k]);
      outcomes[moved[k]].iterations = iterations;
    }
  }
  nodes_replaced = static_cast<int>(std::count(replaced.begin(), replaced.end(), 1));
  return outcomes;
}

}  // namespace loom::fitting::internal
