// loom reconstruct: a scan → the calibrated observation stack (stack.exr) + reconstruction.json.
#include <filesystem>
#include <iostream>

#include "apps/command.h"
#include "core/progress_bar.h"
#include "reconstruction/scan_reconstruction.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

struct ReconstructArguments {
  std::string scan;
  std::string out;
  std::string calib;
  reconstruction::ReconstructOptions options;
  bool quiet = false;
};

Status Reconstruct(const ReconstructArguments& args) {
  StageProgressBars bars("reconstruct: ", args.quiet);
  const auto progress = [&](const reconstruction::ReconstructProgress& p) {
    bars.Update(p.stage, p.done, p.total, p.stage == "heightmap" ? "steps" : "views");
  };
  LOOM_ASSIGN_OR_RETURN(const reconstruction::ReconstructedDirectory written,
                        reconstruction::ReconstructToDirectory(args.scan, args.calib, args.options, args.out, progress));
  bars.Close();
  for (const std::string& note : written.scanned.notes) std::cerr << "note: " << note << "\n";
  written.Report(std::cout);
  return Status::Ok();
}

}  // namespace

int RunReconstruct(int argc, char** argv) {
  CLI::App app(
      "Reconstruct a material scan: structured-light heightmap, every HDR image projected onto it in the "
      "top-view frame → the observation stack that loom fit reads",
      "loom reconstruct");
  AddCommonOptions(app);
  ReconstructArguments args;
  app.add_option("scan", args.scan, "Scan directory (from loom scan)")->required();
  app.add_option("--out", args.out, "Output directory: stack.exr, reconstruction.json")->required();
  app.add_option("--calib", args.calib, "Calibration directory (from loom calibrate); default: the scan's rig YAML, nominal");
  app.add_option("--size", args.options.width_px, "Stack size in pixels (square, centred on the turntable axis)")
      ->check(CLI::Range(1, 16384));
  app.add_option("--pixel-mm", args.options.pixel_mm, "Stack pixel size (mm)")->check(CLI::PositiveNumber);
  app.add_option("--normal-blur-mm", args.options.normal_blur_mm, "Blur of the heightmap for the geometric normals (mm)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--heightmap-camera", args.options.heightmap_camera,
                 "Camera that decodes the structured light (default: the one looking most nearly down)");
  app.add_option("--threads", args.options.threads, "Worker threads (0: one per core)")->check(CLI::Range(0, 1024));
  app.add_flag("--quiet", args.quiet, "No progress output");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  args.options.height_px = args.options.width_px;
  return ExitCode(Reconstruct(args));
}

}  // namespace loom::apps
