// Step 5: poor fits fitted again, from well-fitted neighbours and from grid-searched starts.
#include "fitting/solve/internal/stack_stages.h"

#include <algorithm>
#include <array>

#include "core/parallel.h"

namespace loom::fitting::internal {

namespace {

// Light samples per strip that the grid search scores its candidates with: they are coarse
// anyway, and 4 rank them as 8 do (the main job: same L1, 9 % less time).
constexpr int kGridLights = 4;
// Normals that the grid search tries every lobe shape at, of the 13 ranked by their best
// isotropic lobe: 124 candidates instead of 364, the same starts in effect (the main job: its
// retries 10.5 → 7.9 s, re-render L1 0.1352 → 0.1351; tac7 256²: L1 0.0024 either way).
constexpr int kGridNormals = 3;

// Calls visit(index) for each pixel inside the image within `radius` of pixel (x, y) (a
// (2 radius + 1)² square), the pixel itself left out; radius 1: its 8-connected neighbours.
template <typename Visit>
void ForEachNeighbour(int width, int height, int x, int y, Visit visit, int radius = 1) {
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const int nx = x + dx, ny = y + dy;
      if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= width || ny >= height) continue;
      visit(ny * width + nx);
    }
  }
}

// A pixel's 8-connected neighbours that are fitted at or below `threshold`, best (lowest
// relative RMS) first.
std::vector<int> FittedNeighbours(const std::vector<PixelOutcome>& outcomes, int width, int height, int pixel, double threshold) {
  std::vector<int> fitted;
  ForEachNeighbour(width, height, pixel % width, pixel / width, [&](int n) {
    if (outcomes[n].fitted && outcomes[n].rms <= threshold) fitted.push_back(n);
  });
  std::sort(fitted.begin(), fitted.end(), [&](int a, int b) { return outcomes[a].rms < outcomes[b].rms; });
  return fitted;
}

// Step 5 on the refiner for some retried pixels, in two stages. Explore: each pixel's best grid
// starts and its first fit are refined with the strips merged into `retry_explore_lights`
// samples (a grid start tries another basin; the prior toward the pixel's own start still keeps
// the CNN's knowledge where the data leave a parameter loose). Finish: only where a grid start's
// basin beats the first fit's by retry_min_gain is it refined again with every sample; the
// better of that and the first fit is kept. Most retried pixels are noisy rather than in a wrong
// basin, and end the exploration where they were (docs/benchmarks.md).
// Returns how many were finished.
Result<int> RefineRetryChunk(const StackPixels& pixels, const ObservationStack& stack, const std::vector<int>& retry,
                             const RefineOptions& refine, const StackFitOptions& options, double threshold,
                             const std::function<WardParams<double>(int)>& start_of, const NormalStarts& normals, bool dense,
                             std::vector<PixelOutcome>& outcomes) {
  const int width = pixels.width(), height = pixels.height();
  const int grid_starts = options.retry_grid_starts;
  const int per_pixel = grid_starts + 1;                                               // the grid's starts, then the first fit
  const int neighbour_starts = std::min(grid_starts, options.retry_neighbour_starts);  // among the grid's
  std::vector<std::vector<PixelObservation>> observations(retry.size());
  std::vector<WardParams<double>> starts(retry.size() * per_pixel);
  ParallelFor(static_cast<int>(retry.size()), options.threads, [&](int r) {
    const int i = retry[r];
    observations[r] = pixels.Observations(i % width, i / width);
    std::vector<WardParams<double>> candidates;
    for (int n : FittedNeighbours(outcomes, width, height, i, threshold)) {
      if (static_cast<int>(candidates.size()) == neighbour_starts) break;
      candidates.push_back(outcomes[n].params);
    }
    if (const int more = grid_starts - static_cast<int>(candidates.size()); more > 0) {
      for (const WardParams<double>& p : GridStartsAround({normals.Turn(i), dense}, observations[r], [&](const auto& o) {
             return GridStarts(o, refine.fixed_f0.value_or(1.0), more, kGridLights, kGridNormals);
           })) {
        candidates.push_back(p);
      }
    }
    candidates.resize(grid_starts, candidates.empty() ? outcomes[i].params : candidates.front());
    candidates.push_back(outcomes[i].params);
    std::copy(candidates.begin(), candidates.end(), starts.begin() + static_cast<size_t>(r) * per_pixel);
  });
  RefineOptions explore = refine;
  explore.max_lights_per_observation = options.retry_explore_lights;
  explore.coarse_lights_per_observation = 0;
  explore.uncertainty = false;
  const RefineProblem explore_problem{
      .pixels = static_cast<int>(starts.size()),
      .lights_per_observation = EmittersPerObservation(stack),
      .observations = [&](int j, std::vector<PixelObservation>& into) { into = observations[j / per_pixel]; },
      .start = [&](int j) { return starts[j]; },
      .prior_mean = [&](int j) { return start_of(retry[j / per_pixel]); }};
  LOOM_ASSIGN_OR_RETURN(const std::vector<RefinedPixel> explored, RefinePixels(explore_problem, explore));
  // The pixels whose best explored grid start beats their explored first fit.
  std::vector<int> finish;  // indices into `retry`
  std::vector<WardParams<double>> finish_starts;
  for (size_t r = 0; r < retry.size(); ++r) {
    const RefinedPixel& first = explored[r * per_pixel + grid_starts];
    const RefinedPixel* best = nullptr;
    for (int s = 0; s < per_pixel; ++s) outcomes[retry[r]].iterations += explored[r * per_pixel + s].iterations;
    for (int s = 0; s < grid_starts; ++s) {
      const RefinedPixel& candidate = explored[r * per_pixel + s];
      if (candidate.fitted && (!best || candidate.cost < best->cost)) best = &candidate;
    }
    if (best && (!first.fitted || best->cost < (1 - options.retry_min_gain) * first.cost)) {
      finish.push_back(static_cast<int>(r));
      finish_starts.push_back(best->params);
    }
  }
  RefineOptions full = refine;
  full.coarse_lights_per_observation = 0;
  const RefineProblem finish_problem{
      .pixels = static_cast<int>(finish.size()),
      .lights_per_observation = EmittersPerObservation(stack),
      .observations = [&](int k, std::vector<PixelObservation>& into) { into = observations[finish[k]]; },
      .start = [&](int k) { return finish_starts[k]; },
      .prior_mean = [&](int k) { return start_of(retry[finish[k]]); }};
  LOOM_ASSIGN_OR_RETURN(const std::vector<RefinedPixel> finished, RefinePixels(finish_problem, full));
  for (size_t k = 0; k < finish.size(); ++k) {
    PixelOutcome& outcome = outcomes[retry[finish[k]]];
    const int iterations = outcome.iterations + finished[k].iterations;
    if (finished[k].fitted && finished[k].cost < outcome.cost) outcome = OutcomeOf(finished[k]);
    outcome.iterations = iterations;
  }
  return static_cast<int>(finish.size());
}

