#pragma once
// The Ceres fit of a whole observation stack, in the paper's reference pipeline's order:
//  0. each pixel's normal and albedo by robust photometric stereo (lambert_fit.h);
//  1. cluster the pixels by appearance (k-means on their log radiances, OpenCV);
//  2. fit each cluster on the pooled observations of its most typical pixels — many more
//     angular samples than one pixel has — each turned onto its own normal, from the best
//     grid-searched starts;
//  3. one F0 for the material: held fixed (default 1), or the clusters' size-weighted median,
//     as Pantora fits it — away from grazing angles only a_s·F0 is observable per pixel;
//  4. fit every pixel from its cluster's lobe on its own normal, with its own albedo (a_s
//     rescaled to keep a_s·F0), threaded;
//  5. a pixel left with a poor fit (its highlight is not where its start put it) is fitted
//     again — on the refiner first from well-fitted neighbours' fits (propagation), then from
//     grid-searched starts — and keeps the better.
// A pixel with fewer usable observations than the model's 13 parameters (masked, as an imported
// photograph's background is, unseen, or shadowed) is skipped: NaN in every map, counted.
// With initial maps (e.g. the CNN's), steps 1–3 are skipped: every pixel starts from its map.
// Steps 4 and 5 run on Ceres, one solve per pixel (the reference), or on the batched refiner
// (batch_refiner.h: the same cost, many pixels per vectorised evaluation), which also states
// each pixel's 1σ uncertainty in the unc.* channels and may add a prior toward the start maps.
// Each stage is a file of its own, FitStack runs them (internal/stack_stages.h).
//
// Output maps: fitting/model/svbrdf_maps.h's 13 channels and `height` (the stack's pos.Z), then
// fit.cluster (index; −1 when started from initial maps), fit.observations (used), fit.rms (RMS residual relative to the pixel's
// mean radiance); with the refiner also the 1σ uncertainties kUncertaintyChannels (NaN where
// the data leave a parameter undetermined or the pixel kept its start).

#include <array>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/image.h"
#include "core/observation_stack.h"
#include "fitting/model/stack_pixels.h"
#include "fitting/solve/batch_refiner.h"
#include "fitting/solve/pixel_fitter.h"

