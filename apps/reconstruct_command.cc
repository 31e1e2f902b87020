// loom reconstruct: a scan → the calibrated observation stack (stack.exr) + reconstruction.json.
#include <chrono>
#include <filesystem>
#include <iostream>
#include <map>

#include "apps/command.h"
#include "apps/progress.h"
#include "core/file_io.h"
#include "core/output_directory.h"
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
  const auto start = std::chrono::steady_clock::now();
  LOOM_ASSIGN_OR_RETURN(const reconstruction::ScanToReconstruct opened,
                        reconstruction::OpenScanToReconstruct(args.scan, args.calib, args.options));
  LOOM_ASSIGN_OR_RETURN(OutputDirectory out, OutputDirectory::Create(args.out, "--out"));
  std::map<std::string, ProgressBar> bars;
  const auto progress = [&](const reconstruction::ReconstructProgress& p) {
    const auto bar = bars.try_emplace(p.stage, "reconstruct: " + p.stage, args.quiet).first;
    bar->second.Update(p.done, p.total, p.stage == "heightmap" ? "steps" : "views");
  };
  LOOM_ASSIGN_OR_RETURN(const reconstruction::ScanReconstruction scanned, reconstruction::ReconstructScan(opened, progress));
  bars.clear();
  for (const std::string& note : scanned.notes) std::cerr << "note: " << note << "\n";
  const reconstruction::Reconstruction& result = scanned.reconstruction;
  LOOM_RETURN_IF_ERROR(WriteObservationStack(out.partial() / "stack.exr", result.stack));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(out.partial() / "reconstruction.json", scanned.ToJson(seconds).dump(2) + "\n"));
  LOOM_RETURN_IF_ERROR(out.Commit());
  const fs::path stack_path = fs::path(args.out) / "stack.exr";
  std::cout << "wrote " << stack_path.string() << ": " << result.stack.image.width() << "x" << result.stack.image.height()
            << " px at " << args.options.pixel_mm << " mm, " << result.stack.observations.size()
            << " observations; heightmap from " << result.heightmap_camera << " (" << result.heightmap_filled << " px filled), "
            << 100 * result.unseen_fraction << " % of samples unseen, " << FormatDuration(seconds) << "\n";
  return {};
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
  app.add_option("--calib", args.calib,
                 "Calibration directory (CAMERA.yaml files, from loom calibrate); default: the "
                 "scan's rig YAML, nominal");
  app.add_option("--size", args.options.width_px, "Stack size in pixels (square, centred on the turntable axis)")
      ->check(CLI::Range(1, 16384));
  app.add_option("--pixel-mm", args.options.pixel_mm, "Stack pixel size (mm)")->check(CLI::PositiveNumber);
  app.add_option("--normal-blur-mm", args.options.normal_blur_mm, "Blur of the heightmap for the geometric normals (mm)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--heightmap-camera", args.options.heightmap_camera,
                 "Camera that decodes the structured light "
                 "(default: the one looking most nearly down)");
  app.add_option("--threads", args.options.threads, "Worker threads (0: one per core)")->check(CLI::Range(0, 1024));
  app.add_flag("--quiet", args.quiet, "No progress output");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  args.options.height_px = args.options.width_px;
  return ExitCode(Reconstruct(args));
}

}  // namespace loom::apps
