#include "reconstruction/scan_reconstruction.h"

#include <chrono>
#include <ostream>

#include "core/duration.h"
#include "core/file_io.h"
#include "core/observation_stack.h"
#include "core/output_directory.h"
#include "core/rig_file.h"
#include "core/version.h"
#include "scan/capture_store.h"
#include "scan/plan.h"

namespace loom::reconstruction {

nlohmann::json ScanReconstruction::ToJson(double seconds) const {
  nlohmann::json json = reconstruction.ToJson();
  json.update({{"scan", scan.string()},
               {"calibration", calibration_directory.empty() ? "nominal (the scan's rig YAML)" : calibration_directory.string()},
               {"seconds", seconds},
               {"loom_version", std::string(VersionWithCommit())}});
  json.update(calibration.ToJson());
  return json;
}

Result<ScanToReconstruct> OpenScanToReconstruct(const std::filesystem::path& scan,
                                                const std::filesystem::path& calibration_directory, ReconstructOptions options) {
  LOOM_ASSIGN_OR_RETURN(scan::CaptureStore store, scan::CaptureStore::Open(scan));
  LOOM_ASSIGN_OR_RETURN(const RigFile rig_file, RigFile::Parse(store.info().rig_yaml, (scan / "scan.yaml").string() + " (rig)"));
  LOOM_ASSIGN_OR_RETURN(RigModel rig, rig_file.Model());
  options.light_drift_warn_percent = scan::ReadLightDriftSettings(rig_file).warn_percent;
  LOOM_RETURN_IF_ERROR(rig_file.Finish());
  LOOM_RETURN_IF_ERROR(options.Check());
  ScanToReconstruct opened{std::move(store), std::move(rig), options, {}, scan, calibration_directory, {}};
  if (calibration_directory.empty()) {
    opened.notes.push_back("no calibration directory: reconstructing with the rig YAML's nominal geometry and sensor model");
    return opened;
  }
  LOOM_ASSIGN_OR_RETURN(opened.calibration, calibration::CalibrationDirectory(calibration_directory).Apply(&opened.rig));
  if (!opened.calibration.radiometry) {
    opened.notes.push_back(calibration_directory.string() +
                           " holds no radiometric calibration: the rig YAML's light intensities and sensor model");
  }
  return opened;
}

Result<ScanReconstruction> ReconstructScan(const ScanToReconstruct& scan,
                                           const std::function<void(const ReconstructProgress&)>& progress) {
  LOOM_ASSIGN_OR_RETURN(Reconstruction reconstruction, Reconstruct(scan.store, scan.rig, scan.options, progress));
  ScanReconstruction result{std::move(reconstruction), scan.calibration, scan.scan, scan.calibration_directory, scan.notes};
  if (std::string note = result.reconstruction.CoarseSamplingNote(); !note.empty()) result.notes.push_back(std::move(note));
  return result;
}

Result<ReconstructedDirectory> ReconstructToDirectory(const std::filesystem::path& scan,
                                                      const std::filesystem::path& calibration_directory,
                                                      const ReconstructOptions& options, const std::filesystem::path& out,
                                                      const std::function<void(const ReconstructProgress&)>& progress) {
  const auto start = std::chrono::steady_clock::now();
  LOOM_ASSIGN_OR_RETURN(const ScanToReconstruct opened, OpenScanToReconstruct(scan, calibration_directory, options));
  LOOM_ASSIGN_OR_RETURN(OutputDirectory staged, OutputDirectory::Create(out, "--out"));
  ReconstructedDirectory result;
  result.out = out;
  result.pixel_mm = opened.options.pixel_mm;
  LOOM_ASSIGN_OR_RETURN(result.scanned, ReconstructScan(opened, progress));
  LOOM_RETURN_IF_ERROR(WriteObservationStack(staged.partial() / "stack.exr", result.scanned.reconstruction.stack));
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  LOOM_RETURN_IF_ERROR(
      WriteFileAtomically(staged.partial() / "reconstruction.json", result.scanned.ToJson(result.seconds).dump(2) + "\n"));
  LOOM_RETURN_IF_ERROR(staged.Commit());
  return result;
}

void ReconstructedDirectory::Report(std::ostream& out) const {
  const Reconstruction& result = scanned.reconstruction;
  out << "wrote " << (this->out / "stack.exr").string() << ": " << result.stack.image.width() << "x"
      << result.stack.image.height() << " px at " << pixel_mm << " mm, " << result.stack.observations.size()
      << " observations; heightmap from " << result.heightmap_camera << " (" << result.heightmap_filled << " px filled), "
      << 100 * result.unseen_fraction << " % of samples unseen, " << FormatDuration(seconds) << "\n";
}

}  // namespace loom::reconstruction