namespace loom::fitting {

struct StackFitProgress {
  std::string stage;  // "clusters", "pixels"
  int done = 0;
  int total = 0;
};

// What fits each pixel in steps 4 and 5.
enum class PixelSolver {
  kCeres,         // one Ceres solve per pixel (pixel_fitter.h)
  kBatchRefiner,  // batch_refiner.h
};

// The methods of `loom fit`: what starts each pixel (the clusters' fits, or the CNN's maps) and
// what fits it; kCnn keeps the CNN's maps as they are; kLambert is robust photometric stereo
// (lambert_fit.h), no GD10 lobe at all: the baseline; kLambertAlbedo the plainest one, an albedo
// per pixel on the geometric normal.
enum class FitMethod { kCeres, kRefine, kCnn, kCnnCeres, kCnnRefine, kLambert, kLambertAlbedo };
inline constexpr FitMethod kFitMethods[] = {FitMethod::kCeres,        FitMethod::kRefine,    FitMethod::kCnn,
                                            FitMethod::kCnnCeres,     FitMethod::kCnnRefine, FitMethod::kLambert,
                                            FitMethod::kLambertAlbedo};
// "ceres", "refine", "cnn", "cnn+ceres", "cnn+refine", "lambert", "lambert-albedo"
std::string_view FitMethodName(FitMethod method);
std::optional<FitMethod> ParseFitMethod(std::string_view name);
std::vector<std::string> FitMethodNames();  // every method's, in kFitMethods' order
bool StartsFromCnn(FitMethod method);
PixelSolver SolverOf(FitMethod method);  // for the methods that fit GD10 pixels

struct StackFitOptions {
  int clusters = 8;  // k-means clusters (1: one start for the whole material)
  // Without initial maps: each pixel starts from its cluster's lobe turned onto its own normal
  // by robust photometric stereo (lambert_fit.h), with its own albedo; the clusters pool their
  // pixels' observations turned onto those normals, and retries search around them. On a curved
  // surface the pixels of one cluster have different normals: pooled as they are, they made one
  // broad lobe from which every pixel's fit stayed in a wrong basin.
  bool photometric_stereo_starts = true;
  // With photometric-stereo starts: a pixel whose lobe peaks where no observation's half-vector
  // reaches (internal/peak_coverage.h), at its fitted normal or at its photometric-stereo one, is
  // refitted with the normal held at the photometric-stereo one. The lobe's flank fixes the normal
  // no better than the diffuse term does, and out of GD10's model worse: a highlight of another
  // shape tilts the fitted normal to put Ward's lobe where it lies. The held fit is kept unless its
  // relative RMS exceeds the free fit's by more than held_normal_max_rms_ratio: a broad lobe biases
  // photometric stereo itself, and there holding its normal multiplies the residual. A stack of few
  // views chooses by left-out views instead (method_fit.h), so it holds nothing.
  bool hold_normals_of_unseen_peaks = true;
  double held_normal_max_rms_ratio = 2;
  int pixels_per_cluster_fit = 12;  // most typical pixels pooled into a cluster's fit
  PixelFitOptions cluster_fit = {.max_iterations = 100, .multi_start = false, .fixed_f0 = std::nullopt};
  PixelFitOptions pixel_fit = {.max_iterations = 30, .multi_start = false, .fixed_f0 = std::nullopt};
  int grid_starts = 4;  // best grid-searched starts of a cluster's fit (GridInitialParams)
  // Step 5: a fit is poor above both a floor and a multiple of the stack's noise level (the
  // relative RMS of the best-fitted tenth of its pixels).
  bool retry_poor_fits = true;         // step 5 at all
  double retry_above_rms = 0.1;        // floor: decides on noise-free stacks
  double retry_above_noise_rms = 2.5;  // multiple of the noise level
  int retry_grid_starts = 2;           // best grid-searched starts of a retry
  // With the refiner: a retry's starts are explored with the strips merged into this many light
  // samples (0: all), and finished with all of them only where the best beats the first fit's
  // explored cost by this fraction.
  int retry_explore_lights = 8;
  double retry_min_gain = 0.01;
  // With the refiner: rounds of propagation before the grid search, each refitting a poor pixel
  // from its best-fitted neighbour (0: none); a round whose trial brings fewer than this
  // fraction of its pixels below the threshold ends the propagation.
  int retry_neighbour_rounds = 2;
  double retry_neighbour_min_yield = 0.25;
  // With the refiner: of a retry's explored starts, this many are its best-fitted neighbours'
  // fits where it has them (the grid search gives the rest).
  int retry_neighbour_starts = 1;
  // F0 of every pixel. Away from grazing angles only a_s·F0 is observable, and on tac7-mini's
  // geometry the cluster fits scatter F0 over [0, 1] (measured: 0.01 and 1 for one fabric whose
  // truth is 0.74), so by default it is held at 1 and a_s carries the product. nullopt: one F0
  // per material, as Pantora has: fitted jointly with a sparse grid of pixels (stack_fitter.cc,
  // SearchF0).
  std::optional<double> fixed_f0 = 1.0;
  StackPixelOptions pixels;
  PixelSolver solver = PixelSolver::kCeres;
  // The narrowest lobe any fit may reach. Unset: from how finely the stack samples the
  // half-vectors (the median angle from one observation's to the nearest other's, over a sparse
  // grid of pixels), half of it, at most 0.2, where that spacing exceeds 2° (kMinSigma below):
  // a lobe narrower than the sampling is not resolved, and a free fit there puts a highlight into
  // one view and predicts the others badly. tac7 and tac7-mini space their half-vectors
  // 0.6–0.7° apart, a phone's few flash photographs 5–7°.
  std::optional<double> min_sigma;
  // For `loom fit --method ceres | refine` without start maps (FitWithMethod, method_fit.h): a
  // stack of at most this many views (view_selection.h: a photograph's colour channels are one)
  // has each pixel keep the GD10 fit or the Lambertian one, whichever predicts views left out of
  // it better. 0: never. Costs (views + 1) fits of each.
  int left_out_view_selection_max_views = 16;
  // For `loom fit --method ceres | refine` without start maps on a stack lit by directional
  // lights alone (FitWithMethod; fitting/light_refinement.h): this many rounds of re-estimating
  // every light's direction and intensities from the fitted maps and fitting again. 0: the
  // stack's lights as they are.
  int light_refinement_rounds = 2;
  // Those rounds fit every n-th pixel of each row and column where the stack has more pixels seen
  // than this (a light's estimate needs thousands, not all), then the whole stack once.
  int light_refinement_max_pixels = 16384;
  // > 0: refiner.prior.weight holds at a stack whose noise level (the relative RMS of the best-fitted
  // tenth of a sparse grid of pixels fitted without the prior) is this, and scales with the
  // square of the stack's own: the data term is a sum of squared relative residuals, not of
  // residuals in units of their noise, so a fixed weight would weigh a noise-free stack's exact
  // data as little as a noisy one's and bias its fit toward the CNN. 0: the weight as it is.
  double prior_reference_noise_rms = 0;
  // With the refiner: a second pass with a prior toward each pixel's 5 × 5 neighbourhood's
  // median lobe (a_s, σ, α; the pixel's own normal and a_d, which its data pin down), started
  // there (weight 0: no second pass); α from the neighbours that initial_maps, where given, put
  // on the pixel's yarn (fitting/solve/internal/neighbour_lobes.h). Where a pixel's own data pin a parameter down the data
  // win; where they leave it loose (a highlight between observations, α of a nearly isotropic
  // lobe) the neighbours decide, which removes the speckle a free per-pixel fit leaves. With
  // prior_reference_noise_rms > 0 the weight follows the stack's noise as the CNN prior's does.
  RefinePrior smoothing;
  // With the refiner (solver kBatchRefiner): how it fits each pixel (batch_refiner.h), and with
  // initial maps the prior toward them (in step 5 too, from grid starts). Its fixed_f0, min_sigma
  // and threads are this fit's own (fixed_f0 or the material's F0, min_sigma, threads): Check()
  // refuses them set here. Its function_tolerance, the relative cost change of an accepted step
  // that ends a pixel's fit, is 1e-4 rather than Ceres' 1e-6: a step that lowers the cost by 1e-4
  // of itself lowers χ² by about 1e-4 × observations (0.02–0.08 on tac7 stacks), far below a 1σ
  // change of any parameter, and the main job's fits end 22 % sooner at the same maps
  // (docs/benchmarks.md).
  RefineOptions refiner = [] {
    RefineOptions refiner;
    refiner.function_tolerance = 1e-4;
    return refiner;
  }();
  // Starts of the per-pixel fits, when given: SVBRDF maps on the stack's grid (the CNN's, for
  // cnn+ceres, or a user's: loom fit --start). No clusters are formed; with fixed_f0 unset the
  // material's F0 is fitted from the maps' lobes (SearchF0). Not owned; must outlive FitStack.
  const Image* initial_maps = nullptr;
  int threads = 0;                                        // 0: one per core
  uint64_t seed = 1;                                      // k-means initialisation
  std::function<void(const StackFitProgress&)> progress;  // on the calling thread
  Status Check() const;                                   // every problem, naming the field
  nlohmann::json ToJson() const;                          // the settings a user chooses (fit.json)
};

// F0 as a user states it: a number in [0, 1] held for every pixel, or "material" (nullopt: one
// F0 fitted per material). `what` names the option in errors.
Result<std::optional<double>> ParseFixedF0(const std::string& text, const std::string& what);

struct StackFitSummary {
  int pixels = 0;
  int pixels_fitted = 0;
  int pixels_skipped = 0;         // not fitted (masked, unseen, too few usable observations): NaN maps
  int pixels_retried = 0;         // redone from grid starts
  int pixels_propagated = 0;      // of those, brought below the threshold from a neighbour's fit
  int pixels_retry_finished = 0;  // of those, fitted from a grid start with every light sample
                                  // (the refiner explores with fewer and finishes only the
                                  // pixels where a grid start wins; Ceres finishes all)
  // First fits refined again because their lobe left the strip span their nodes were placed for
  // (StackPixelOptions::strip_quadrature).
  int pixels_nodes_replaced = 0;
  // Fits refitted on the pixel's photometric-stereo normal, held, because no observation sees
  // where their lobe peaks (internal/peak_coverage.h).
  int pixels_normal_held = 0;
  double retry_threshold_rms = 0;      // relative RMS above which they were
  double noise_rms = 0;                // the stack's, where the prior's weight follows it
  double half_vector_spacing_deg = 0;  // how finely the stack samples the half-vectors (HalfVectorSpacing)
  double min_sigma = 0;                // the narrowest lobe the fits could reach
  double prior_weight = 0;             // the prior's weight as applied
  double smoothing_weight = 0;         // the smoothing prior's, as applied (0: no smoothing pass)
  std::vector<WardParams<double>> cluster_params;
  std::vector<int> cluster_sizes;
  double f0 = 0;  // the material's
  // With fixed_f0 unset: the sparse grid's joint fits, each (F0 started from, F0 reached, cost,
  // iterations).
  std::vector<std::array<double, 4>> f0_fits;
  double mean_iterations = 0;    // per pixel fit
  double mean_observations = 0;  // usable per pixel
  double cluster_seconds = 0;
  double pixel_seconds = 0;
  // pixel_seconds by stage (the refiner's; Ceres reports first fits and retries only).
  struct StageSeconds {
    double f0_search = 0;    // with fixed_f0 unset: the sparse grid's fits
    double noise_probe = 0;  // the sparse fit that weighs the prior
    double first_fits = 0;
    double propagation = 0;
    double retries = 0;  // grid search, exploration, refits
    double smoothing = 0;
    double held_normals = 0;  // which peaks no view sees, and those pixels refitted
  } stage_seconds;
  int threads = 0;
  double ms_per_pixel_per_thread() const { return pixels ? 1e3 * pixel_seconds * threads / pixels : 0; }

