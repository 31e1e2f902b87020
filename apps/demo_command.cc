// loom demo: the main job on a simulated rig, end to end (demo/main_job.h), its scans run on the
// rig's sim backends.
#include <filesystem>
#include <iostream>

#include "apps/command.h"
#include "apps/config_paths.h"
#include "apps/scanning.h"
#include "demo/main_job.h"
#include "fitting/method_fit.h"
#include "reconstruction/scan_reconstruction.h"

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

std::vector<std::string> FitMethodNames() {
  std::vector<std::string> names;
  for (fitting::FitMethod method : fitting::kFitMethods) names.emplace_back(fitting::FitMethodName(method));
  return names;
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
      ->check(CLI::IsMember(FitMethodNames()));
  app.add_option("--size", request.size_px,
                 "Stack size in pixels (square, centred; default: reconstruct's); the scans then read only that crop "
                 "(--crop-mm of the size at reconstruct's pixel size) unless --crop-mm says otherwise")
      ->check(CLI::Range(8, 8192));
  app.add_option("--crop-mm", request.crop_mm,
                 "Scan only a centred square crop of the sample this wide, each camera reading the window that sees it "
                 "(as loom scan --crop-mm; for rigs with large sensors, e.g. tac7 with --size 64 and 12.8); the "
                 "calibration scan then reads each calibration object through its windows (loom scan --object-windows)")
      ->check(CLI::Range(0.5, 1000.0));
  app.add_flag("!--no-calibration", request.calibrate,
               "No calibration scan: reconstruct with the rig YAML's geometry and radiometry (on a simulated rig without "
               "as_built: that is what it is)");
  app.add_option("--out", request.out, "Directory to write, new or empty (default loom-demo)");
  app.add_flag("--quiet", request.quiet, "No progress bars");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  // A demo that reconstructs a crop scans only that crop: on tac7's 2048 × 1536 sensors a whole
  // material scan takes hours here, the 12.8 mm that --size 64 reconstructs a few minutes.
  if (request.crop_mm == 0 && request.size_px > 0)
    request.crop_mm = request.size_px * reconstruction::ReconstructOptions{}.pixel_mm;
  return ExitCode(Demo(args));
}

}  // namespace loom::apps
