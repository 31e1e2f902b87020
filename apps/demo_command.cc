// loom demo: the main job on a simulated rig, end to end (demo/main_job.h), its scans run on the
// rig's sim backends.
#include <filesystem>
#include <iostream>

#include "apps/command.h"
#include "apps/config_paths.h"
#include "apps/scanning.h"
#include "demo/main_job.h"
#include "fitting/solve/stack_fitter.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

struct DemoArguments {
  demo::MainJobRequest request;
  std::string rig = "tac7-mini";
};

Status Demo(DemoArguments args) {
  args.request.rig = ResolveRigPath(args.rig);
  if (!fs::exists(args.request.rig)) {
    return NotFoundError("--rig " + args.rig, "no such file, nor configs/rig/" + args.rig + ".yaml");
  }
  args.request.preset_file = ResolvePresetPath(args.request.preset);
  args.request.models_dir = fs::path(LOOM_CONFIGS_DIR) / "models";
  LOOM_ASSIGN_OR_RETURN(const nlohmann::ordered_json summary, demo::RunMainJob(args.request, NewScan, std::cout, std::cerr));
  demo::PrintMainJobSummary(summary, std::cout);
  std::cout << "\nsummary: " << (args.request.out / "summary.json").string()
            << "\nreport:  " << summary["methods"][args.request.methods.back()]["report"].get<std::string>()
            << "\nglTF:    " << (args.request.out / "gltf" / "material.gltf").string() << "\n";
  return Status::Ok();
}

}  // namespace

int RunDemo(int argc, char** argv) {
  CLI::App app(
      "The main job on a simulated rig: calibration scan, calibrate, scan a procedural fabric, reconstruct, "
      "fit, evaluate against the ground truth, summarise",
      "loom demo");
  AddCommonOptions(app);
  DemoArguments args;
  demo::MainJobRequest& request = args.request;
  request.out = "loom-demo";
  app.add_option("--rig", args.rig, "Simulated rig: a name in configs/rig/ or a YAML file (default tac7-mini)");
  app.add_option("--object", request.object, "The material: fabric:SEED or fabric-out-of-model:SEED (default fabric:1)");
  app.add_option("--preset", request.preset, "Gloss preset of the material scan (default low)");
  app.add_option("--methods", request.methods, "Fit methods, in order, the last being the main result (default cnn cnn+refine)")
      ->delimiter(',')
      ->check(CLI::IsMember(fitting::FitMethodNames()));
  app.add_option("--size", request.size_px,
                 "Stack size in pixels (square, centred; default: reconstruct's); the scans read only that crop")
      ->check(CLI::Range(8, 8192));
  app.add_option("--crop-mm", request.crop_mm,
                 "Scan only a centred square crop of the sample this wide (loom scan --crop-mm; default: --size's)")
      ->check(CLI::Range(0.5, 1000.0));
  app.add_flag("!--no-calibration", request.calibrate,
               "No calibration scan: reconstruct with the rig YAML's geometry and radiometry");
  app.add_option("--out", request.out, "Directory to write, new or empty (default loom-demo)");
  app.add_flag("--quiet", request.quiet, "No progress bars");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  return ExitCode(Demo(args));
}

}  // namespace loom::apps
