#pragma once
// What `loom fit --method` does, in one call: for the cnn methods the CNN's maps of the stack
// (fitting/cnn/cnn.h), then, unless the method is the CNN alone, the whole-stack fit the method names
// (fitting/solve/stack_fitter.h) started from those maps or from the clusters' fits; for lambert, robust
// photometric stereo (fitting/solve/lambert_fit.h). ceres and refine on a stack of few views keep per pixel the
// GD10 fit or the Lambertian one, whichever predicts left-out views better (view_selection.h,
// StackFitOptions::left_out_view_selection_max_views); on a stack of more views lit by directional
// lights alone they re-estimate the lights from their first fit and fit again under them where
// that is worth it (light_refinement.h, StackFitOptions::light_refinement_rounds).

#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "core/image.h"
#include "core/observation_stack.h"
#include "fitting/cnn/cnn.h"
#include "fitting/solve/stack_fitter.h"

namespace loom::fitting {

struct MethodFit {
  Image maps;                              // fitting/model/svbrdf_maps.h's layout, plus the fit's channels
  std::optional<StackFitSummary> summary;  // none for the CNN alone and for lambert
  nlohmann::json lambert;                  // lambert's summary (LambertFit::ToJson), null for the others
  nlohmann::json view_selection;           // where pixels chose by left-out views (ViewSelection::ToJson), else null
  nlohmann::json light_refinement;         // the lights re-estimated (LightRefinement::ToJson), else null
  nlohmann::json settings;                 // the options the fit ran with (StackFitOptions::ToJson)
  std::string cnn;                         // the model used, described in a line ("" without one)
  double cnn_seconds = 0;

  // fit.json's content: the summary's fields and the settings, the CNN's time and the maps'
  // uncertainty channels.
  nlohmann::json ToJson() const;
};

// The method `loom fit` uses when none is asked for: cnn+refine where `model_dir` holds a model
// (model.json) and no start maps are given (the main job's method: the nearest to the truth and
// the fastest); ceres for photographs from another rig (`loom import`'s stacks: on a real flash
// capture its left-out views were 0.745× a Lambertian albedo's L1, refine's 0.776×); otherwise
// refine, which fits what ceres fits in a fraction of the time.
FitMethod RecommendedMethod(const ObservationStack& stack, const std::filesystem::path& model_dir, bool start_maps);

// `model_dir` holds the CNN (a loom train model directory) for the cnn methods; a directory
// without model.json is an error naming it. `options.solver` is set from the method, and for
// the cnn methods `options.initial_maps` (the CNN's maps); the other methods keep the caller's
// (a user's start maps, or none: the clusters' fits).
// `cnn_device`: where the CNN runs (the refiner runs on the CPU's threads either way).
Result<MethodFit> FitWithMethod(const ObservationStack& stack, FitMethod method, const std::filesystem::path& model_dir,
                                StackFitOptions options, CnnDevice cnn_device = CnnDevice::kCpu);

// The fit by `recommended` (RecommendedMethod's choice for the stack, made once by the caller;
// start maps are options.initial_maps). Where that is cnn+refine and the CNN cannot fit the
// stack (FailedPrecondition: most often a model that takes another preset's stacks), refine's fit
// instead, `fallback` saying why; a failure of the refiner's own is then refine's too, and
// reported as such.
struct RecommendedFit {
  FitMethod method = FitMethod::kRefine;  // the method that fitted
  MethodFit fit;
  std::string fallback;  // why cnn+refine fell back to refine; empty where it did not
};
Result<RecommendedFit> FitWithRecommendedMethod(const ObservationStack& stack, FitMethod recommended,
                                                const std::filesystem::path& model_dir, const StackFitOptions& options,
                                                CnnDevice cnn_device = CnnDevice::kCpu);

// Where more than 1 % of the fitted pixels have a diffuse albedo at the model's bound
// (kMaxAlbedo), the stack's radiance scale is likely too high (an imported capture's unknown
// exposure) and the fit bends its other parameters to make up for it: a warning saying so, with
// the remedy. None otherwise. (a_s at the bound is another matter: a narrow lobe whose peak falls
// between the observations.)
std::optional<std::string> AlbedoBoundWarning(const Image& maps);

}  // namespace loom::fitting
