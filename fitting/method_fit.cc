#include "fitting/method_fit.h"

#include <chrono>

#include "fitting/cnn.h"
#include "fitting/lambert_fit.h"

namespace loom::fitting {

Result<MethodFit> FitWithMethod(const ObservationStack& stack, FitMethod method, const std::filesystem::path& model_dir,
                                StackFitOptions options) {
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
    LOOM_ASSIGN_OR_RETURN(fit.maps, cnn.PredictMaps(stack, options.threads));
    fit.cnn_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (method == FitMethod::kCnn) return fit;
    options.initial_maps = &fit.maps;
  }
  options.solver = SolverOf(method);
  fit.settings = options.ToJson();
  LOOM_ASSIGN_OR_RETURN(StackFit stack_fit, FitStack(stack, options));
  fit.maps = std::move(stack_fit.maps);
  fit.summary = std::move(stack_fit.summary);
  return fit;
}

nlohmann::json MethodFit::ToJson() const {
  nlohmann::json json = summary ? summary->ToJson() : nlohmann::json{{"pixels", maps.pixel_count()}};
  if (!lambert.is_null()) json.update(lambert);
  if (summary) json.update(settings);
  std::vector<std::string> uncertainty;
  for (const std::string& name : maps.channel_names()) {
    if (name.starts_with("unc.")) uncertainty.push_back(name);
  }
  json.update({{"cnn_seconds", cnn_seconds}, {"uncertainty_channels", uncertainty}});
  return json;
}

}  // namespace loom::fitting