  nlohmann::json ToJson() const;
  // Two lines for the operator: what was fitted from what, and the time it took.
  void Report(std::ostream& out) const;
};

struct StackFit {
  Image maps;
  StackFitSummary summary;
};

inline constexpr const char* kFitClusterChannel = "fit.cluster";
inline constexpr const char* kFitObservationsChannel = "fit.observations";
inline constexpr const char* kFitRmsChannel = "fit.rms";
// 1σ of the normal's angle (degrees), a_d, a_s, σx, σy and α (degrees).
inline constexpr std::array<const char*, 10> kUncertaintyChannels = {"unc.normal_deg", "unc.a_d.R",    "unc.a_d.G", "unc.a_d.B",
                                                                     "unc.a_s.R",      "unc.a_s.G",    "unc.a_s.B", "unc.sigma_x",
                                                                     "unc.sigma_y",    "unc.alpha_deg"};

Result<StackFit> FitStack(const ObservationStack& stack, const StackFitOptions& options = {});

// The appearance clusters: k-means on each pixel's log radiances (an unseen value takes that
// observation's mean over the stack). Row-major per pixel: its cluster and its distance to the
// cluster's centre (small = typical); −1 for a pixel with fewer than 13 seen observations, which
// no cluster takes (`count` 0 when none has them).
struct PixelClusters {
  int count = 0;
  std::vector<int> labels;
  std::vector<float> distances;
};
PixelClusters ClusterPixels(const ObservationStack& stack, int clusters, uint64_t seed);

}  // namespace loom::fitting
