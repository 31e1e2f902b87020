// loom fit: an observation stack → SVBRDF maps (OpenEXR + PNG previews + fit.json).
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>

#include "apps/command.h"
#include "core/progress_bar.h"
#include "fitting/fit_directory.h"
#include "fitting/method_fit.h"
#include "fitting/solve/refine_settings.h"
#include "fitting/solve/stack_fitter.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

struct FitArguments {
  fitting::FitRequest request;
  bool retries = false;
  bool quiet = false;
};

Status Fit(FitArguments args) {
  StageProgressBars bars("", args.quiet);
  args.request.options.progress = [&](const fitting::StackFitProgress& p) { bars.Update(p.stage, p.done, p.total, p.stage); };
  args.request.models_dir = fs::path(LOOM_CONFIGS_DIR) / "models";
  LOOM_ASSIGN_OR_RETURN(const fitting::FitDirectory fit, fitting::FitToDirectory(std::move(args.request), std::cerr));
  bars.Close();
  fit.Report(std::cout);
  return Status::Ok();
}

}  // namespace

int RunFit(int argc, char** argv) {
  CLI::App app("Fit SVBRDF maps (GD10 anisotropic Ward) to an observation stack", "loom fit");
  AddCommonOptions(app);
  FitArguments args;
  app.add_option("stack", args.request.stack, "Observation stack (OpenEXR, from loom reconstruct or loom sim render --stack)")
      ->required();
  app.add_option("--out", args.request.out, "Output directory: svbrdf.exr, PNG previews, fit.json")->required();
  app.add_option("--method", args.request.method,
                 "default: cnn+refine where the stack's rig has a model (configs/models/<rig>, or --model), ceres for "
                 "photographs from loom import, refine otherwise. ceres (clusters, then every pixel with Ceres), refine "
                 "(clusters, then every pixel with the batched "
                 "refiner), cnn (the network alone), cnn+ceres (the CNN's maps start every pixel's Ceres fit) or "
                 "cnn+refine (the CNN's maps start the batched refiner: Ceres' cost, many pixels at once, with 1 sigma "
                 "uncertainty maps), lambert (robust photometric stereo: a normal and an albedo per pixel, the "
                 "baseline) or lambert-albedo (an albedo per pixel on the geometric normal)");
  app.add_option("--start", args.request.start,
                 "ceres and refine: maps that start every pixel's fit instead of the clusters' fits, on the stack's "
                 "grid: an earlier fit's svbrdf.exr (to refit a stored capture after recalibrating, or to finish a "
                 "fit with another method), an AxF file, or a simulator's truth (the fit nearest the true maps)");
  app.add_option("--prior-weight", args.request.options.refiner.prior.weight,
                 "cnn+refine: weight of the prior toward the CNN's maps (default 0.1; 0: none; 1: the CNN's "
                 "measured errors as its 1 sigma)")
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--min-sigma", args.request.min_sigma,
                 "The narrowest lobe a fit may reach (default: half the angle between the stack's neighbouring "
                 "half-vectors, at least 0.001 and at most 0.2)")
      ->check(CLI::Range(0.001, 0.999));
  app.add_option("--left-out-views-max", args.request.options.left_out_view_selection_max_views,
                 "ceres and refine: on a stack of at most this many views (a photograph's colour channels are one), each "
                 "appearance cluster keeps the GD10 fit or the Lambertian one, whichever predicts views left out of its "
                 "fit better, at (views + 1) fits of each (0: never)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  app.add_flag("!--no-photometric-stereo-starts", args.request.options.photometric_stereo_starts,
               "Start every pixel from its cluster's lobe on the stack's geometric normal instead of on the pixel's "
               "normal by photometric stereo");
  app.add_option("--prior-noise", args.request.options.prior_reference_noise_rms,
                 "cnn+refine: the stack noise level (relative RMS of its best-fitted tenth) at which --prior-weight "
                 "holds; the weight scales with the square of the stack's own, so that exact data outweigh the CNN "
                 "(default 0.16, the level the weight was picked at; 0: the weight as given)")
      ->check(CLI::Range(0.0, 10.0));
  CLI::Option* smoothing_weight =
      app.add_option("--smoothing-weight", args.request.options.smoothing.weight,
                     "refine methods: weight of a second pass's prior toward each pixel's 5x5 neighbourhood's median "
                     "lobe (with cnn+refine, its anisotropy angle from the neighbours the CNN's maps put on the "
                     "pixel's yarn), scaled with the stack's noise as --prior-weight is (default: the model "
                     "directory's refine.json, 3 for tac7-mini; without one 0: no second pass)")
          ->check(CLI::Range(0.0, 1e6));
  app.add_option("--strip-samples", args.request.options.refiner.max_lights_per_observation,
                 "refine methods: light samples per linear-light observation, the stack's emitters merged along the "
                 "strip (0: all of them)")
      ->check(CLI::Range(0, 4096));
  app.add_option("--coarse-samples", args.request.options.refiner.coarse_lights_per_observation,
                 "refine methods: coarse to fine, each pixel first converged with its strips merged into this many "
                 "light samples, then finished with all of them (0: one pass)")
      ->check(CLI::Range(0, 4096));
  app.add_option_function<int>(
         "--strip-nodes",
         [&args](int nodes) {
           if (nodes > 0) args.request.options.pixels.strip_quadrature = fitting::StripQuadratureWithNodes(nodes);
         },
         "refine methods: the first fit integrates each linear light's strip by Gauss-Legendre quadrature with this "
         "many nodes, a fifth of them either side of the span of the pixel's specular lobe, instead of the stack's "
         "emitters (0: the emitters; 16 or 20: within 0.1 % of the continuous strip at the 99th percentile; "
         "fitting/model/strip_quadrature.h, docs/benchmarks.md)")
      ->check(CLI::Range(0, 127) & !CLI::Range(1, 4));
  CLI::Option* function_tolerance =
      app.add_option("--function-tolerance", args.request.options.refiner.function_tolerance,
                     "refine methods: a pixel's fit ends at an accepted step that changes its cost by less than this "
                     "fraction (default: the model directory's refine.json, 1e-3 for tac7-mini; without one 1e-4; "
                     "Ceres' is 1e-6; looser is faster: docs/benchmarks.md)")
          ->check(CLI::Range(0.0, 0.5));
  app.add_option("--model", args.request.model,
                 "Model directory: the CNN, and in refine.json the refiner's settings picked for its rig (default: "
                 "configs/models/<the stack's rig>)");
  app.add_option("--clusters", args.request.options.clusters, "Appearance clusters that initialise the per-pixel fits")
      ->check(CLI::Range(1, 1000));
  app.add_option("--threads", args.request.options.threads, "Worker threads (0: one per core)")->check(CLI::Range(0, 1024));
  app.add_option("--device", args.request.cnn_device,
                 "cnn methods: where the network runs, cpu or cuda (the first GPU; needs loom built against a CUDA "
                 "LibTorch: docs/gpu-training.md); the refiner runs on --threads either way")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, fitting::CnnDevice>{{"cpu", fitting::CnnDevice::kCpu}, {"cuda", fitting::CnnDevice::kCuda}}));
  CLI::Option* f0 =
      app.add_option("--f0", args.request.f0,
                     "F0 held for every pixel (default 1: a_s carries a_s*F0, the product the observations fix; for the refine "
                     "methods the model directory's refine.json may say otherwise: 'material' for tac7 and tac7-mini), or "
                     "'material': one F0 for the material, fitted jointly with a sparse grid of its pixels (fit.json: "
                     "material_f0, f0_fits)");
  app.add_option("--retry-above", args.request.options.retry_above_noise_rms,
                 "Fit a pixel again from grid-searched starts when its relative RMS exceeds this many times the "
                 "stack's noise level (the best-fitted tenth's RMS; default 2.5)")
      ->check(CLI::Range(1.0, 1e6));
  app.add_option("--neighbour-rounds", args.request.options.retry_neighbour_rounds,
                 "refine methods: rounds that fit a poor pixel again from its best-fitted neighbour's fit before "
                 "any grid search, while a trial of each round brings a quarter of its pixels below the retry "
                 "threshold (default 2; 0: grid search only)")
      ->check(CLI::Range(0, 100));
  app.add_option("--neighbour-starts", args.request.options.retry_neighbour_starts,
                 "refine methods: of a retried pixel's explored starts, how many are its best-fitted neighbours' fits "
                 "(default 1; the grid search gives the rest)")
      ->check(CLI::Range(0, 8));
  CLI::Option* retries = app.add_flag(
      "--retries", args.retries,
      "Retry poor fits from well-fitted neighbours and grid-searched starts (the default, but where the model "
      "directory's refine.json turns them off for the refine methods: tac7-mini's, whose smoothing pass restarts every pixel)");
  CLI::Option* no_retries =
      app.add_flag("--no-retries", args.request.no_retries,
                   "Keep every pixel's first fit: no second fit from grid-searched starts where it fits poorly");
  retries->excludes(no_retries);
  app.add_flag("--quiet", args.quiet, "No progress output");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  if (!args.request.method.empty() && !fitting::ParseFitMethod(args.request.method)) {  // a usage error, as CLI11's own are
    ExitCode(InvalidArgumentError("--method " + args.request.method,
                                  "expected ceres, refine, cnn, cnn+ceres, cnn+refine, lambert or lambert-albedo"));
    return kExitUsage;
  }
  args.request.given = {.smoothing_weight = smoothing_weight->count() > 0,
                        .retries = retries->count() + no_retries->count() > 0,
                        .function_tolerance = function_tolerance->count() > 0,
                        .f0 = f0->count() > 0};
  return ExitCode(Fit(args));
}

}  // namespace loom::apps
