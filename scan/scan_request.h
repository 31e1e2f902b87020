#pragma once
// What a new scan on a rig is asked for, as `loom scan --rig … --out …` takes it: the rig, the
// gloss preset's plan (or a calibration plan), the object on the turntable, a crop whose camera
// windows the scan reads, and the new scan directory. Whoever holds the device backends runs it
// (apps/scanning.h); the main job (demo/) asks for its scans in these terms.

#include <filesystem>
#include <string>

namespace loom::scan {

struct ScanRequest {
  std::string rig_path;         // a file, or a name in configs/rig/
  std::string preset = "low";   // a name in configs/plans/, or a file
  std::string object;           // replaces a simulated rig's sample ("fabric:SEED", …); empty keeps it
  bool calibration = false;     // the calibration plan instead of the preset's material plan
  bool object_windows = false;  // calibration objects read through the camera windows that see them
  double crop_mm = 0;           // > 0: every camera reads only the window that sees this centred crop
  std::filesystem::path out;
  bool quiet = false;
};

}  // namespace loom::scan
