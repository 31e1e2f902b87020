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
                 "photographs from loom import, refine otherwise. ceres or refine (clusters, then every pixel by Ceres "
                 "or by the batched refiner), cnn (the network alone), cnn+ceres or cnn+refine (the CNN's maps start "
                 "each pixel's fit), lambert (robust photometric stereo, the baseline) or lambert-albedo (an albedo per "
                 "pixel on the geometric normal)")
      ->check(CLI::IsMember(fitting::FitMethodNames()));
  app.add_option("--start", args.request.start,
                 "ceres and refine: maps on the stack's grid that start every pixel's fit instead of the clusters' "
                 "fits: an earlier fit's svbrdf.exr (e.g. to refit after recalibrating), an AxF file, or a truth");
  app.add_option("--prior-weight", args.request.options.refiner.prior.weight,
                 "cnn+refine: weight of the prior toward the CNN's maps (default 0.1; 0: none)")
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--min-sigma", args.request.min_sigma,
                 "The narrowest lobe a fit may reach (default: half the stack's half-vector spacing, 0.001 to 0.2)")
      ->check(CLI::Range(0.001, 0.999));
  app.add_option("--left-out-views-max", args.request.options.left_out_view_selection_max_views,
                 "ceres and refine: on a stack of at most this many views, each appearance cluster keeps the GD10 or the "
                 "Lambertian fit, whichever predicts views left out of its fit better (0: never)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  app.add_option("--light-rounds", args.request.options.light_refinement_rounds,
                 "ceres and refine on a stack lit by directional lights alone (loom import's ps and lp): rounds of "
                 "re-estimating each light's direction and intensities from the fitted maps and fitting again (0: the "
                 "stack's lights as they are)")
      ->capture_default_str()
      ->check(CLI::Range(0, 10));
  app.add_flag("!--no-photometric-stereo-starts", args.request.options.photometric_stereo_starts,
               "Start every pixel on the geometric normal instead of its photometric-stereo normal");
  app.add_option("--prior-noise", args.request.options.prior_reference_noise_rms,
                 "cnn+refine: the stack noise level at which --prior-weight holds as given; it scales with the square "
                 "of the stack's own (default 0.16; 0: as given)")
      ->check(CLI::Range(0.0, 10.0));
  CLI::Option* smoothing_weight =
      app.add_option("--smoothing-weight", args.request.options.smoothing.weight,
                     "refine methods: weight of a second pass's prior toward each pixel's 5x5 neighbourhood's median "
                     "lobe (default: the model directory's refine.json; without one 0: no second pass)")
          ->check(CLI::Range(0.0, 1e6));
  app.add_option("--strip-samples", args.request.options.refiner.max_lights_per_observation,
                 "refine methods: light samples per linear-light observation (0: every emitter)")
      ->check(CLI::Range(0, 4096));
  app.add_option("--coarse-samples", args.request.options.refiner.coarse_lights_per_observation,
                 "refine methods: converge each pixel first with this many samples per strip (0: one pass)")
      ->check(CLI::Range(0, 4096));
  app.add_option_function<int>(
         "--strip-nodes",
         [&args](int nodes) {
           if (nodes > 0) args.request.options.pixels.strip_quadrature = fitting::StripQuadratureWithNodes(nodes);
         },
         "refine methods: the first fit integrates each linear light's strip by Gauss-Legendre quadrature with this "
         "many nodes around the pixel's lobe instead of the stack's emitters (0: the emitters; 16 or 20: within 0.1 %)")
      ->check(CLI::Range(0, 127) & !CLI::Range(1, 4));
  CLI::Option* function_tolerance =
      app.add_option("--function-tolerance", args.request.options.refiner.function_tolerance,
                     "refine methods: a pixel's fit ends at a step that changes its cost by less than this fraction "
                     "(default: the model directory's refine.json; without one 1e-4)")
          ->check(CLI::Range(0.0, 0.5));
  app.add_option("--model", args.request.model,
                 "Model directory: the CNN and its refine.json (default: configs/models/<the stack's rig>)");
  app.add_option("--clusters", args.request.options.clusters, "Appearance clusters that initialise the per-pixel fits")
      ->check(CLI::Range(1, 1000));
  app.add_option("--threads", args.request.options.threads, "Worker threads (0: one per core)")->check(CLI::Range(0, 1024));
  app.add_option("--device", args.request.cnn_device,
                 "cnn methods: where the network runs, cpu or cuda (a CUDA LibTorch build); the refiner runs on the CPU")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, fitting::CnnDevice>{{"cpu", fitting::CnnDevice::kCpu}, {"cuda", fitting::CnnDevice::kCuda}}));
  CLI::Option* f0 =
      app.add_option("--f0", args.request.f0,
                     "F0 held for every pixel (default 1, or the model directory's refine.json's), or 'material': one F0 "
                     "for the material, fitted jointly over a sparse grid of its pixels");
  app.add_option("--retry-above", args.request.options.retry_above_noise_rms,
                 "Fit a pixel again from grid-searched starts when its relative RMS exceeds this many times the "
                 "stack's noise level (default 2.5)")
      ->check(CLI::Range(1.0, 1e6));
  app.add_option("--neighbour-rounds", args.request.options.retry_neighbour_rounds,
                 "refine methods: rounds that refit poor pixels from their best-fitted neighbours before any grid "
                 "search (default 2; 0: grid search only)")
      ->check(CLI::Range(0, 100));
  app.add_option("--neighbour-starts", args.request.options.retry_neighbour_starts,
                 "refine methods: how many of a retried pixel's starts are its neighbours' fits (default 1)")
      ->check(CLI::Range(0, 8));
  CLI::Option* retries =
      app.add_flag("--retries", args.retries,
                   "Retry poor fits from neighbours and grid-searched starts (the default unless refine.json says otherwise)");
  CLI::Option* no_retries = app.add_flag("--no-retries", args.request.no_retries, "Keep every pixel's first fit");
  retries->excludes(no_retries);
  app.add_flag("--quiet", args.quiet, "No progress output");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  args.request.given = {.smoothing_weight = smoothing_weight->count() > 0,
                        .retries = retries->count() + no_retries->count() > 0,
                        .function_tolerance = function_tolerance->count() > 0,
                        .f0 = f0->count() > 0};
  return ExitCode(Fit(args));
}

}  // namespace loom::apps
