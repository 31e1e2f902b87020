// loom scan: run a measurement plan on a rig into a crash-safe scan directory (acquisition/rig_scan.h),
// resume one, or verify one.
#include <iostream>

#include "acquisition/rig_scan.h"
#include "apps/backends.h"
#include "apps/command.h"
#include "apps/config_paths.h"
#include "apps/scanning.h"
#include "scan/capture_store.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

// A real rig's operator places each object: the first before the scan starts (it is named),
// the others when the scan asks, confirmed with Enter.
Status AskOperator(scan::ScanObject placed, bool first) {
  const std::string object(scan::ScanObjectName(placed));
  if (first) {
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

}  // namespace

Status NewScan(const scan::ScanRequest& request) {
  scan::ScanRequest resolved = request;
  resolved.rig_path = ResolveRigPath(request.rig_path).string();
  return acquisition::NewScan(resolved, ResolvePresetPath(request.preset), AllBackends(), AskOperator,
                              {std::cout, std::cerr, request.quiet});
}

namespace {

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
  scan::ScanRequest request;
  std::string resume, verify;
  app.add_option("--rig", request.rig_path, "Rig YAML, or its name in configs/rig/");
  app.add_option("--preset", request.preset, "Gloss preset: low, medium, high or a file");
  app.add_option("--object", request.object,
                 "What lies on the turntable; on a simulated rig: fabric:SEED, "
                 "fabric-out-of-model:SEED, white-tile, chessboard, colour-chart");
  app.add_flag("--calibration", request.calibration, "Run the calibration plan");
  app.add_flag("--object-windows", request.object_windows,
               "With --calibration: each camera reads only the window around the calibration object of a step");
  app.add_option("--crop-mm", request.crop_mm,
                 "Scan a centred square crop of the sample this wide: each camera reads only the window that sees it")
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
  if (!resume.empty())
    return ExitCode(acquisition::ResumeScan(resume, AllBackends(), AskOperator, {std::cout, std::cerr, request.quiet}));
  return ExitCode(NewScan(request));
}

}  // namespace loom::apps
