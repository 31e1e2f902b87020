// What the whole-stack fit's stages share: starts, fits from them, the refiner's options, the maps.
#include "fitting/solve/internal/stack_stages.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/geometry.h"
#include "core/parallel.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/solve/internal/normal_frame.h"

namespace loom::fitting::internal {

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

// How finely the stack samples the half-vectors: over a sparse grid of pixels, the median over a
// pixel's observations of the angle (rad) from each half-vector to the nearest other one, and the
// median of that over the pixels. A strip's light samples count as one half-vector, its
// brightest's: the strip's other samples lie along it, so they resolve a lobe across the strip
// no finer than one.
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

// A photometric-stereo normal tilted further than this from the stack's normal has the retries
// also search around the stack's (GridFrames::also_stack_normal): half the 20° that a search
// reaches from the normal it is given.
constexpr double kStackNormalSearchTiltDeg = 10;

// Grid-searched starts (GridInitialParams, or the refiner's GridStarts through `search`) around
// the pixel's photometric-stereo normal where it has one: the search's normals lie within 20° of
// the normal it is given, and a curved surface tilts much further than that. With
// `also_stack_normal` the search runs around the stack's own normal too (where the two lie more
// than kStackNormalSearchTiltDeg apart) and the lowest-cost starts of both are kept: on a dense
// stack a highlight tilts a glossy flat fabric's photometric-stereo normal, and starts searched
// around it alone left a noise-free fabric's retried pixels in a wrong basin. Not on sparse
// stacks: on a phone's eight flash photographs the lower-cost start generalised worse
// (docs/benchmarks.md, "The per-pixel Ceres fit").
std::vector<WardParams<double>> GridStartsAround(
    const GridFrames& frames, const std::vector<PixelObservation>& observations,
    const std::function<std::vector<WardParams<double>>(const std::vector<PixelObservation>&)>& search) {
  if (!frames.turn) return search(observations);
  std::vector<PixelObservation> turned = observations;
  internal::TurnObservations(*frames.turn, turned);
  std::vector<WardParams<double>> starts = search(turned);
  for (WardParams<double>& start : starts) start = internal::TurnedBack(*frames.turn, start);
  // Tilted less than half the search's reach, the normal's search already covers the stack's.
  if (!frames.also_stack_normal || (*frames.turn)(2, 2) > std::cos(DegToRad(kStackNormalSearchTiltDeg))) return starts;
  const size_t count = starts.size();
  for (const WardParams<double>& start : search(observations)) starts.push_back(start);
  std::vector<std::pair<double, size_t>> ranked;
  for (size_t k = 0; k < starts.size(); ++k) ranked.push_back({RelativeRms(starts[k], observations), k});
  std::sort(ranked.begin(), ranked.end());
  std::vector<WardParams<double>> best;
  for (size_t k = 0; k < count && k < ranked.size(); ++k) best.push_back(starts[ranked[k].second]);
  return best;
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

std::vector<int> EmittersPerObservation(const ObservationStack& stack) {
  std::vector<int> emitters;
  for (const StackObservation& o : stack.observations) emitters.push_back(static_cast<int>(o.emitters.size()));
  return emitters;
}

RefineOptions RefinerOptions(const PixelFitOptions& fit, const StackFitOptions& options) {
  RefineOptions refine = options.refiner;
  refine.fixed_f0 = fit.fixed_f0;
  refine.min_sigma = fit.min_sigma;
  refine.threads = options.threads;
  refine.prior = {};  // toward initial maps only, where FitStack sets it
  return refine;
}

PixelOutcome OutcomeOf(const RefinedPixel& r) {
  PixelOutcome outcome{r.params, r.cost, r.rms, r.iterations, r.observations_used, r.fitted, std::nullopt};
  if (r.fitted) outcome.sigma = r.sigma;
  return outcome;
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

}  // namespace loom::fitting::internal
