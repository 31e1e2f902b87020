// loom fit: an observation stack → SVBRDF maps (OpenEXR + PNG previews + fit.json).
#include <chrono>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <optional>

#include <nlohmann/json.hpp>

#include "apps/command.h"
#include "apps/progress.h"
#include "core/file_io.h"
#include "core/observation_stack.h"
#include "core/version.h"
#include "fitting/cnn.h"
#include "fitting/export.h"
#include "fitting/stack_fitter.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

fitting::StackFitOptions DefaultOptions() {
  fitting::StackFitOptions options;
  // Picked on a training fabric's reconstructed stack (fabric:1003; docs/benchmarks.md): every
  // parameter's NRMSE below the CNN's, re-render L1 within 1 % of CNN + Ceres.
  options.prior.weight = 0.1;
  return options;
}

struct FitArguments {
  std::string stack;
  std::string out;
  std::string method = "ceres";
  std::string model;  // empty: configs/models/<the stack's rig>
  std::string f0 = "1";
  bool no_retries = false;
  fitting::StackFitOptions options = DefaultOptions();
  bool quiet = false;
};

std::string SummaryJson(const nlohmann::json& fit, const FitArguments& args, double cnn_seconds, const Image& maps) {
  std::vector<std::string> uncertainty;
  for (const std::string& name : maps.channel_names()) {
    if (name.starts_with("unc.")) uncertainty.push_back(name);
  }
  nlohmann::json json = fit;
  json.update({{"method", args.method},
               {"model", args.model},
               {"cnn_seconds", cnn_seconds},
               {"stack", args.stack},
               {"uncertainty_channels", uncertainty},
               {"loom_version", std::string(VersionWithCommit())}});
  return json.dump(2) + "\n";
}

// The CNN's maps of the stack, with the model of --model or the rig's shipped one.
Result<Image> CnnMaps(FitArguments& args, const ObservationStack& stack) {
  if (args.model.empty()) args.model = std::string(LOOM_CONFIGS_DIR) + "/models/" + stack.rig;
  if (!fs::exists(fs::path(args.model) / "model.json")) {
    return NotFoundError(
        args.model, "no CNN model here (model.json) for rig '" + stack.rig + "': train one with loom train, or pass --model");
  }
  LOOM_ASSIGN_OR_RETURN(const fitting::Cnn cnn, fitting::Cnn::Load(args.model));
  std::cerr << "CNN " << args.model << " (" << cnn.info().architecture.input_channels << " input channels, width 1/"
            << cnn.info().architecture.width_divisor << ")\n";
  return cnn.PredictMaps(stack, args.options.threads);
}

Status WriteMaps(const FitArguments& args, const ObservationStack& stack, const Image& maps, const std::string& summary) {
  LOOM_RETURN_IF_ERROR(fitting::WriteSvbrdf(args.out, maps, {args.method, args.stack, stack.rig, stack.pixel_mm}));
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(fs::path(args.out) / "fit.json", summary));
  std::cout << "wrote " << (fs::path(args.out) / "svbrdf.exr").string() << ", previews and fit.json in " << args.out << "\n";
  return Status::Ok();
}

