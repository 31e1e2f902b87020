// loom scan: run a measurement plan on a rig into a crash-safe scan directory, or resume one.
#include <iostream>

#include "acquisition/crop_windows.h"
#include "acquisition/sequencer.h"
#include "apps/command.h"
#include "apps/progress.h"
#include "apps/rig_loader.h"
#include "apps/scanning.h"
#include "core/file_io.h"
#include "scan/capture_store.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

Result<scan::Plan> MakePlan(const LoadedRig& loaded, const std::string& preset_name, scan::PlanPurpose purpose) {
  if (!loaded.model) {
    return InvalidArgumentError("rig '" + loaded.rig->name() + "'",
                                "has no 'geometry:' section: a plan needs the rig's description");
  }
  LOOM_ASSIGN_OR_RETURN(const scan::Preset preset, scan::LoadPreset(ResolvePresetPath(preset_name)));
  return scan::MakePlan(*loaded.model, preset, purpose, loaded.light_drift);
}

// A real rig's operator places each object: the first before the scan starts (it is named),
// the others when the scan asks, confirmed with Enter.
Status AskOperator(scan::ScanObject placed, bool* first) {
  const std::string object(scan::ScanObjectName(placed));
  if (*first) {
    *first = false;
    std::cerr << "the scan starts with the " << object << " on the turntable\n";
    return Status::Ok();
  }
  std::cerr << "place the " << object << " on the turntable, then press Enter: " << std::flush;
  std::string line;
  if (!std::getline(std::cin, line)) {
    return FailedPreconditionError("the " + object,
                                   "must be placed on the turntable, but stdin is closed: run loom scan "
                                   "interactively (or --resume the scan once it is placed)");
  }
  return Status::Ok();
}

Status RunScan(LoadedRig& loaded, const scan::Plan& plan, scan::CaptureStore& store, bool quiet) {
  hal::SafeStateGuard guard(*loaded.rig);
  acquisition::SequencerOptions options;
  options.light_drift_warn_percent = loaded.light_drift.warn_percent;
  options.device_faults = loaded.device_faults;
  bool first_object = true;
  options.place_object = [&](scan::ScanObject object) {
    return loaded.sim ? hal::PlaceObject(*loaded.sim, object) : AskOperator(object, &first_object);
  };
  acquisition::Sequencer sequencer(*loaded.rig, plan, store, options);
  ProgressBar bar("scan", quiet);
  LOOM_RETURN_IF_ERROR(sequencer.Run([&](const acquisition::ScanProgress& p) {
    bar.Update(p.steps_done, p.steps_total, "steps", std::to_string(p.frames_stored) + " frames", p.eta_s);
  }));
  std::cout << "scan complete: " << store.records().size() << " frames in " << store.directory().string() << "\n";
  return Status::Ok();
}

// A scan of a crop: every camera reads only the window that sees it.
Status ApplyCrop(LoadedRig& loaded, double crop_mm, bool quiet) {
  if (crop_mm <= 0) return Status::Ok();
  if (!loaded.model) return InvalidArgumentError("--crop-mm", "needs the rig's geometry: where the cameras are");
  LOOM_ASSIGN_OR_RETURN(const auto windows, acquisition::CropWindows(*loaded.model, {.size_mm = crop_mm}));
  for (const auto& [camera, window] : windows) {
    LOOM_RETURN_IF_ERROR(loaded.rig->SetCameraRegion(camera, window));
    if (!quiet) {
      std::cerr << camera << " reads " << window.width << "x" << window.height << " px at " << window.x << "," << window.y
                << " for the " << crop_mm << " mm crop\n";
    }
  }
  return Status::Ok();
}

}  // namespace

