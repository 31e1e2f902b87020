#pragma once
// The main job on a simulated rig, end to end, as `loom demo` runs it: a calibration scan →
// geometric and radiometric calibration (or, without calibrating, the rig YAML's) → a material
// scan of a procedural fabric (or of a crop of it) → reconstruction with that calibration → a fit
// by each method asked for → evaluation against the simulator's ground truth → export of the
// last method's maps as glTF and AxF, then summary.json. Each stage calls the library function
// its loom command calls, with that command's defaults, and prints that command line first.

#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/status.h"
#include "scan/scan_request.h"

namespace loom::demo {

struct MainJobRequest {
  std::filesystem::path rig;          // a simulated rig's YAML (one with `geometry:`)
  std::string object = "fabric:1";    // fabric:SEED or fabric-out-of-model:SEED
  std::string preset = "low";         // the gloss preset as the user named it (printed commands, summary.json)
  std::filesystem::path preset_file;  // and its file
  std::vector<std::string> methods = {"cnn", "cnn+refine"};  // the last is the main result
  int size_px = 0;                                           // 0: the reconstruction's default
  double crop_mm = 0;                // > 0: the scans read only the windows that see this crop; 0: size_px's crop, if any
  bool calibrate = true;             // false: reconstruct with the rig YAML's geometry and radiometry
  bool quiet = false;                // no progress bars
  std::filesystem::path models_dir;  // the shipped CNN models (configs/models)
  std::filesystem::path out;         // a new or empty directory
};

// Runs a new scan on the rig: whoever holds the device backends does (apps/scanning.h).
using ScanOnRig = std::function<Status(const scan::ScanRequest&)>;

// Runs every stage into `request.out`, each stage's report to `report` and its notes and warnings
// to `notes`; writes and returns summary.json: each method's evaluation, the camera calibration's
// RMS and each stage's seconds.
Result<nlohmann::ordered_json> RunMainJob(MainJobRequest request, const ScanOnRig& scan_on_rig, std::ostream& report,
                                          std::ostream& notes);

// summary.json as one screen: the methods' scores side by side and the time per stage.
void PrintMainJobSummary(const nlohmann::ordered_json& summary, std::ostream& out);

}  // namespace loom::demo
