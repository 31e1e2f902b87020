#include "fitting/fit_directory.h"

#include <iomanip>
#include <ostream>
#include <utility>

#include "core/duration.h"
#include "core/file_io.h"
#include "core/observation_stack.h"
#include "core/output_directory.h"
#include "core/version.h"
#include "fitting/io/svbrdf_file.h"
#include "fitting/report/export.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

// The noise level (StackFitOptions::prior_reference_noise_rms) of the stack the prior's weight
// was picked on: fabric:1003 scanned and reconstructed on tac7-mini.
constexpr double kPriorReferenceNoiseRms = 0.16;

// Start maps checked against the stack they are to start: its grid and, where the file states
// one, its pixel size (maps of another crop or resolution would start every pixel from another
// pixel's lobe).
Result<Image> ReadStartMaps(const fs::path& path, const ObservationStack& stack) {
  LOOM_ASSIGN_OR_RETURN(SvbrdfFile start, ReadSvbrdf(path));
  LOOM_RETURN_IF_ERROR(
      CheckOnStackGrid(start, stack.image.width(), stack.image.height(), stack.pixel_mm, "--start " + path.string()));
  return std::move(start.maps);
}

Result<FitMethod> ChooseMethod(FitRequest& request, const ObservationStack& stack, std::ostream& notes) {
  if (request.method.empty()) {
    request.method = FitMethodName(RecommendedMethod(stack, request.model, !request.start.empty()));
    notes << "method " << request.method << " (the recommended one for this stack; --method chooses another)\n";
  }
  const std::optional<FitMethod> method = ParseFitMethod(request.method);
  if (!method) {
    return InvalidArgumentError("--method " + request.method,
                                "expected ceres, refine, cnn, cnn+ceres, cnn+refine, lambert or lambert-albedo");
  }
  return *method;
}

// The request's options with its F0, retries, σ floor, refine.json and start maps applied.
Status ApplyRequest(FitRequest& request, FitMethod method, const ObservationStack& stack, std::optional<Image>& start) {
  StackFitOptions& options = request.options;
  options.retry_poor_fits = !request.no_retries;
  if (request.min_sigma > 0) options.min_sigma = request.min_sigma;
  const bool refiner = method == FitMethod::kRefine || method == FitMethod::kCnnRefine;
  LOOM_ASSIGN_OR_RETURN(options.fixed_f0, ParseFixedF0(request.f0, "--f0"));
  LOOM_RETURN_IF_ERROR(ApplyRefineSettings(request.model, refiner, request.given, options));
  if (request.start.empty()) return Status::Ok();
  if (StartsFromCnn(method)) {
    return InvalidArgumentError("--start " + request.start.string(), "starts the ceres and refine methods; --method " +
                                                                         request.method + " starts from the CNN's maps");
  }
  LOOM_ASSIGN_OR_RETURN(start, ReadStartMaps(request.start, stack));
  options.initial_maps = &*start;
  options.refiner.prior.weight = 0;  // the prior's 1σ are the CNN's measured errors, not these maps'
  return Status::Ok();
}

}  // namespace

StackFitOptions DefaultFitOptions() {
  StackFitOptions options;
  options.refiner.prior.weight = 0.1;
  options.prior_reference_noise_rms = kPriorReferenceNoiseRms;
  return options;
}

