#include "fitting/method_fit.h"

#include <chrono>
#include <cmath>
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
// summary is the GD10 fit's of every view.
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
  const StackMapsFit lambert = [&](const ObservationStack& s) -> Result<Image> {
    LOOM_ASSIGN_OR_RETURN(LambertFit f, FitLambert(s, {.threads = options.threads}));
    return std::move(f.maps);
  };
  if (progress) progress({"views left out", 0, 1});
  LOOM_ASSIGN_OR_RETURN(ViewSelection selection, SelectByLeftOutViews(stack, gd10, lambert));
  if (progress) progress({"views left out", 1, 1});
  fit.maps = std::move(selection.maps);
  fit.summary = std::move(summary);
  fit.view_selection = selection.ToJson();
  return fit;
}

// Up to `rounds` of the stack's directional lights re-estimated from the last fit's maps and the
// stack fitted again under them (light_refinement.h), while the corrections are worth applying;
// each round's corrections from the stack's own lights. The maps are the last fit's; `report` the
// corrections applied last, or the first estimate where none was worth applying.
Result<StackFit> FitRefiningLights(const ObservationStack& stack, const StackFitOptions& options, StackFit fit,
                                   nlohmann::json& report) {
  for (int round = 0; round < options.light_refinement_rounds; ++round) {
    LOOM_ASSIGN_OR_RETURN(const LightRefinement lights, EstimateLightCorrections(stack, fit.maps, options.threads));
    if (!lights.WorthApplying()) {
      if (round == 0) report = lights.ToJson();
      break;
    }
    report = lights.ToJson();
    LOOM_ASSIGN_OR_RETURN(fit, FitStack(WithCorrectedLights(stack, lights), options));
  }
  return fit;
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
  LOOM_ASSIGN_OR_RETURN(StackFit stack_fit, FitStack(stack, options));
  if (!options.initial_maps && HasOnlyDirectionalLights(stack)) {
    LOOM_ASSIGN_OR_RETURN(stack_fit, FitRefiningLights(stack, options, std::move(stack_fit), fit.light_refinement));
  }
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
  LOOM_ASSIGN_OR_RETURN(recommended.fit, std::move(fitted));
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
