#include "fitting/method_fit.h"

#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>

#include "fitting/cnn/cnn.h"
#include "fitting/light_refinement.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/solve/lambert_fit.h"
#include "fitting/view_selection.h"

namespace loom::fitting {

namespace {

// Maps of the stack's grid with every pixel skipped.
Image NoMaps(const ObservationStack& stack) {
  Image maps = MakeSvbrdfImage(stack.image.width(), stack.image.height(), /*with_height=*/false);
  for (int c = 0; c < kNumWardParams; ++c) {
    for (float& v : maps.channel(c)) v = NAN;
  }
  return maps;
}

// The GD10 fit or the Lambertian one per pixel, by views left out (view_selection.h); the
// summary is the GD10 fit's of every view, its pixel counts the chosen maps'.
Result<MethodFit> FitChoosingByLeftOutViews(const ObservationStack& stack, StackFitOptions options, MethodFit fit) {
  std::optional<StackFitSummary> summary;
  const auto progress = options.progress;
  options.progress = nullptr;                    // the inner fits' bars would repeat for every view
  options.hold_normals_of_unseen_peaks = false;  // on a phone's flash photographs it worsened left-out views
  const StackMapsFit gd10 = [&](const ObservationStack& s) -> Result<Image> {
    Result<StackFit> f = FitStack(s, options);
    // A view left out can leave every pixel too few observations for GD10 (a handful of views):
    // nothing is fitted there, and the selection counts that against GD10.
    if (!f.ok() && f.status().code() == StatusCode::kFailedPrecondition && &s != &stack) return NoMaps(s);
    if (!f.ok()) return f.status();
    if (&s == &stack) summary = f->summary;
    return std::move(f->maps);
  };
  // Where photometric stereo finds no normal, the albedo under the geometric one: a pixel that
  // chose the Lambertian model keeps it rather than a GD10 fit judged worse there.
  const StackMapsFit photometric_stereo = [&](const ObservationStack& s) -> Result<Image> {
    LOOM_ASSIGN_OR_RETURN(LambertFit f, FitLambert(s, {.geometric_normal_fallback = true, .threads = options.threads}));
    return std::move(f.maps);
  };
  const StackMapsFit geometric_normal = [&](const ObservationStack& s) -> Result<Image> {
    LOOM_ASSIGN_OR_RETURN(LambertFit f, FitLambert(s, {.fit_normal = false, .threads = options.threads}));
    const int region = f.maps.AddChannel(kFitClusterChannel);
    for (float& label : f.maps.channel(region)) label = 0;
    return std::move(f.maps);
  };
  // The Lambertian model is itself chosen by views left out, once for the whole stack (the
  // geometric normal's maps one region, fit.cluster 0): photometric stereo, the baseline, unless
  // the geometric normal predicts the views better by the rule that holds GD10. Under a flash,
  // whose lights all lie near the view, photometric stereo's normals can tilt to mimic a lobe and
  // predict other views worse than the sample's own normal; per pixel, eight views choose by
  // chance about as often as by merit (the real flash capture's fold 2 went 1.04× → 1.18×).
  nlohmann::json lambertian_choice;
  const StackMapsFit lambert = [&](const ObservationStack& s) -> Result<Image> {
    LOOM_ASSIGN_OR_RETURN(ViewSelection normals, SelectByLeftOutViews(s, geometric_normal, photometric_stereo));
    if (&s == &stack) {
      lambertian_choice = {{"pixels_photometric_stereo", normals.pixels_lambert},
                           {"pixels_geometric_normal", normals.pixels_gd10}};
    }
    return std::move(normals.maps);
  };
  if (progress) progress({"views left out", 0, 1});
  LOOM_ASSIGN_OR_RETURN(ViewSelection selection, SelectByLeftOutViews(stack, gd10, lambert));
  if (progress) progress({"views left out", 1, 1});
  fit.maps = std::move(selection.maps);
  fit.summary = std::move(summary);
  if (fit.summary) {  // the maps written: a pixel GD10 skipped may have the Lambertian fit
    fit.summary->pixels_fitted = selection.pixels_gd10 + selection.pixels_lambert;
    fit.summary->pixels_skipped = fit.summary->pixels - fit.summary->pixels_fitted;
  }
  fit.view_selection = selection.ToJson();
  fit.view_selection["lambertian"] = lambertian_choice;
  return fit;
}

// The pixels of the stack with any seen observation.
int SeenPixels(const ObservationStack& stack) {
  int seen = 0;
  for (int y = 0; y < stack.image.height(); ++y) {
    for (int x = 0; x < stack.image.width(); ++x) {
      for (size_t k = 0; k < stack.observations.size(); ++k) {
        if (std::isfinite(stack.image.at(ObservationStack::ObservationChannel(static_cast<int>(k)), y, x))) {
          ++seen;
          break;
        }
      }
    }
  }
  return seen;
}

// The stack fitted under its directional lights re-estimated (light_refinement.h): up to `rounds`
// of estimating them from the last fit's maps and fitting again, while the corrections are worth
// applying (each round's from the stack's own lights), then the whole stack fitted under the last
// ones. The rounds run on every n-th pixel where the stack has more pixels seen than
// options.light_refinement_max_pixels: a light's estimate needs thousands of pixels, not all of
// them, and each round is a fit (on a 256² sphere of 96 lights, half the time for the same
// angle). `report`: the corrections applied, or the first estimate where none was worth applying.
Result<StackFit> FitRefiningLights(const ObservationStack& stack, const StackFitOptions& options, nlohmann::json& report) {
  LOOM_RETURN_IF_ERROR(options.Check());  // light_refinement_max_pixels divides below
  const int stride =
      static_cast<int>(std::ceil(std::sqrt(SeenPixels(stack) / static_cast<double>(options.light_refinement_max_pixels))));
  const std::optional<ObservationStack> sparse = stride > 1 ? std::optional(EveryNthPixel(stack, stride)) : std::nullopt;
  const ObservationStack& rounds_stack = sparse ? *sparse : stack;
  LOOM_ASSIGN_OR_RETURN(StackFit fit, FitStack(rounds_stack, options));
  std::optional<LightRefinement> applied;
  for (int round = 0; round < options.light_refinement_rounds; ++round) {
    LOOM_ASSIGN_OR_RETURN(LightRefinement lights, EstimateLightCorrections(rounds_stack, fit.maps, options.threads));
    if (!lights.WorthApplying()) {
      if (round == 0) report = lights.ToJson();
      break;
    }
    report = lights.ToJson();
    LOOM_ASSIGN_OR_RETURN(fit, FitStack(WithCorrectedLights(rounds_stack, lights), options));
    applied = std::move(lights);
  }
  if (!sparse) return fit;
  report["every_nth_pixel"] = stride;
  return FitStack(applied ? WithCorrectedLights(stack, *applied) : stack, options);
}

}  // namespace

FitMethod RecommendedMethod(const ObservationStack& stack, const std::filesystem::path& model_dir, bool start_maps) {
  if (stack.rig.starts_with(kImportedRigPrefix)) return FitMethod::kCeres;
  if (!start_maps && std::filesystem::exists(model_dir / "model.json")) return FitMethod::kCnnRefine;
  return FitMethod::kRefine;
}

Result<MethodFit> FitWithMethod(const ObservationStack& stack, FitMethod method, const std::filesystem::path& model_dir,
                                StackFitOptions options, CnnDevice cnn_device) {
  MethodFit fit;
  if (method == FitMethod::kLambert || method == FitMethod::kLambertAlbedo) {
    LambertFitOptions lambert;
    lambert.threads = options.threads;
    lambert.fit_normal = method == FitMethod::kLambert;
    LOOM_ASSIGN_OR_RETURN(LambertFit lambert_fit, FitLambert(stack, lambert));
    fit.maps = std::move(lambert_fit.maps);
    fit.lambert = lambert_fit.ToJson();
    return fit;
  }
  if (StartsFromCnn(method)) {
    if (!std::filesystem::exists(model_dir / "model.json")) {
      return NotFoundError(model_dir.string(), "no CNN model here (model.json) for rig '" + stack.rig +
                                                   "': train one with loom train, or give another model directory");
    }
    const auto start = std::chrono::steady_clock::now();
    LOOM_ASSIGN_OR_RETURN(const Cnn cnn, Cnn::Load(model_dir));
    fit.cnn = model_dir.string() + " (" + std::to_string(cnn.info().architecture.input_channels) + " input channels, width 1/" +
              std::to_string(cnn.info().architecture.width_divisor) + ")";
    LOOM_ASSIGN_OR_RETURN(fit.maps, cnn.PredictMaps(stack, options.threads, cnn_device));
    fit.cnn_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (method == FitMethod::kCnn) return fit;
    options.initial_maps = &fit.maps;
  }
  options.solver = SolverOf(method);
  fit.settings = options.ToJson();
  const bool few_views = static_cast<int>(StackViews(stack).size()) <= options.left_out_view_selection_max_views;
  if (!options.initial_maps && few_views) return FitChoosingByLeftOutViews(stack, options, std::move(fit));
  const bool refine_lights = !options.initial_maps && options.light_refinement_rounds > 0 && HasOnlyDirectionalLights(stack);
  LOOM_ASSIGN_OR_RETURN(StackFit stack_fit,
                        refine_lights ? FitRefiningLights(stack, options, fit.light_refinement) : FitStack(stack, options));
  fit.maps = std::move(stack_fit.maps);
  fit.summary = std::move(stack_fit.summary);
  return fit;
}

nlohmann::json MethodFit::ToJson() const {
  nlohmann::json json = summary ? summary->ToJson() : nlohmann::json{{"pixels", maps.pixel_count()}};
  if (!lambert.is_null()) json.update(lambert);
  if (!view_selection.is_null()) json["left_out_view_selection"] = view_selection;
  if (!light_refinement.is_null()) json["light_refinement"] = light_refinement;
  if (summary) json.update(settings);
  std::vector<std::string> uncertainty;
  for (const std::string& name : maps.channel_names()) {
    if (name.starts_with("unc.")) uncertainty.push_back(name);
  }
  json.update({{"cnn_seconds", cnn_seconds}, {"uncertainty_channels", uncertainty}});
  return json;
}

Result<RecommendedFit> FitWithRecommendedMethod(const ObservationStack& stack, FitMethod method,
                                                const std::filesystem::path& model_dir, const StackFitOptions& options,
                                                CnnDevice cnn_device) {
  RecommendedFit recommended;
  recommended.method = method;
  Result<MethodFit> fitted = FitWithMethod(stack, recommended.method, model_dir, options, cnn_device);
  if (recommended.method == FitMethod::kCnnRefine && !fitted.ok() && fitted.status().code() == StatusCode::kFailedPrecondition) {
    recommended.fallback = "cnn+refine cannot fit this stack (" + fitted.status().ToString() + "): method refine";
    recommended.method = FitMethod::kRefine;
    LOOM_ASSIGN_OR_RETURN(recommended.fit, FitWithMethod(stack, recommended.method, model_dir, options));
    return recommended;
  }
  if (!fitted.ok()) return fitted.status();
  recommended.fit = *std::move(fitted);
  return recommended;
}

std::optional<std::string> AlbedoBoundWarning(const Image& maps) {
  int at_bound = 0, fitted = 0;
  for (int y = 0; y < maps.height(); ++y) {
    for (int x = 0; x < maps.width(); ++x) {
      if (IsSkippedPixel(maps, x, y)) continue;
      ++fitted;
      at_bound += (GetParams(maps, x, y).a_d.array() >= 0.999 * kMaxAlbedo).any();
    }
  }
  if (fitted == 0 || at_bound <= fitted / 100) return std::nullopt;
  std::ostringstream warning;
  warning << at_bound << " of " << fitted << " px reached the albedo bound (" << kMaxAlbedo
          << " in a_d): the stack's radiance scale is likely too high (loom import --scale, or its automatic scale)";
  return warning.str();
}

}  // namespace loom::fitting
