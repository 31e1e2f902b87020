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
#include "fitting/solve/internal/normal_frame.h"
#include "fitting/solve/internal/stack_stages.h"
#include "fitting/solve/lambert_fit.h"

namespace loom::fitting {
namespace {

// The stages, each in its own file (internal/stack_stages.h).
using namespace internal;  // NOLINT(google-build-using-namespace)

using Clock = std::chrono::steady_clock;

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

}  // namespace

nlohmann::json StackFitOptions::ToJson() const {
  const bool refines = solver == PixelSolver::kBatchRefiner;
  return {{"solver", refines ? "batch refiner (" + RefinerInstructionSet() + ")" : "ceres"},
          {"clusters", clusters},
          {"photometric_stereo_starts", photometric_stereo_starts},
          {"hold_normals_of_unseen_peaks", hold_normals_of_unseen_peaks},
          {"held_normal_max_rms_ratio", held_normal_max_rms_ratio},
          {"left_out_view_selection_max_views", left_out_view_selection_max_views},
          {"light_refinement_rounds", light_refinement_rounds},
          {"light_refinement_max_pixels", light_refinement_max_pixels},
          {"f0", fixed_f0 ? nlohmann::json(*fixed_f0) : nlohmann::json("material")},
          {"retries", retry_poor_fits},
          {"retry_above", retry_above_noise_rms},
          {"neighbour_rounds", refines ? retry_neighbour_rounds : 0},
          {"prior_weight", refines ? refiner.prior.weight : 0},
          {"prior_reference_noise_rms", refines ? prior_reference_noise_rms : 0},
          {"smoothing_weight", refines ? smoothing.weight : 0},
          {"smoothing_specular_albedo", smoothing.specular_albedo},  // the pass's a_s scale
          {"strip_samples", refiner.max_lights_per_observation},
          {"strip_nodes", refines && pixels.strip_quadrature ? pixels.strip_quadrature->Nodes() : 0},
          {"coarse_samples", refiner.coarse_lights_per_observation},
          {"function_tolerance", refiner.function_tolerance}};
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
  if (refiner.fixed_f0) problems.push_back("refiner.fixed_f0 must be unset (fixed_f0 holds F0)");
  if (refiner.min_sigma != kMinSigma) problems.push_back("refiner.min_sigma must be left as it is (min_sigma sets it)");
  if (refiner.threads != 0) problems.push_back("refiner.threads must be 0 (threads sets it)");
  if (Status s = refiner.Check(); !s.ok()) problems.push_back("refiner: " + s.message());
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
  if (light_refinement_rounds < 0 || light_refinement_rounds > 10)
    problems.push_back("light_refinement_rounds must be in [0, 10]");
  if (light_refinement_max_pixels < 1) problems.push_back("light_refinement_max_pixels must be ≥ 1");
  if (!(retry_min_gain >= 0 && retry_min_gain < 1)) problems.push_back("retry_min_gain must be in [0, 1)");
  if (Status s = cluster_fit.Check(); !s.ok()) problems.push_back("cluster_fit: " + s.message());
  if (Status s = pixel_fit.Check(); !s.ok()) problems.push_back("pixel_fit: " + s.message());
  if (pixels.strip_quadrature) {
    if (Status s = pixels.strip_quadrature->Check(); !s.ok()) problems.push_back("pixels.strip_quadrature: " + s.message());
  }
  RefineOptions smoothed;  // the smoothing pass's prior, checked as the refiner checks its own
  smoothed.prior = smoothing;
  if (Status s = smoothed.Check(); !s.ok()) problems.push_back("smoothing: " + s.message());
  return ProblemsStatus("StackFitOptions", problems);
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
    LOOM_RETURN_IF_ERROR(FitClusters(
        pixels, clusters, options, normals, [&](int done) { report("clusters", done, clusters.count); }, summary));
  }
  summary.cluster_seconds = SecondsSince(cluster_start);

  const auto start_at = [&](int i, double f0) {
    WardParams<double> start = options.initial_maps      ? GetParams(*options.initial_maps, i % width, i / width)
                               : clusters.labels[i] >= 0 ? summary.cluster_params[clusters.labels[i]]
                                                         : NeutralStart();
    // Start maps with a masked pixel (NaN), or any parameter a solver cannot start from.
    if (!AllFinite(start)) start = NeutralStart();
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
  if (options.initial_maps) refine.prior = options.refiner.prior;
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
                                        dense, retry_progress, outcomes));
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
          outcomes[i] = RetryFromGrid(observations, outcomes[i], pixel_options, options, {normals.Turn(i), dense},
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

std::vector<std::string> FitMethodNames() {
  std::vector<std::string> names;
  for (FitMethod method : kFitMethods) names.emplace_back(FitMethodName(method));
  return names;
}

bool StartsFromCnn(FitMethod method) {
  return method == FitMethod::kCnn || method == FitMethod::kCnnCeres || method == FitMethod::kCnnRefine;
}

PixelSolver SolverOf(FitMethod method) {
  return method == FitMethod::kRefine || method == FitMethod::kCnnRefine ? PixelSolver::kBatchRefiner : PixelSolver::kCeres;
}

}  // namespace loom::fitting
