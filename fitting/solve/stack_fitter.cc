#include "fitting/solve/stack_fitter.h"

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <numeric>
#include <ostream>

#include <opencv2/core.hpp>

#include "core/duration.h"
#include "core/parallel.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/solve/internal/neighbour_lobes.h"
#include "fitting/solve/internal/normal_frame.h"
#include "fitting/solve/internal/peak_coverage.h"
#include "fitting/solve/lambert_fit.h"

namespace loom::fitting {
namespace {

using Clock = std::chrono::steady_clock;

// log(1 + L / typical) of the pixels `rows` (indices into the stack): compresses highlights so
// that k-means groups by appearance, not by the few brightest observations.
cv::Mat AppearanceFeatures(const ObservationStack& stack, const std::vector<int>& rows) {
  const int n = static_cast<int>(stack.observations.size());
  const auto value = [&](int k, int i) {
    return stack.image.channel(ObservationStack::ObservationChannel(k))[static_cast<size_t>(i)];
  };
  std::vector<float> finite;
  for (int k = 0; k < n; ++k) {
    for (int i : rows) {
      if (const float v = value(k, i); std::isfinite(v) && v > 0) finite.push_back(v);
    }
  }
  float typical = 1;
  if (!finite.empty()) {
    std::nth_element(finite.begin(), finite.begin() + finite.size() / 2, finite.end());
    typical = finite[finite.size() / 2];
  }
  cv::Mat features(static_cast<int>(rows.size()), n, CV_32F);
  for (int k = 0; k < n; ++k) {
    double sum = 0;
    int seen = 0;
    for (int i : rows) {
      if (const float v = value(k, i); std::isfinite(v)) sum += std::log1p(std::max(0.0f, v) / typical), ++seen;
    }
    const float unseen = seen ? static_cast<float>(sum / seen) : 0.0f;
    for (size_t r = 0; r < rows.size(); ++r) {
      const float v = value(k, rows[r]);
      features.at<float>(static_cast<int>(r), k) = std::isfinite(v) ? std::log1p(std::max(0.0f, v) / typical) : unseen;
    }
  }
  return features;
}

// The pixels that a fit can use: those with at least as many seen observations as GD10 has
// parameters. The others (masked, as an imported photograph's background is, or unseen by the
// cameras) are skipped: NaN maps, counted, never an error.
std::vector<int> FittablePixels(const ObservationStack& stack) {
  const int pixels = static_cast<int>(stack.image.pixel_count());
  std::vector<int> seen(pixels, 0);
  for (size_t k = 0; k < stack.observations.size(); ++k) {
    const auto values = stack.image.channel(ObservationStack::ObservationChannel(static_cast<int>(k)));
    for (int i = 0; i < pixels; ++i) seen[i] += !std::isnan(values[i]);
  }
  std::vector<int> fittable;
  for (int i = 0; i < pixels; ++i) {
    if (seen[i] >= kNumWardParams) fittable.push_back(i);
  }
  return fittable;
}

// Where a pixel without a cluster (one FittablePixels leaves out) starts: it is never fitted, but
// the refiner's batches take a finite start for every pixel.
WardParams<double> NeutralStart() {
  WardParams<double> p;
  p.n_s = Eigen::Vector3d::UnitZ();
  p.a_d = Eigen::Vector3d::Constant(0.5);
  p.a_s = Eigen::Vector3d::Constant(0.01);
  p.sigma_x = p.sigma_y = 0.2;
  p.alpha = 0;
  p.f0 = 1;
  return p;
}

// A pixel that was not fitted, in every parameter.
WardParams<double> NanParams() {
  WardParams<double> p;
  p.n_s = p.a_d = p.a_s = Eigen::Vector3d::Constant(NAN);
  p.sigma_x = p.sigma_y = p.alpha = p.f0 = NAN;
  return p;
}

// The narrowest lobe a stack resolves, per radian of its half-vectors' spacing: a lobe has to
// span about two observations' half-vectors to be told from a narrower one of the same peak.
// Where it spans fewer, the fit is free to put all of a highlight into one view and predict
// any other view's value badly (a phone's few flash photographs: the held-out views of a
// simulated fabric came out several times worse than a Lambertian surface's).
constexpr double kMinSigmaPerSpacing = 0.5;
// The floor never rises above this: a stack that sparse says little of any lobe.
constexpr double kMaxResolvedSigma = 0.2;
// Below this spacing the floor stays kMinSigma: a scanner's stack (tac7's and tac7-mini's space
// their half-vectors 0.6–0.7° apart) resolves every lobe its fits are scored on, and their maps
// stay as they were.
constexpr double kSparseSpacingDeg = 2;

// How finely the stack samples the half-vectors: over a sparse grid of pixels, the median over a
// pixel's observations of the angle (rad) from each half-vector to the nearest other one, and the
// median of that over the pixels. A strip's light samples count as one half-vector, its
// brightest's: the strip's other samples lie along it, so they resolve a lobe across the strip
// no finer than one.
std::vector<int> SparseGrid(int width, int height, int count);
double HalfVectorSpacing(const StackPixels& pixels) {
  const std::vector<int> grid = SparseGrid(pixels.width(), pixels.height(), 64);
  std::vector<double> spacings;
  for (int i : grid) {
    std::vector<Eigen::Vector3d> halves;
    for (const PixelObservation& o : pixels.Observations(i % pixels.width(), i / pixels.width())) {
      const auto brightest = std::max_element(o.lights.begin(), o.lights.end(), [](const LightSample& a, const LightSample& b) {
        return a.irradiance < b.irradiance;
      });
      if (brightest != o.lights.end()) halves.push_back((brightest->l_local + o.v_local).normalized());
    }
    if (halves.size() < 2) continue;
    std::vector<double> nearest(halves.size(), kPi);
    for (size_t a = 0; a < halves.size(); ++a) {
      for (size_t b = 0; b < halves.size(); ++b) {
        const double angle = std::acos(std::clamp(halves[a].dot(halves[b]), -1.0, 1.0));
        if (a != b && angle > 1e-9) nearest[a] = std::min(nearest[a], angle);
      }
    }
    std::nth_element(nearest.begin(), nearest.begin() + static_cast<std::ptrdiff_t>(nearest.size() / 2), nearest.end());
    spacings.push_back(nearest[nearest.size() / 2]);
  }
  if (spacings.empty()) return 0;
  std::nth_element(spacings.begin(), spacings.begin() + static_cast<std::ptrdiff_t>(spacings.size() / 2), spacings.end());
  return spacings[spacings.size() / 2];
}

// Per pixel, its photometric-stereo normal and albedo (lambert_fit.h), where the fit starts from
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

// Grid-searched starts (GridInitialParams, or the refiner's GridStarts through `search`) around
// the pixel's photometric-stereo normal where it has one: the search's normals lie within 20° of
// the normal it is given, and a curved surface tilts much further than that.
std::vector<WardParams<double>> GridStartsAround(
    const std::optional<Eigen::Matrix3d>& turn, const std::vector<PixelObservation>& observations,
    const std::function<std::vector<WardParams<double>>(const std::vector<PixelObservation>&)>& search) {
  if (!turn) return search(observations);
  std::vector<PixelObservation> turned = observations;
  internal::TurnObservations(*turn, turned);
  std::vector<WardParams<double>> starts = search(turned);
  for (WardParams<double>& start : starts) start = internal::TurnedBack(*turn, start);
  return starts;
}

// RMS of the model's residuals relative to the pixel's mean radiance.
double RelativeRms(const WardParams<double>& params, const std::vector<PixelObservation>& observations) {
  const WardLobe<double> lobe(params);
  double squares = 0, sum = 0;
  for (const PixelObservation& o : observations) {
    const double r = PredictRadiance(lobe, o) - o.radiance;
    squares += r * r;
    sum += std::abs(o.radiance);
  }
  if (observations.empty() || sum <= 0) return 0;
  return std::sqrt(squares / observations.size()) / (sum / observations.size());
}

// The lowest-cost fit over several starts (costs compare: same observations, same scale).
Result<PixelFitResult> FitFromStarts(const std::vector<PixelObservation>& observations,
                                     const std::vector<WardParams<double>>& starts, const PixelFitOptions& options) {
  Result<PixelFitResult> best = InternalError("pixel fit", "no start");
  for (const WardParams<double>& start : starts) {
    Result<PixelFitResult> fitted = FitPixel(observations, start, options);
    if (!fitted.ok()) return fitted;
    if (!best.ok() || fitted->cost < best->cost) best = std::move(fitted);
  }
  return best;
}

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

// A fit worse than the pixel's Lambertian surface on the same observations (GD10 with a_s 0 is
// that surface, so the fit is in a wrong basin): a broad lobe that swallowed the diffuse term
// can fit below the retry threshold and still be that. Asked on dense stacks only: on a phone's
// few flash photographs retrying such pixels lowered their cost and raised the left-out views'
// error (ceres 0.6099 → 0.6135, refine 0.6374 → 0.6491).
bool WorseThanLambertian(const PixelOutcome& outcome, const NormalStarts& normals, int i) {
  if (normals.empty() || !normals.Pixel(i)) return false;
  return outcome.rms > normals.Pixel(i)->rms_all;
}

PixelOutcome FitFromStart(const std::vector<PixelObservation>& observations, const WardParams<double>& start,
                          const PixelFitOptions& fit) {
  PixelOutcome outcome{start, 0, 0, 0, static_cast<int>(observations.size()), false, std::nullopt};
  if (Result<PixelFitResult> result = FitPixel(observations, start, fit); result.ok()) {
    outcome.params = result->params;
    outcome.cost = result->cost;
    outcome.iterations = result->iterations;
    outcome.fitted = true;
  }
  outcome.rms = RelativeRms(outcome.params, observations);
  return outcome;
}

// A pixel fitted again from grid-searched starts (its highlight is not where its start put it)
// and, where it has one, from its Lambertian surface; the better of the fits is kept.
PixelOutcome RetryFromGrid(const std::vector<PixelObservation>& observations, const PixelOutcome& first,
                           const PixelFitOptions& fit, const StackFitOptions& options, const std::optional<Eigen::Matrix3d>& turn,
                           const std::optional<LambertPixel>& lambertian) {
  std::vector<WardParams<double>> starts = GridStartsAround(turn, observations, [&](const auto& o) {
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

std::vector<int> EmittersPerObservation(const ObservationStack& stack) {
  std::vector<int> emitters;
  for (const StackObservation& o : stack.observations) emitters.push_back(static_cast<int>(o.emitters.size()));
  return emitters;
}

RefineOptions RefinerOptions(const PixelFitOptions& fit, const StackFitOptions& options) {
  RefineOptions refine;
  refine.max_iterations = fit.max_iterations;
  refine.huber_scale = fit.huber_scale;
  refine.fixed_f0 = fit.fixed_f0;
  refine.min_sigma = fit.min_sigma;
  refine.threads = options.threads;
  refine.max_lights_per_observation = options.max_lights_per_observation;
  refine.coarse_lights_per_observation = options.coarse_lights_per_observation;
  refine.function_tolerance = options.refine_function_tolerance;
  return refine;
}

PixelOutcome OutcomeOf(const RefinedPixel& r) {
  PixelOutcome outcome{r.params, r.cost, r.rms, r.iterations, r.observations_used, r.fitted, std::nullopt};
  if (r.fitted) outcome.sigma = r.sigma;
  return outcome;
}

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
                             const std::function<WardParams<double>(int)>& start_of, const NormalStarts& normals,
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
      for (const WardParams<double>& p : GridStartsAround(normals.Turn(i), observations[r], [&](const auto& o) {
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
                          const std::function<WardParams<double>(int)>& start_of, const NormalStarts& normals,
                          const std::function<void(int)>& progress, std::vector<PixelOutcome>& outcomes) {
  constexpr size_t kChunk = 512;
  int finished = 0;
  for (size_t first = 0; first < retry.size(); first += kChunk) {
    const size_t end = std::min(retry.size(), first + kChunk);
    const std::vector<int> chunk(retry.begin() + static_cast<std::ptrdiff_t>(first),
                                 retry.begin() + static_cast<std::ptrdiff_t>(end));
    LOOM_ASSIGN_OR_RETURN(const int chunk_finished,
                          RefineRetryChunk(pixels, stack, chunk, refine, options, threshold, start_of, normals, outcomes));
    finished += chunk_finished;
    progress(static_cast<int>(end));
  }
  return finished;
}

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

// The smoothing prior's weight on a stack whose noise variance is `variance_ratio` times the one
// the weight was picked at: scaled as the CNN prior's is (StackFitOptions::
// prior_reference_noise_rms). Below a hundredth of it the pass would move a pixel by under a
// hundredth of what it moves one at the picked noise, so it is not run (0): a noise-free stack,
// whose data are exact, costs no second pass.
double SmoothingWeightAt(double weight, double variance_ratio) { return variance_ratio >= 0.01 ? weight * variance_ratio : 0; }

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

double RetryThreshold(const std::vector<PixelOutcome>& outcomes, const StackFitOptions& options) {
  std::vector<double> rms;
  for (const PixelOutcome& o : outcomes) {
    if (o.fitted) rms.push_back(o.rms);
  }
  const std::optional<double> noise = NoiseRms(std::move(rms));
  return noise ? std::max(options.retry_above_rms, options.retry_above_noise_rms * *noise) : options.retry_above_rms;
}

// Row-major indices of about `count` pixels on an even grid over a width × height image (all of
// them when it has fewer).
std::vector<int> SparseGrid(int width, int height, int count) {
  const int stride = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(width) * height / count)));
  std::vector<int> grid;
  for (int y = stride / 2; y < height; y += stride) {
    for (int x = stride / 2; x < width; x += stride) grid.push_back(y * width + x);
  }
  return grid;
}

// The stack's noise level as the retries measure it (NoiseRms), from a sparse grid of
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

// Pixels that SearchF0 fits with one shared F0: on a 630² material about 1/3,000 of them.
constexpr int kF0ProbePixels = 128;
// F0s that SearchF0's joint fit starts from; the lowest cost wins. The fit moves F0 smoothly,
// but across a material's pixels the cost of F0 can have more than one dip.
constexpr std::array<double, 3> kF0Starts = {1.0, 0.3, 0.08};
// The share of them, the best fitted at F0 1, that the joint fit takes.
constexpr double kF0BestFittedShare = 0.5;

// `p` at another F0, a_s·F0 kept (within the albedo's bound).
WardParams<double> AtF0(WardParams<double> p, double f0) {
  p.a_s = (p.a_s * (p.f0 / f0)).cwiseMin(kMaxAlbedo);
  p.f0 = f0;
  return p;
}

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

Result<MaterialF0> SearchF0(const StackPixels& pixels, const ObservationStack& stack,
                            const std::function<WardParams<double>(int, double)>& start_at, const StackFitOptions& options) {
  const int width = pixels.width();
  const std::vector<int> probe = SparseGrid(width, pixels.height(), kF0ProbePixels);
  const int count = static_cast<int>(probe.size());
  std::vector<std::vector<PixelObservation>> observations(count);
  ParallelFor(count, options.threads, [&](int k) { observations[k] = pixels.Observations(probe[k] % width, probe[k] / width); });
  LOOM_ASSIGN_OR_RETURN(const auto first, FitAtF0One(
                                              observations, stack, [&](int k) { return start_at(probe[k], 1.0); }, options));
  const auto& [fitted, costs] = first;
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

// The cluster's start: its most typical pixels' observations pooled into one fit, each pixel's
// turned onto its photometric-stereo normal where it has one (the fit's n_s is then relative
// to each pixel's normal).
Result<PixelFitResult> FitCluster(const StackPixels& pixels, const PixelClusters& clusters, int cluster,
                                  const StackFitOptions& options, const NormalStarts& normals) {
  std::vector<std::pair<float, int>> members;
  for (size_t i = 0; i < clusters.labels.size(); ++i) {
    if (clusters.labels[i] == cluster) members.push_back({clusters.distances[i], static_cast<int>(i)});
  }
  const size_t take = std::min(members.size(), static_cast<size_t>(options.pixels_per_cluster_fit));
  std::partial_sort(members.begin(), members.begin() + take, members.end());
  std::vector<PixelObservation> pooled;
  for (size_t m = 0; m < take; ++m) {
    const int i = members[m].second;
    std::vector<PixelObservation> own = pixels.Observations(i % pixels.width(), i / pixels.width());
    if (const std::optional<Eigen::Matrix3d> turn = normals.Turn(i)) internal::TurnObservations(*turn, own);
    pooled.insert(pooled.end(), std::make_move_iterator(own.begin()), std::make_move_iterator(own.end()));
  }
  PixelFitOptions fit = options.cluster_fit;
  fit.fixed_f0 = options.fixed_f0;
  return FitFromStarts(pooled, GridInitialParams(pooled, options.fixed_f0.value_or(1.0), options.grid_starts), fit);
}

// Steps 1–3: every cluster's fit (the material's F0 is searched after, SearchF0).
template <typename Report>
Status FitClusters(const StackPixels& pixels, const PixelClusters& clusters, const StackFitOptions& options,
                   const NormalStarts& normals, const Report& report, StackFitSummary& summary) {
  std::vector<Result<PixelFitResult>> cluster_fits(clusters.count, InternalError("cluster", "not fitted"));
  ParallelFor(
      clusters.count, options.threads, [&](int c) { cluster_fits[c] = FitCluster(pixels, clusters, c, options, normals); },
      [&](int done) { report("clusters", done, clusters.count); });
  summary.cluster_sizes.assign(clusters.count, 0);
  for (int label : clusters.labels) {
    if (label >= 0) ++summary.cluster_sizes[label];
  }
  for (int c = 0; c < clusters.count; ++c) {
    if (!cluster_fits[c].ok()) {
      return FailedPreconditionError("cluster " + std::to_string(c) + " of the stack", cluster_fits[c].status().ToString());
    }
    summary.cluster_params.push_back(cluster_fits[c]->params);
  }
  return {};
}

// Maps of the outcomes; a pixel that was not fitted (skipped, or left with too few usable
// observations) is NaN in every parameter: no map claims a value that no data support.
Image MapsOf(const std::vector<PixelOutcome>& outcomes, const PixelClusters& clusters, const ObservationStack& stack) {
  const int width = stack.image.width();
  Image maps = MakeSvbrdfImage(width, stack.image.height(), /*with_height=*/true);
  const auto stack_height = stack.image.channel(2);  // pos.Z
  std::copy(stack_height.begin(), stack_height.end(), maps.channel(*maps.ChannelIndex(kHeightChannel)).begin());
  const int cluster_channel = maps.AddChannel(kFitClusterChannel);
  const int used_channel = maps.AddChannel(kFitObservationsChannel);
  const int rms_channel = maps.AddChannel(kFitRmsChannel);
  const bool with_uncertainty = std::any_of(outcomes.begin(), outcomes.end(), [](const PixelOutcome& o) { return o.sigma; });
  const int first_uncertainty = maps.num_channels();
  if (with_uncertainty) {
    for (const char* name : kUncertaintyChannels) maps.AddChannel(name);
  }
  for (size_t i = 0; i < outcomes.size(); ++i) {
    const int x = static_cast<int>(i) % width, y = static_cast<int>(i) / width;
    SetParams(maps, x, y, outcomes[i].fitted ? outcomes[i].params : NanParams());
    maps.at(cluster_channel, y, x) = static_cast<float>(clusters.labels[i]);
    maps.at(used_channel, y, x) = static_cast<float>(outcomes[i].observations);
    maps.at(rms_channel, y, x) = outcomes[i].fitted ? static_cast<float>(outcomes[i].rms) : NAN;
    if (!with_uncertainty) continue;
    const std::optional<ParamSigma>& s = outcomes[i].sigma;
    const double values[kUncertaintyChannels.size()] = {
        s ? s->normal_deg : NAN, s ? s->a_d.x() : NAN, s ? s->a_d.y() : NAN, s ? s->a_d.z() : NAN, s ? s->a_s.x() : NAN,
        s ? s->a_s.y() : NAN,    s ? s->a_s.z() : NAN, s ? s->sigma_x : NAN, s ? s->sigma_y : NAN, s ? s->alpha_deg : NAN};
    for (size_t c = 0; c < kUncertaintyChannels.size(); ++c) {
      maps.at(first_uncertainty + static_cast<int>(c), y, x) = static_cast<float>(values[c]);
    }
  }
  return maps;
}

void Summarise(const std::vector<PixelOutcome>& outcomes, StackFitSummary& summary) {
  int64_t iterations = 0, observations = 0;
  for (const PixelOutcome& o : outcomes) {
    summary.pixels_fitted += o.fitted;
    iterations += o.iterations;
    observations += o.observations;
  }
  summary.pixels_skipped = summary.pixels - summary.pixels_fitted;
  summary.mean_iterations = summary.pixels_fitted ? static_cast<double>(iterations) / summary.pixels_fitted : 0;
  summary.mean_observations = summary.pixels ? static_cast<double>(observations) / summary.pixels : 0;
}

}  // namespace

nlohmann::json StackFitOptions::ToJson() const {
  const bool refiner = solver == PixelSolver::kBatchRefiner;
  return {{"solver", refiner ? "batch refiner (" + RefinerInstructionSet() + ")" : "ceres"},
          {"clusters", clusters},
          {"photometric_stereo_starts", photometric_stereo_starts},
          {"hold_normals_of_unseen_peaks", hold_normals_of_unseen_peaks},
          {"held_normal_max_rms_ratio", held_normal_max_rms_ratio},
          {"left_out_view_selection_max_views", left_out_view_selection_max_views},
          {"f0", fixed_f0 ? nlohmann::json(*fixed_f0) : nlohmann::json("material")},
          {"retries", retry_poor_fits},
          {"retry_above", retry_above_noise_rms},
          {"neighbour_rounds", refiner ? retry_neighbour_rounds : 0},
          {"prior_weight", refiner ? prior.weight : 0},
          {"prior_reference_noise_rms", refiner ? prior_reference_noise_rms : 0},
          {"smoothing_weight", refiner ? smoothing.weight : 0},
          {"smoothing_specular_albedo", smoothing.specular_albedo},  // the pass's a_s scale
          {"strip_samples", max_lights_per_observation},
          {"strip_nodes", refiner && pixels.strip_quadrature ? pixels.strip_quadrature->Nodes() : 0},
          {"coarse_samples", coarse_lights_per_observation},
          {"function_tolerance", refine_function_tolerance}};
}

Result<std::optional<double>> ParseFixedF0(const std::string& text, const std::string& what) {
  if (text == "material") return std::optional<double>();
  double f0 = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), f0);
  if (error != std::errc() || end != text.data() + text.size() || !(f0 >= 0 && f0 <= 1)) {
    return InvalidArgumentError(what + " " + text, "expected a number in [0, 1] or 'material'");
  }
  return std::optional<double>(f0);
}

nlohmann::json StackFitSummary::ToJson() const {
  return {{"pixels", pixels},
          {"pixels_fitted", pixels_fitted},
          {"pixels_skipped", pixels_skipped},
          {"pixels_retried", pixels_retried},
          {"pixels_nodes_replaced", pixels_nodes_replaced},
          {"pixels_propagated", pixels_propagated},
          {"pixels_retry_finished", pixels_retry_finished},
          {"pixels_normal_held", pixels_normal_held},
          {"retry_threshold_rms", retry_threshold_rms},
          {"noise_rms", noise_rms},
          {"half_vector_spacing_deg", half_vector_spacing_deg},
          {"min_sigma", min_sigma},
          {"prior_weight_applied", prior_weight},
          {"smoothing_weight_applied", smoothing_weight},
          {"cluster_sizes", cluster_sizes},  // not "clusters": fit.json has the options' count beside it
          {"material_f0", f0},               // not "f0": fit.json has the options' (a number or "material") beside it
          {"f0_fits", f0_fits},
          {"mean_iterations", mean_iterations},
          {"mean_observations", mean_observations},
          {"cluster_seconds", cluster_seconds},
          {"pixel_seconds", pixel_seconds},
          {"stage_seconds",
           {{"f0_search", stage_seconds.f0_search},
            {"noise_probe", stage_seconds.noise_probe},
            {"first_fits", stage_seconds.first_fits},
            {"propagation", stage_seconds.propagation},
            {"retries", stage_seconds.retries},
            {"smoothing", stage_seconds.smoothing},
            {"held_normals", stage_seconds.held_normals}}},
          {"threads", threads},
          {"ms_per_pixel_per_thread", ms_per_pixel_per_thread()}};
}

void StackFitSummary::Report(std::ostream& out) const {
  const std::string start = cluster_sizes.empty() ? "the initial maps" : std::to_string(cluster_sizes.size()) + " clusters";
  out << std::fixed << std::setprecision(2) << "fitted " << pixels_fitted << " of " << pixels << " px (" << pixels_skipped
      << " skipped: masked, unseen or too few usable observations; " << pixels_retried << " retried, relative RMS above "
      << retry_threshold_rms << ": " << pixels_propagated << " brought below it from a neighbour's fit, " << pixels_retry_finished
      << " refitted from a grid start; " << pixels_normal_held << " on a held photometric-stereo normal) from " << start
      << "; F0 " << f0 << "; " << mean_observations << " observations and " << mean_iterations << " iterations per pixel\n"
      << "time: clusters " << FormatDuration(cluster_seconds) << ", pixels " << FormatDuration(pixel_seconds) << " ("
      << ms_per_pixel_per_thread() << " ms per pixel per thread, " << threads << " threads; first fits " << std::setprecision(1)
      << stage_seconds.first_fits << " s, retries " << stage_seconds.propagation + stage_seconds.retries << " s";
  if (smoothing_weight > 0) out << ", smoothing " << stage_seconds.smoothing << " s";
  if (stage_seconds.held_normals > 0) out << ", unseen peaks " << stage_seconds.held_normals << " s";
  if (!f0_fits.empty()) out << ", F0 fitted on a sparse grid " << stage_seconds.f0_search << " s";
  out << ")\n";
}

Status StackFitOptions::Check() const {
  std::vector<std::string> problems;
  if (clusters < 1) problems.push_back("clusters must be ≥ 1");
  if (pixels_per_cluster_fit < 1) problems.push_back("pixels_per_cluster_fit must be ≥ 1");
  if (fixed_f0 && !(*fixed_f0 >= 0 && *fixed_f0 <= 1)) problems.push_back("fixed_f0 must be in [0, 1]");
  if (grid_starts < 1) problems.push_back("grid_starts must be ≥ 1");
  if (retry_grid_starts < 1) problems.push_back("retry_grid_starts must be ≥ 1");
  if (!(retry_above_rms > 0)) problems.push_back("retry_above_rms must be > 0");
  if (!(retry_above_noise_rms >= 1)) problems.push_back("retry_above_noise_rms must be ≥ 1");
  if (!(held_normal_max_rms_ratio >= 1)) problems.push_back("held_normal_max_rms_ratio must be ≥ 1");
  if (threads < 0) problems.push_back("threads must be ≥ 0");
  if (max_lights_per_observation < 0) problems.push_back("max_lights_per_observation must be ≥ 0");
  if (coarse_lights_per_observation < 0) problems.push_back("coarse_lights_per_observation must be ≥ 0");
  if (!(refine_function_tolerance >= 0 && refine_function_tolerance < 1)) {
    problems.push_back("refine_function_tolerance must be in [0, 1)");
  }
  if (retry_explore_lights < 0) problems.push_back("retry_explore_lights must be ≥ 0");
  if (!(prior_reference_noise_rms >= 0)) problems.push_back("prior_reference_noise_rms must be ≥ 0");
  if (min_sigma && !(*min_sigma >= kMinSigma && *min_sigma < kMaxSigma)) {
    problems.push_back("min_sigma must be in [kMinSigma, kMaxSigma)");
  }
  if (retry_neighbour_rounds < 0) problems.push_back("retry_neighbour_rounds must be ≥ 0");
  if (!(retry_neighbour_min_yield >= 0 && retry_neighbour_min_yield <= 1)) {
    problems.push_back("retry_neighbour_min_yield must be in [0, 1]");
  }
  if (retry_neighbour_starts < 0) problems.push_back("retry_neighbour_starts must be ≥ 0");
  if (left_out_view_selection_max_views < 0) problems.push_back("left_out_view_selection_max_views must be ≥ 0");
  if (!(retry_min_gain >= 0 && retry_min_gain < 1)) problems.push_back("retry_min_gain must be in [0, 1)");
  if (Status s = cluster_fit.Check(); !s.ok()) problems.push_back("cluster_fit: " + s.message());
  if (Status s = pixel_fit.Check(); !s.ok()) problems.push_back("pixel_fit: " + s.message());
  if (pixels.strip_quadrature) {
    if (Status s = pixels.strip_quadrature->Check(); !s.ok()) problems.push_back("pixels.strip_quadrature: " + s.message());
  }
  for (const auto& [name, p] : {std::pair{"prior", prior}, {"smoothing", smoothing}}) {
    RefineOptions refine;
    refine.prior = p;
    if (Status s = refine.Check(); !s.ok()) problems.push_back(std::string(name) + ": " + s.message());
  }
  return ProblemsStatus("StackFitOptions", problems);
}

PixelClusters ClusterPixels(const ObservationStack& stack, int clusters, uint64_t seed) {
  const std::vector<int> fittable = FittablePixels(stack);
  const cv::Mat features = AppearanceFeatures(stack, fittable);
  PixelClusters result;
  result.count = std::min(clusters, features.rows);
  result.labels.assign(stack.image.pixel_count(), -1);
  result.distances.assign(stack.image.pixel_count(), 0);
  for (int i : fittable) result.labels[i] = 0;
  if (result.count <= 1) return result;
  cv::Mat labels, centres;
  cv::theRNG().state = seed;  // k-means++ seeding draws from OpenCV's thread-local generator
  cv::kmeans(features, result.count, labels, cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-4), 3,
             cv::KMEANS_PP_CENTERS, centres);
  for (int r = 0; r < features.rows; ++r) {
    const int i = fittable[r];
    result.labels[i] = labels.at<int>(r);
    result.distances[i] = static_cast<float>(cv::norm(features.row(r), centres.row(result.labels[i])));
  }
  return result;
}

Result<StackFit> FitStack(const ObservationStack& stack, const StackFitOptions& given) {
  LOOM_RETURN_IF_ERROR(given.Check());
  const int width = stack.image.width();
  const int height = stack.image.height();
  const int pixel_count = width * height;
  StackPixelOptions frames = given.pixels;
  frames.keep_frames = given.solver == PixelSolver::kBatchRefiner && given.smoothing.weight > 0;  // two passes
  const StackPixels pixels(stack, frames);
  StackFit fit;
  StackFitSummary& summary = fit.summary;
  // The narrowest lobe the stack's sampling resolves (StackFitOptions::min_sigma), for every fit.
  StackFitOptions options = given;
  const double spacing = HalfVectorSpacing(pixels);
  summary.half_vector_spacing_deg = RadToDeg(spacing);
  // Dense: every lobe resolved. On a sparse stack a lower cost on the views given is no better
  // fit (the views left out say so), so no retry chases one there.
  const bool dense = RadToDeg(spacing) < kSparseSpacingDeg;
  const double resolved = dense ? kMinSigma : kMinSigmaPerSpacing * spacing;
  summary.min_sigma = given.min_sigma.value_or(std::clamp(resolved, kMinSigma, kMaxResolvedSigma));
  options.cluster_fit.min_sigma = options.pixel_fit.min_sigma = summary.min_sigma;
  summary.pixels = pixel_count;
  summary.threads = ThreadCount(options.threads);
  const auto report = [&](const char* stage, int done, int total) {
    if (options.progress) options.progress({stage, done, total});
  };

  const Clock::time_point cluster_start = Clock::now();
  PixelClusters clusters;
  NormalStarts normals;
  if (options.initial_maps) {
    const Image& initial = *options.initial_maps;
    if (initial.width() != width || initial.height() != height || !HasSvbrdfLayout(initial)) {
      return InvalidArgumentError("initial maps", std::to_string(initial.width()) + "x" + std::to_string(initial.height()) +
                                                      " px, not SVBRDF maps of the stack's " + std::to_string(width) + "x" +
                                                      std::to_string(height));
    }
    clusters.labels.assign(pixel_count, -1);
  } else {
    if (options.photometric_stereo_starts) normals = NormalStarts(LambertPixels(stack, {.threads = options.threads}));
    clusters = ClusterPixels(stack, options.clusters, options.seed);
    if (clusters.count == 0) {
      return FailedPreconditionError("stack", "no pixel has " + std::to_string(kNumWardParams) +
                                                  " or more seen observations: nothing to fit (is every pixel masked?)");
    }
    LOOM_RETURN_IF_ERROR(FitClusters(pixels, clusters, options, normals, report, summary));
  }
  summary.cluster_seconds = SecondsSince(cluster_start);

  const auto start_at = [&](int i, double f0) {
    WardParams<double> start = options.initial_maps      ? GetParams(*options.initial_maps, i % width, i / width)
                               : clusters.labels[i] >= 0 ? summary.cluster_params[clusters.labels[i]]
                                                         : NeutralStart();
    if (!start.n_s.allFinite()) start = NeutralStart();  // start maps with a masked pixel
    if (!options.initial_maps && clusters.labels[i] >= 0) {
      if (const std::optional<Eigen::Matrix3d> turn = normals.Turn(i)) {
        // The cluster's lobe on the pixel's own normal, with the pixel's own albedo.
        start = internal::TurnedBack(*turn, start);
        start.a_d = normals.Pixel(i)->albedo.cwiseMin(kMaxAlbedo);
      }
    }
    return f0 > 0 ? AtF0(start, f0) : start;  // keeps a_s·F0, the observable product
  };
  const bool refiner = options.solver == PixelSolver::kBatchRefiner;
  const Clock::time_point pixel_start = Clock::now();
  if (options.fixed_f0) {
    summary.f0 = *options.fixed_f0;
  } else {
    LOOM_ASSIGN_OR_RETURN(const MaterialF0 material, SearchF0(pixels, stack, start_at, options));
    summary.f0 = material.f0;
    summary.f0_fits = material.fits;
  }
  summary.stage_seconds.f0_search = SecondsSince(pixel_start);
  PixelFitOptions pixel_options = options.pixel_fit;
  pixel_options.fixed_f0 = summary.f0;
  const auto start_of = [&](int i) { return start_at(i, summary.f0); };
  const auto pixel_progress = [&](int done) { report("pixels", done, pixel_count); };
  std::vector<PixelOutcome> outcomes(pixel_count);
  RefineOptions refine = RefinerOptions(pixel_options, options);
  if (options.initial_maps) refine.prior = options.prior;
  StackFitSummary::StageSeconds& stage = summary.stage_seconds;
  Clock::time_point stage_start = Clock::now();
  const auto end_stage = [&stage_start](double& seconds) {
    seconds = SecondsSince(stage_start);
    stage_start = Clock::now();
  };
  RefinePrior smoothing = options.smoothing;
  if (refiner && (refine.prior.weight > 0 || smoothing.weight > 0) && options.prior_reference_noise_rms > 0) {
    LOOM_ASSIGN_OR_RETURN(const std::optional<double> noise_rms, ProbeNoiseRms(pixels, stack, start_of, refine));
    summary.noise_rms = noise_rms.value_or(options.prior_reference_noise_rms);
    const double ratio = summary.noise_rms / options.prior_reference_noise_rms;
    refine.prior.weight *= ratio * ratio;
    smoothing.weight = SmoothingWeightAt(smoothing.weight, ratio * ratio);
  }
  end_stage(stage.noise_probe);
  summary.prior_weight = refiner ? refine.prior.weight : 0;
  summary.smoothing_weight = refiner ? smoothing.weight : 0;
  if (refiner) {
    LOOM_ASSIGN_OR_RETURN(outcomes, RefineAll(pixels, stack, start_of, refine, pixel_progress, summary.pixels_nodes_replaced));
  } else {
    ParallelFor(
        pixel_count, options.threads,
        [&](int i) {
          const std::vector<PixelObservation> observations = pixels.Observations(i % width, i / width);
          outcomes[i] = FitFromStart(observations, start_of(i), pixel_options);
        },
        pixel_progress);
  }
  end_stage(stage.first_fits);
  summary.retry_threshold_rms = RetryThreshold(outcomes, options);
  std::vector<int> retry;
  for (int i = 0; options.retry_poor_fits && i < pixel_count; ++i) {
    if (outcomes[i].fitted &&
        (outcomes[i].rms > summary.retry_threshold_rms || (dense && WorseThanLambertian(outcomes[i], normals, i)))) {
      retry.push_back(i);
    }
  }
  summary.pixels_retried = static_cast<int>(retry.size());
  if (refiner) {
    LOOM_ASSIGN_OR_RETURN(
        retry, PropagateFromNeighbours(pixels, stack, std::move(retry), refine, options, summary.retry_threshold_rms, start_of,
                                       outcomes, summary.pixels_propagated));
  }
  end_stage(stage.propagation);
  const auto retry_progress = [&](int done) { report("retries", done, static_cast<int>(retry.size())); };
  if (refiner) {
    LOOM_ASSIGN_OR_RETURN(summary.pixels_retry_finished,
                          RefineRetries(pixels, stack, retry, refine, options, summary.retry_threshold_rms, start_of, normals,
                                        retry_progress, outcomes));
    end_stage(stage.retries);
    if (smoothing.weight > 0) {
      LOOM_RETURN_IF_ERROR(SmoothingPass(
          pixels, stack, refine, smoothing, options.initial_maps, [&](int done) { report("smoothing", done, pixel_count); },
          outcomes));
    }
    end_stage(stage.smoothing);
  } else {
    ParallelFor(
        static_cast<int>(retry.size()), options.threads,
        [&](int r) {
          const int i = retry[r];
          const std::vector<PixelObservation> observations = pixels.Observations(i % width, i / width);
          outcomes[i] = RetryFromGrid(observations, outcomes[i], pixel_options, options, normals.Turn(i),
                                      normals.empty() ? std::nullopt : normals.Pixel(i));
        },
        retry_progress);
    summary.pixels_retry_finished = static_cast<int>(retry.size());
    end_stage(stage.retries);
  }
  summary.pixels_normal_held = HoldNormalsOfUnseenPeaks(pixels, normals, pixel_options, options, outcomes);
  end_stage(stage.held_normals);
  summary.pixel_seconds = SecondsSince(pixel_start);
  fit.maps = MapsOf(outcomes, clusters, stack);
  Summarise(outcomes, summary);
  return fit;
}

std::string_view FitMethodName(FitMethod method) {
  switch (method) {
    case FitMethod::kCeres:
      return "ceres";
    case FitMethod::kRefine:
      return "refine";
    case FitMethod::kCnn:
      return "cnn";
    case FitMethod::kCnnCeres:
      return "cnn+ceres";
    case FitMethod::kCnnRefine:
      return "cnn+refine";
    case FitMethod::kLambert:
      return "lambert";
    case FitMethod::kLambertAlbedo:
      return "lambert-albedo";
  }
  return "?";
}

std::optional<FitMethod> ParseFitMethod(std::string_view name) {
  for (FitMethod method : kFitMethods) {
    if (FitMethodName(method) == name) return method;
  }
  return std::nullopt;
}

bool StartsFromCnn(FitMethod method) {
  return method == FitMethod::kCnn || method == FitMethod::kCnnCeres || method == FitMethod::kCnnRefine;
}

PixelSolver SolverOf(FitMethod method) {
  return method == FitMethod::kRefine || method == FitMethod::kCnnRefine ? PixelSolver::kBatchRefiner : PixelSolver::kCeres;
}

}  // namespace loom::fitting
