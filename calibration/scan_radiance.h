#pragma once
// The radiance a scan recorded: for one step and camera, the step's bracket of raw frames merged
// into linear DN/µs (calibration/hdr_merge.h) above the camera's black level — measured on the
// scan's dark step — and turned into radiance units with the camera's radiometric model:
//   radiance = L · electrons_per_dn / (gain · sensitivity · 1e-6 · vignetting(x, y))
// (core/rig_model.h's SensorModel: nominal from the rig YAML, as radiometric calibration will
// refine it). Frames are read one step at a time, so a full-size scan never sits in memory.
// A scan must be complete: a step not done, or a camera's bracket missing from it, is an error
// naming the step, the camera and the scan.

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "calibration/hdr_merge.h"
#include "core/image.h"
#include "core/rig_model.h"
#include "core/rig_observation.h"
#include "scan/capture_store.h"
#include "scan/dark_level.h"
#include "scan/light_drift.h"

namespace loom::calibration {

struct RadianceView {
  int camera = 0;        // index into the rig's cameras
  scan::RigState state;  // what the devices did (the first frame's record)
  Image radiance;        // channel "L"; NaN where every exposure saturated, and outside `window`
  int saturated_pixels = 0;
  scan::Roi window;  // where on the sensor the frames were read (their region of interest)
};

// The lights of a view as the rig model names them (only the wheels in front of lit LEDs
// count); a lit LED whose wheel position was not recorded is an error naming `where`.
Result<LightingState> LightingOf(const RigModel& rig, const scan::RigState& state, const std::string& where);

// One view's radiance and what lit it: ScanRadiance's views, or rendered ones in tests.
struct LitView {
  int camera = 0;
  LightingState lighting;
  Image radiance;  // channel "L", converted with rig's sensor model
  std::string source;
  int step = -1;     // the scan's step it came from; −1 for a rendered one
  scan::Roi window;  // where the camera read: NaN outside it; 0 × 0 (a rendered one): the whole sensor
};

// The pixels of `view` that its camera read: x in [x0, x1), y in [y0, y1).
struct SeenPixels {
  int x0, y0, x1, y1;
};
SeenPixels SeenPixelsOf(const LitView& view);

class ScanRadiance {
 public:
  // `store` and `rig` must outlive the reader. Every camera of the plan must be in `rig`.
  static Result<ScanRadiance> Open(const scan::CaptureStore& store, const RigModel& rig);

  const scan::Plan& plan() const { return store_->info().plan; }
  const RigModel& rig() const { return *rig_; }
  const std::filesystem::path& directory() const { return store_->directory(); }
  Result<RadianceView> View(int step, const std::string& camera) const;
  // The views of `ids`, read and merged on every core (a calibration's time had been one core
  // reading brackets one by one); on failure, the first in `ids`' order.
  Result<std::vector<RadianceView>> Views(const std::vector<scan::ViewId>& ids) const;
  // The step's raw bracket for one camera, and what the HDR merge knows of that camera at the
  // bracket's gain: what View merges, for measurements on the raw readings (linearity).
  Result<std::vector<scan::RawFrame>> Bracket(int step, const std::string& camera) const;
  SensorNoise NoiseOf(const std::string& camera, double gain_db) const;
  // Every view of every step of `kind`, with its lighting.
  Result<std::vector<LitView>> LitViews(scan::StepKind kind) const;
  // The LEDs' and the linear light's drift through the scan, from its drift reference steps
  // (scan/light_drift.h); without any, tracks whose output is 1 everywhere.
  Result<scan::LightDrift> LightDrift() const;

 private:
  ScanRadiance(const scan::CaptureStore& store, const RigModel& rig) : store_(&store), rig_(&rig) {}
  std::string Where(int step, const std::string& camera) const;

  const scan::CaptureStore* store_;
  const RigModel* rig_;
  std::map<std::string, scan::DarkLevel> dark_;                                            // by camera
  std::map<std::pair<int, std::string>, std::vector<const scan::FrameRecord*>> brackets_;  // (step, camera)
};

}  // namespace loom::calibration