Result<FitDirectory> FitToDirectory(FitRequest request, std::ostream& notes) {
  LOOM_ASSIGN_OR_RETURN(const ObservationStack stack, ReadObservationStack(request.stack));
  notes << "fitting " << request.stack.string() << ": " << stack.image.width() << "x" << stack.image.height() << " px, "
        << stack.observations.size() << " observations (" << stack.source << ")\n";
  if (request.model.empty()) request.model = request.models_dir / stack.rig;
  const bool recommended = request.method.empty();
  LOOM_ASSIGN_OR_RETURN(const FitMethod method, ChooseMethod(request, stack, notes));
  std::optional<Image> start;
  LOOM_RETURN_IF_ERROR(ApplyRequest(request, method, stack, start));
  if (request.cnn_device != CnnDevice::kCpu) {  // before the output, and never a silent fallback to refine
    if (const Status usable = CheckCnnDevice(request.cnn_device); !usable.ok()) {
      return FailedPreconditionError("--device cuda", usable.message());
    }
  }
  LOOM_ASSIGN_OR_RETURN(OutputDirectory out, OutputDirectory::Create(request.out, "--out"));
  FitDirectory result;
  if (recommended) {
    LOOM_ASSIGN_OR_RETURN(RecommendedFit chosen,
                          FitWithRecommendedMethod(stack, method, request.model, request.options, request.cnn_device));
    if (!chosen.fallback.empty()) notes << chosen.fallback << "\n";
    result.method = FitMethodName(chosen.method);
    result.fallback = std::move(chosen.fallback);
    result.fit = std::move(chosen.fit);
  } else {
    result.method = request.method;
    LOOM_ASSIGN_OR_RETURN(result.fit, FitWithMethod(stack, method, request.model, request.options, request.cnn_device));
  }
  result.summary = result.fit.ToJson();
  result.summary.update({{"method", result.method},
                         {"model", result.fit.cnn.empty() ? "" : request.model.string()},
                         {"start", request.start.string()},
                         {"stack", request.stack.string()},
                         {"loom_version", std::string(VersionWithCommit())}});
  LOOM_RETURN_IF_ERROR(
      WriteSvbrdf(out.partial(), result.fit.maps, {result.method, request.stack.string(), stack.rig, stack.pixel_mm}));
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(out.partial() / "fit.json", result.summary.dump(2) + "\n"));
  LOOM_RETURN_IF_ERROR(out.Commit());
  result.out = request.out;
  return result;
}

namespace {

// What the lights' re-estimate found (LightRefinement::ToJson) and whether the fit used it.
void ReportLightRefinement(const nlohmann::json& lights, std::ostream& out) {
  if (lights["lights"].empty()) {
    out << std::fixed << std::setprecision(3) << "lights as given: their normals span too little to re-estimate them (spread "
        << lights["normal_spread"].get<double>() << ")\n"
        << std::defaultfloat;
    return;
  }
  out << std::fixed << std::setprecision(2) << "lights re-estimated from the fit: turned "
      << lights["mean_turn_deg"].get<double>() << " deg on average (at most " << lights["max_turn_deg"].get<double>()
      << "), intensities spread " << 100 * lights["gain_spread"].get<double>() << " %; "
      << (lights["applied"].get<bool>() ? "fitted again under them (fit.json: light_refinement)"
                                        : "too little to refit: the lights as given")
      << "\n"
      << std::defaultfloat;
}

}  // namespace

void FitDirectory::Report(std::ostream& out) const {
  if (!fit.cnn.empty()) out << "CNN " << fit.cnn << ": " << FormatDuration(fit.cnn_seconds) << "\n";
  if (fit.summary) fit.summary->Report(out);
  if (!fit.lambert.is_null()) {
    out << "photometric stereo: fitted " << fit.lambert["pixels_fitted"] << " of " << fit.lambert["pixels"] << " px ("
        << fit.lambert["pixels_skipped"] << " skipped: masked, unseen or too few lit observations)\n";
  }
  if (!fit.view_selection.is_null()) {
    const nlohmann::json& v = fit.view_selection;
    out << "few views (" << v["views"] << "): each pixel kept the model that predicted views left out of its fit "
        << "better: GD10 " << v["pixels_gd10"] << " px, Lambertian " << v["pixels_lambert"]
        << " px (left-out views' relative L1: GD10 " << v["left_out_view_l1"]["gd10"] << ", Lambertian "
        << v["left_out_view_l1"]["lambert"] << ", chosen " << v["left_out_view_l1"]["chosen"] << ")\n";
  }
  if (!fit.light_refinement.is_null()) ReportLightRefinement(fit.light_refinement, out);
  if (const std::optional<std::string> warning = AlbedoBoundWarning(fit.maps)) out << "warning: " << *warning << "\n";
  out << "wrote " << (this->out / "svbrdf.exr").string() << ", previews and fit.json in " << this->out.string() << "\n";
}

}  // namespace loom::fitting
