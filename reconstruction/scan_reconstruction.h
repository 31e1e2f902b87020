#pragma once
// A scan directory reconstructed as `loom reconstruct` does it, in two steps so that a caller
// checks its own outputs between them: OpenScanToReconstruct reads and checks everything (the
// capture store, the rig it was scanned with, scan.yaml's copy of the rig YAML, and that rig's
// light-drift settings, a calibration directory applied to the rig or else its nominal geometry
// and sensor model); ReconstructScan then runs Reconstruct (reconstruct.h), the long part.

#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calibration/calibration_directory.h"
#include "core/rig_model.h"
#include "core/status.h"
#include "reconstruction/reconstruct.h"
#include "scan/capture_store.h"

namespace loom::reconstruction {

struct ScanToReconstruct {
  scan::CaptureStore store;
  RigModel rig;  // calibrated where the calibration directory says
  ReconstructOptions options;
  calibration::AppliedCalibration calibration;  // nothing applied: the rig YAML's, nominal
  std::filesystem::path scan;
  std::filesystem::path calibration_directory;  // empty: none
  std::vector<std::string> notes;               // for the operator: what is not calibrated
};

// `calibration_directory` empty: the scan's rig YAML, nominal. Errors name the scan's files or
// the calibration directory's.
Result<ScanToReconstruct> OpenScanToReconstruct(const std::filesystem::path& scan,
                                                const std::filesystem::path& calibration_directory, ReconstructOptions options);

struct ScanReconstruction {
  Reconstruction reconstruction;
  calibration::AppliedCalibration calibration;
  std::filesystem::path scan;
  std::filesystem::path calibration_directory;
  // The opened scan's notes, and where a camera samples the stack coarsely.
  std::vector<std::string> notes;

  // reconstruction.json: the reconstruction's fields, the scan, the calibration applied (each
  // part calibrated or nominal) and `seconds`.
  nlohmann::json ToJson(double seconds) const;
};

Result<ScanReconstruction> ReconstructScan(const ScanToReconstruct& scan,
                                           const std::function<void(const ReconstructProgress&)>& progress = nullptr);

struct ReconstructedDirectory {
  ScanReconstruction scanned;
  std::filesystem::path out;
  double pixel_mm = 0;
  double seconds = 0;

  // What `loom reconstruct` prints: what was written, the heightmap, unseen samples, the time.
  void Report(std::ostream& out) const;
};

// Opens `scan` (OpenScanToReconstruct), checks `out` before the work, reconstructs and writes
// OUT/stack.exr and OUT/reconstruction.json.
Result<ReconstructedDirectory> ReconstructToDirectory(const std::filesystem::path& scan,
                                                      const std::filesystem::path& calibration_directory,
                                                      const ReconstructOptions& options, const std::filesystem::path& out,
                                                      const std::function<void(const ReconstructProgress&)>& progress);

}  // namespace loom::reconstruction
