#pragma once
// A scan on a rig from its rig file: the rig loaded with the device backends the caller holds
// (only apps/ picks them) and, for a simulated rig (one with `geometry:`), the `sim` devices
// sharing its virtual world; a new scan (a crop's camera windows applied, the preset's plan made,
// a crash-safe capture store created and the plan run into it) or an interrupted one resumed.

#include <filesystem>
#include <functional>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>

#include "acquisition/sequencer.h"
#include "core/rig_file.h"
#include "hal/registry.h"
#include "hal/rig.h"
#include "hal/sim/sim_rig.h"
#include "scan/capture_store.h"
#include "scan/plan.h"
#include "scan/scan_request.h"

namespace loom::acquisition {

struct LoadedRig {
  std::unique_ptr<hal::Rig> rig;
  std::optional<RigModel> model;   // from `geometry:`, when the file has one
  std::optional<hal::SimRig> sim;  // with `model`: for the devices whose backend is `sim`
  scan::LightDriftSettings light_drift;
  DeviceFaultPolicy device_faults;
};

// `object` replaces a simulated rig's `sample:` ("fabric:SEED", "white-tile", …); empty keeps it.
Result<LoadedRig> LoadRig(const RigFile& file, hal::BackendRegistry registry, const std::string& object = "");

// A real rig's operator placing an object the scan needs (`first`: before the scan starts);
// a simulated rig's world places its objects itself.
using PlaceObjectByHand = std::function<Status(scan::ScanObject object, bool first)>;

// Where a scan reports: its result and progress bar (unless `quiet`), and its notes.
struct ScanOutput {
  std::ostream& report;
  std::ostream& notes;
  bool quiet = false;
};

// `request.rig_path` and `preset_file`: files (apps/ resolves names in configs/).
Status NewScan(const scan::ScanRequest& request, const std::filesystem::path& preset_file, hal::BackendRegistry registry,
               const PlaceObjectByHand& place_by_hand, const ScanOutput& output);
// Continues the plan the scan started with (not today's preset), on the rig its snapshot describes.
Status ResumeScan(const std::filesystem::path& directory, hal::BackendRegistry registry, const PlaceObjectByHand& place_by_hand,
                  const ScanOutput& output);

}  // namespace loom::acquisition