// Refits each target pixel from its source neighbour's fit, keeping the result where its cost is
// lower; marks the targets it brings to or below `threshold` good from `round` + 1 and returns
// how many.
Result<int> RefitFromNeighbours(const StackPixels& pixels, const ObservationStack& stack, const std::vector<int>& targets,
                                const std::vector<int>& sources, RefineOptions refine, double threshold,
                                const std::function<WardParams<double>(int)>& start_of, int round, std::vector<int>& good_since,
                                std::vector<PixelOutcome>& outcomes) {
  const int width = pixels.width();
  refine.coarse_lights_per_observation = 0;
  const RefineProblem problem{.pixels = static_cast<int>(targets.size()),
                              .lights_per_observation = EmittersPerObservation(stack),
                              .observations =
                                  [&](int k, std::vector<PixelObservation>& into) {
                                    pixels.ObservationsInto(targets[k] % width, targets[k] / width, nullptr, into);
                                  },
                              .start = [&](int k) { return outcomes[sources[k]].params; },
                              .prior_mean = [&](int k) { return start_of(targets[k]); }};
  LOOM_ASSIGN_OR_RETURN(const std::vector<RefinedPixel> refined, RefinePixels(problem, refine));
  int good = 0;
  for (size_t k = 0; k < targets.size(); ++k) {
    PixelOutcome& outcome = outcomes[targets[k]];
    const int iterations = outcome.iterations + refined[k].iterations;
    if (refined[k].fitted && refined[k].cost < outcome.cost) outcome = OutcomeOf(refined[k]);
    outcome.iterations = iterations;
    if (outcome.rms <= threshold) good_since[targets[k]] = round + 1, ++good;
  }
  return good;
}

}  // namespace

// A fit worse than the pixel's Lambertian surface on the same observations (GD10 with a_s 0 is
// that surface, so the fit is in a wrong basin): a broad lobe that swallowed the diffuse term
// can fit below the retry threshold and still be that. Asked on dense stacks only: on a phone's
// few flash photographs retrying such pixels lowered their cost and raised the left-out views'
// error (ceres 0.6099 → 0.6135, refine 0.6374 → 0.6491).
bool WorseThanLambertian(const PixelOutcome& outcome, const NormalStarts& normals, int i) {
  if (normals.empty() || !normals.Pixel(i)) return false;
  return outcome.rms > normals.Pixel(i)->rms_all;
}