Status Fit(FitArguments args) {
  const std::optional<fitting::FitMethod> method = fitting::ParseFitMethod(args.method);
  if (!method) return InvalidArgumentError("--method " + args.method, "expected ceres, refine, cnn, cnn+ceres or cnn+refine");
  const bool with_cnn = fitting::StartsFromCnn(*method);
  LOOM_ASSIGN_OR_RETURN(const ObservationStack stack, ReadObservationStack(args.stack));
  std::cerr << "fitting " << args.stack << ": " << stack.image.width() << "x" << stack.image.height() << " px, "
            << stack.observations.size() << " observations (" << stack.source << ")\n";
  std::optional<Image> cnn_maps;
  double cnn_seconds = 0;
  if (with_cnn) {
    const auto start = std::chrono::steady_clock::now();
    LOOM_ASSIGN_OR_RETURN(cnn_maps, CnnMaps(args, stack));
    cnn_seconds = SecondsSince(start);
    std::cout << "CNN: " << stack.image.width() << "x" << stack.image.height() << " px in " << FormatDuration(cnn_seconds)
              << "\n";
    if (*method == fitting::FitMethod::kCnn) {
      return WriteMaps(args, stack, *cnn_maps,
                       SummaryJson({{"pixels", stack.image.pixel_count()}}, args, cnn_seconds, *cnn_maps));
    }
  }
  ProgressBar clusters("clusters", args.quiet);
  ProgressBar pixels("pixels  ", args.quiet);
  ProgressBar retries("retries ", args.quiet);
  ProgressBar smoothing("smoothing", args.quiet);
  fitting::StackFitOptions& options = args.options;
  options.retry_poor_fits = !args.no_retries;
  options.solver = fitting::SolverOf(*method);
  LOOM_ASSIGN_OR_RETURN(options.fixed_f0, fitting::ParseFixedF0(args.f0, "--f0"));
  options.progress = [&](const fitting::StackFitProgress& p) {
    ProgressBar& bar = p.stage == "clusters"  ? clusters
                       : p.stage == "pixels"  ? pixels
                       : p.stage == "retries" ? retries
                                              : smoothing;
    bar.Update(p.done, p.total, p.stage);
  };
  if (cnn_maps) options.initial_maps = &*cnn_maps;
  LOOM_ASSIGN_OR_RETURN(const fitting::StackFit fit, fitting::FitStack(stack, options));
  fit.summary.Report(std::cout);
  nlohmann::json summary = fit.summary.ToJson();
  summary.update(options.ToJson());
  return WriteMaps(args, stack, fit.maps, SummaryJson(summary, args, cnn_seconds, fit.maps));
}

}  // namespace

int RunFit(int argc, char** argv) {
  CLI::App app("Fit SVBRDF maps (GD10 anisotropic Ward) to an observation stack", "loom fit");
  AddCommonOptions(app);
  FitArguments args;
  app.add_option("stack", args.stack, "Observation stack (OpenEXR, from loom reconstruct or loom sim render --stack)")
      ->required();
  app.add_option("--out", args.out, "Output directory: svbrdf.exr, PNG previews, fit.json")->required();
  app.add_option("--method", args.method,
                 "ceres (clusters, then every pixel with Ceres), refine (clusters, then every pixel with the batched "
                 "refiner), cnn (the network alone), cnn+ceres (the CNN's maps start every pixel's Ceres fit) or "
                 "cnn+refine (the CNN's maps start the batched refiner: Ceres' cost, many pixels at once, with 1 sigma "
                 "uncertainty maps)");
  app.add_option("--prior-weight", args.options.prior.weight,
                 "cnn+refine: weight of the prior toward the CNN's maps (default 0.1; 0: none; 1: the CNN's "
                 "measured errors as its 1 sigma)")
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--smoothing-weight", args.options.smoothing.weight,
                 "refine methods: weight of a second pass's prior toward each pixel's 3x3 neighbourhood median (0: no "
                 "second pass)")
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--strip-samples", args.options.max_lights_per_observation,
                 "refine methods: light samples per linear-light observation, the stack's emitters merged along the "
                 "strip (0: all of them)")
      ->check(CLI::Range(0, 4096));
  app.add_option("--coarse-samples", args.options.coarse_lights_per_observation,
                 "refine methods: coarse to fine, each pixel first converged with its strips merged into this many "
                 "light samples, then finished with all of them (0: one pass)")
      ->check(CLI::Range(0, 4096));
  app.add_option("--model", args.model, "CNN model directory (default: configs/models/<the stack's rig>)");
  app.add_option("--clusters", args.options.clusters, "Appearance clusters that initialise the per-pixel fits")
      ->check(CLI::Range(1, 1000));
  app.add_option("--threads", args.options.threads, "Worker threads (0: one per core)")->check(CLI::Range(0, 1024));
  app.add_option("--f0", args.f0,
                 "F0 held for every pixel (default 1: a_s carries a_s*F0, the product the "
                 "observations fix), or 'material': one F0 fitted per material");
  app.add_option("--retry-above", args.options.retry_above_noise_rms,
                 "Fit a pixel again from grid-searched starts when its relative RMS exceeds this many times the "
                 "stack's noise level (the best-fitted tenth's RMS; default 2.5)")
      ->check(CLI::Range(1.0, 1e6));
  app.add_flag("--no-retries", args.no_retries,
               "Keep every pixel's first fit: no second fit from grid-searched starts where it fits poorly");
  app.add_flag("--quiet", args.quiet, "No progress output");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  if (Status status = Fit(args); !status.ok()) return ReportFailure(status);
  return kExitOk;
}

}  // namespace loom::apps
