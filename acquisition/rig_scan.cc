#include "acquisition/rig_scan.h"

#include <ostream>

#include "acquisition/crop_windows.h"
#include "core/file_io.h"
#include "core/progress_bar.h"
#include "hal/sim/sim_backends.h"

namespace loom::acquisition {
namespace {

namespace fs = std::filesystem;

Result<LoadedRig> LoadRigFromText(const std::string& text, const std::string& source, hal::BackendRegistry registry,
                                  const std::string& object) {
  LOOM_ASSIGN_OR_RETURN(const RigFile file, RigFile::Parse(text, source));
  return LoadRig(file, std::move(registry), object);
}

Result<scan::Plan> MakePlan(const LoadedRig& loaded, const fs::path& preset_file, scan::PlanPurpose purpose) {
  if (!loaded.model) {
    return InvalidArgumentError("rig '" + loaded.rig->name() + "'",
                                "has no 'geometry:' section: a plan needs the rig's description");
  }
  LOOM_ASSIGN_OR_RETURN(const scan::Preset preset, scan::LoadPreset(preset_file));
  return scan::MakePlan(*loaded.model, preset, purpose, loaded.light_drift);
}

Status RunPlan(LoadedRig& loaded, const scan::Plan& plan, scan::CaptureStore& store, const PlaceObjectByHand& place_by_hand,
               const ScanOutput& output) {
  hal::SafeStateGuard guard(*loaded.rig);
  SequencerOptions options;
  options.light_drift_warn_percent = loaded.light_drift.warn_percent;
  options.device_faults = loaded.device_faults;
  bool first_object = true;
  options.place_object = [&](scan::ScanObject object) {
    if (loaded.sim) return hal::PlaceObject(*loaded.sim, object);
    const bool first = std::exchange(first_object, false);
    return place_by_hand(object, first);
  };
  Sequencer sequencer(*loaded.rig, plan, store, options);
  ProgressBar bar("scan", output.quiet);
  LOOM_RETURN_IF_ERROR(sequencer.Run([&](const ScanProgress& p) {
    bar.Update(p.steps_done, p.steps_total, "steps", std::to_string(p.frames_stored) + " frames", p.eta_s);
  }));
  output.report << "scan complete: " << store.records().size() << " frames in " << store.directory().string() << "\n";
  return Status::Ok();
}

// A scan of a crop: every camera reads only the window that sees it.
Status ApplyCrop(LoadedRig& loaded, double crop_mm, const ScanOutput& output) {
  if (crop_mm <= 0) return Status::Ok();
  if (!loaded.model) return InvalidArgumentError("--crop-mm", "needs the rig's geometry: where the cameras are");
  LOOM_ASSIGN_OR_RETURN(const auto windows, CropWindows(*loaded.model, {.size_mm = crop_mm}));
  for (const auto& [camera, window] : windows) {
    LOOM_RETURN_IF_ERROR(loaded.rig->SetCameraRegion(camera, window));
    if (!output.quiet) {
      output.notes << camera << " reads " << window.width << "x" << window.height << " px at " << window.x << "," << window.y
                   << " for the " << crop_mm << " mm crop\n";
    }
  }
  return Status::Ok();
}

}  // namespace

Result<LoadedRig> LoadRig(const RigFile& file, hal::BackendRegistry registry, const std::string& object) {
  LoadedRig loaded;
  if (file.Has("geometry")) {
    LOOM_ASSIGN_OR_RETURN(loaded.model, file.Model());
    LOOM_ASSIGN_OR_RETURN(loaded.sim, hal::MakeSimRig(file, *loaded.model, object));
    hal::RegisterSimBackends(registry, loaded.sim->world);
  }
  loaded.light_drift = scan::ReadLightDriftSettings(file);
  loaded.device_faults = ReadDeviceFaultPolicy(file);
  LOOM_ASSIGN_OR_RETURN(loaded.rig, hal::Rig::Load(file, registry));
  return loaded;
}

Status NewScan(const scan::ScanRequest& request, const fs::path& preset_file, hal::BackendRegistry registry,
               const PlaceObjectByHand& place_by_hand, const ScanOutput& output) {
  LOOM_ASSIGN_OR_RETURN(const std::string rig_text, ReadFile(request.rig_path));
  LOOM_ASSIGN_OR_RETURN(LoadedRig loaded, LoadRigFromText(rig_text, request.rig_path, std::move(registry), request.object));
  LOOM_RETURN_IF_ERROR(ApplyCrop(loaded, request.crop_mm, output));
  const scan::PlanPurpose purpose = request.calibration ? scan::PlanPurpose::kCalibration : scan::PlanPurpose::kMaterial;
  LOOM_ASSIGN_OR_RETURN(scan::Plan plan, MakePlan(loaded, preset_file, purpose));
  if (request.object_windows) {
    if (!loaded.model) return InvalidArgumentError("--object-windows", "needs the rig's geometry: where the cameras are");
    LOOM_ASSIGN_OR_RETURN(plan, WithObjectWindows(std::move(plan), *loaded.model, {}));
  }
  const std::string object = request.object.empty() ? "sample" : request.object;
  LOOM_ASSIGN_OR_RETURN(scan::CaptureStore store,
                        scan::CaptureStore::Create(request.out, {rig_text, object, plan, request.crop_mm}));
  return RunPlan(loaded, store.info().plan, store, place_by_hand, output);
}

Status ResumeScan(const fs::path& directory, hal::BackendRegistry registry, const PlaceObjectByHand& place_by_hand,
                  const ScanOutput& output) {
  LOOM_ASSIGN_OR_RETURN(scan::CaptureStore store, scan::CaptureStore::Open(directory, /*repair=*/true));
  const scan::ScanInfo& info = store.info();
  const std::string object = info.object == "sample" ? "" : info.object;
  LOOM_ASSIGN_OR_RETURN(LoadedRig loaded, LoadRigFromText(info.rig_yaml, (directory / "scan.yaml").string() + " (rig)",
                                                          std::move(registry), object));
  LOOM_RETURN_IF_ERROR(ApplyCrop(loaded, info.crop_mm, output));
  if (!output.quiet) {
    output.notes << "resuming " << directory.string() << ": " << store.steps_done() << " of " << info.plan.steps.size()
                 << " steps done, " << store.records().size() << " frames kept\n";
  }
  // The plan the scan was started with, not today's preset: the resumed scan ends as planned.
  return RunPlan(loaded, info.plan, store, place_by_hand, output);
}

}  // namespace loom::acquisition
