#pragma once
// A new scan on a rig, as `loom scan --rig … --out …` runs it and the main job calls it: the rig
// loaded with its device backends (rig_loader.h), a crop's camera windows applied, the preset's
// plan made, a crash-safe capture store created and the plan run into it.

#include <filesystem>
#include <string>

#include "core/status.h"

namespace loom::apps {

struct NewScanRequest {
  std::string rig_path, preset = "low", object;
  bool calibration = false;
  bool object_windows = false;  // calibration objects read through their windows
  double crop_mm = 0;
  std::filesystem::path out;
  bool quiet = false;
};

Status NewScan(const NewScanRequest& request);

}  // namespace loom::apps