// A pixel fitted again from grid-searched starts (its highlight is not where its start put it)
// and, where it has one, from its Lambertian surface; the better of the fits is kept.
PixelOutcome RetryFromGrid(const std::vector<PixelObservation>& observations, const PixelOutcome& first,
                           const PixelFitOptions& fit, const StackFitOptions& options, const GridFrames& frames,
                           const std::optional<LambertPixel>& lambertian) {
  std::vector<WardParams<double>> starts = GridStartsAround(frames, observations, [&](const auto& o) {
    return GridInitialParams(o, fit.fixed_f0.value_or(1.0), options.retry_grid_starts);
  });
  if (lambertian) {  // the Lambertian surface with a faint lobe to grow from (at a_s 0 σ has no gradient)
    WardParams<double> start = AsWardParams(*lambertian);
    start.a_s = Eigen::Vector3d::Constant(0.01);
    start.f0 = fit.fixed_f0.value_or(1.0);
    starts.push_back(start);
  }
  Result<PixelFitResult> again = FitFromStarts(observations, starts, fit);
  if (!again.ok() || again->cost >= first.cost) return first;
  return {again->params,
          again->cost,
          RelativeRms(again->params, observations),
          first.iterations + again->iterations,
          first.observations,
          true,
          std::nullopt};
}

// Step 5a on the refiner: propagation. On a fabric a pixel fitted into a wrong basin mostly lies
// beside a well-fitted one of the same yarn, whose fit is a start in the right basin and much
// cheaper to refine from than a grid search is to find (PatchMatch's idea, with the refiner as
// the local step). Each round refits every still-poor pixel from its best well-fitted neighbour
// that no earlier round offered it; a pixel brought to or below the threshold leaves the retries
// and is offered to its own neighbours in the next round. A round starts with a trial on every
// 8th of its pixels and stops there when fewer than retry_neighbour_min_yield of them come good:
// on a noisy stack most poor pixels are noise, not a wrong basin (the main job: 10 %), and
// refitting them all cost 17 % more time for a 1 % lower L1. Returns the pixels left poor.
Result<std::vector<int>> PropagateFromNeighbours(const StackPixels& pixels, const ObservationStack& stack, std::vector<int> retry,
                                                 const RefineOptions& refine, const StackFitOptions& options, double threshold,
                                                 const std::function<WardParams<double>(int)>& start_of,
                                                 std::vector<PixelOutcome>& outcomes, int& propagated) {
  constexpr int kTrialStride = 8;
  const int width = pixels.width(), height = pixels.height();
  std::vector<int> good_since(outcomes.size(), 0);  // the round from which a pixel may be offered
  for (int round = 0; round < options.retry_neighbour_rounds && !retry.empty(); ++round) {
    std::array<std::vector<int>, 2> targets, sources;  // the trial's, the rest's
    for (int i : retry) {
      for (int n : FittedNeighbours(outcomes, width, height, i, threshold)) {
        if (good_since[n] != round) continue;  // offered in an earlier round
        const int part = targets[0].size() * kTrialStride <= targets[1].size() ? 0 : 1;
        targets[part].push_back(i), sources[part].push_back(n);
        break;
      }
    }
    if (targets[0].empty()) break;
    LOOM_ASSIGN_OR_RETURN(const int trial_good, RefitFromNeighbours(pixels, stack, targets[0], sources[0], refine, threshold,
                                                                    start_of, round, good_since, outcomes));
    propagated += trial_good;
    const bool worth_it = trial_good >= options.retry_neighbour_min_yield * static_cast<double>(targets[0].size());
    if (worth_it) {
      LOOM_ASSIGN_OR_RETURN(const int good, RefitFromNeighbours(pixels, stack, targets[1], sources[1], refine, threshold,
                                                                start_of, round, good_since, outcomes));
      propagated += good;
    }
    std::erase_if(retry, [&](int i) { return outcomes[i].rms <= threshold; });
    if (!worth_it) break;
  }
  return retry;
}

// Step 5 on the refiner, a chunk of retried pixels at a time: a chunk's observations are computed
// once for the grid search and every start (their shadow tests and LED falloff were a fifth of
// the fit when repeated), about 150 KB a pixel on tac7-mini. Returns how many were finished.
Result<int> RefineRetries(const StackPixels& pixels, const ObservationStack& stack, const std::vector<int>& retry,
                          const RefineOptions& refine, const StackFitOptions& options, double threshold,
                          const std::function<WardParams<double>(int)>& start_of, const NormalStarts& normals, bool dense,
                          const std::function<void(int)>& progress, std::vector<PixelOutcome>& outcomes) {
  constexpr size_t kChunk = 512;
  int finished = 0;
  for (size_t first = 0; first < retry.size(); first += kChunk) {
    const size_t end = std::min(retry.size(), first + kChunk);
    const std::vector<int> chunk(retry.begin() + static_cast<std::ptrdiff_t>(first),
                                 retry.begin() + static_cast<std::ptrdiff_t>(end));
    LOOM_ASSIGN_OR_RETURN(const int chunk_finished,
                          RefineRetryChunk(pixels, stack, chunk, refine, options, threshold, start_of, normals, dense, outcomes));
    finished += chunk_finished;
    progress(static_cast<int>(end));
  }
  return finished;
}

}  // namespace loom::fitting::internal