Status NewScan(const NewScanRequest& request) {
  LOOM_ASSIGN_OR_RETURN(const std::string rig_text, ReadFile(ResolveRigPath(request.rig_path)));
  LOOM_ASSIGN_OR_RETURN(LoadedRig loaded, LoadRigFromText(rig_text, request.rig_path, request.object));
  LOOM_RETURN_IF_ERROR(ApplyCrop(loaded, request.crop_mm, request.quiet));
  const scan::PlanPurpose purpose = request.calibration ? scan::PlanPurpose::kCalibration : scan::PlanPurpose::kMaterial;
  LOOM_ASSIGN_OR_RETURN(scan::Plan plan, MakePlan(loaded, request.preset, purpose));
  if (request.object_windows) {
    if (!loaded.model) return InvalidArgumentError("--object-windows", "needs the rig's geometry: where the cameras are");
    LOOM_ASSIGN_OR_RETURN(plan, acquisition::WithObjectWindows(std::move(plan), *loaded.model, {}));
  }
  const std::string object = request.object.empty() ? "sample" : request.object;
  LOOM_ASSIGN_OR_RETURN(scan::CaptureStore store,
                        scan::CaptureStore::Create(request.out, {rig_text, object, plan, request.crop_mm}));
  return RunScan(loaded, store.info().plan, store, request.quiet);
}

namespace {

Status ResumeScan(const fs::path& directory, bool quiet) {
  LOOM_ASSIGN_OR_RETURN(scan::CaptureStore store, scan::CaptureStore::Open(directory, /*repair=*/true));
  const scan::ScanInfo& info = store.info();
  const std::string object = info.object == "sample" ? "" : info.object;
  LOOM_ASSIGN_OR_RETURN(LoadedRig loaded, LoadRigFromText(info.rig_yaml, (directory / "scan.yaml").string() + " (rig)", object));
  LOOM_RETURN_IF_ERROR(ApplyCrop(loaded, info.crop_mm, quiet));
  if (!quiet) {
    std::cerr << "resuming " << directory.string() << ": " << store.steps_done() << " of " << info.plan.steps.size()
              << " steps done, " << store.records().size() << " frames kept\n";
  }
  // The plan the scan was started with, not today's preset: the resumed scan ends as planned.
  return RunScan(loaded, info.plan, store, quiet);
}

// Exit 0 when every recorded frame is intact (complete or not), 1 otherwise.
int Verify(const fs::path& directory) {
  const Result<scan::ScanIntegrity> integrity = scan::VerifyScan(directory);
  if (!integrity.ok()) return ExitCode(integrity.status());
  integrity->Report(std::cout);
  return integrity->intact() ? kExitOk : kExitFailure;
}

}  // namespace

int RunScan(int argc, char** argv) {
  CLI::App app("Scan: run a measurement plan on a rig into a scan directory, resume one, or verify one", "loom scan");
  AddCommonOptions(app);
  NewScanRequest request;
  std::string resume, verify;
  app.add_option("--rig", request.rig_path, "Rig YAML, or its name in configs/rig/");
  app.add_option("--preset", request.preset, "Gloss preset: low, medium, high or a file");
  app.add_option("--object", request.object,
                 "What lies on the turntable; on a simulated rig: fabric:SEED, "
                 "fabric-out-of-model:SEED, white-tile, chessboard, colour-chart");
  app.add_flag("--calibration", request.calibration, "Run the calibration plan");
  app.add_flag("--object-windows", request.object_windows,
               "With --calibration: the steps of the calibration target, the chrome sphere and the colour chart read, "
               "from every camera, only the window around where that object lies (the white tile's and the dark steps "
               "read whole frames)");
  app.add_option("--crop-mm", request.crop_mm,
                 "Scan a square crop of the sample of this side, centred: each camera reads only the window that sees "
                 "it (reconstruct it with --size = this / the stack's pixel size)")
      ->check(CLI::PositiveNumber);
  app.add_option("--out", request.out, "New scan directory");
  app.add_option("--resume", resume, "Continue the interrupted scan in this directory");
  app.add_option("--verify", verify,
                 "Check the scan in this directory and change nothing: its journal, and every frame against its checksum");
  app.add_flag("--quiet", request.quiet, "No progress output");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  if (!verify.empty()) return Verify(verify);
  if (resume.empty() && (request.rig_path.empty() || request.out.empty())) {
    std::cerr << "error: loom scan needs --rig and --out (or --resume DIR)\n";
    return kExitUsage;
  }
  if (request.object_windows && !request.calibration) {
    std::cerr << "error: --object-windows needs --calibration: only a calibration scan places calibration objects\n";
    return kExitUsage;
  }
  return ExitCode(resume.empty() ? NewScan(request) : ResumeScan(resume, request.quiet));
}

}  // namespace loom::apps
