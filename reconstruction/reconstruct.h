#pragma once
// A scan → the calibrated observation stack (core/observation_stack.h) that fitting reads.
//
// 1. Heightmap: the structured-light steps, decoded in one camera (the one nearest the top view
//    unless chosen) and triangulated on the stack's grid (structured_light.h).
// 2. Geometry channels: pos = (x, y, height) in the top-view frame (the sample frame at
//    turntable angle 0); the geometric normal of the heightmap blurred to `normal_blur_mm`
//    (core/heightfield.h, as the simulator's materials define it).
// 3. Observations: for every colour, monochrome and linear-light step of the plan and every
//    camera of it (in plan order — the order the simulator's fast path and the CNN use), the
//    HDR radiance (scan_radiance.h) at each grid point: the point is turned to the step's
//    turntable angle, projected through the camera's lens model and sampled bilinearly; NaN
//    where the relief hides the point from the camera. The table entry comes from what the
//    devices recorded doing (frame metadata), not from what the plan asked.
// 4. Drift: when the plan has drift references (scan/light_drift.h), every LED-lit observation
//    is divided by the LEDs' output at its step, relative to the first reference, and every
//    strip-lit one by the linear light's, from the strip's own references; a drift beyond
//    `light_drift_warn_percent` is logged as a warning.
// Geometry and light model come from `rig`: the rig YAML's nominal description, or a
// calibrated one.

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/observation_stack.h"
#include "core/rig_model.h"
#include "scan/capture_store.h"

namespace loom::reconstruction {

// The largest stack side: 16384² pixels of a tac7 stack's 934 channels would be ~1 TB.
inline constexpr int kMaxStackSide = 16384;

struct ReconstructOptions {
  int width_px = 128;
  int height_px = 128;
  double pixel_mm = 0.2;
  double normal_blur_mm = 1.0;
  double min_height_mm = -5;
  double max_height_mm = 5;
  std::string heightmap_camera;  // empty: the camera looking most nearly straight down
  int threads = 0;               // 0: one per core
  bool correct_light_drift = true;
  double light_drift_warn_percent = 1;  // the rig YAML's light_drift: warn_percent
  Status Check() const;                 // every problem, naming the field (NaN fails every check)
};

struct ReconstructProgress {
  std::string stage;  // "heightmap", "observations"
  int done = 0;
  int total = 0;
};

// How finely a camera samples the stack: camera pixels per stack pixel at the turntable's
// centre, along the direction in the sample plane that the camera sees most coarsely (a side
// camera foreshortens one by the cosine of its angle from the normal). Below ~2 every
// observation is noticeably blurred over neighbouring stack pixels (reconstruction/README.md).
struct CameraSampling {
  std::string camera;
  double camera_px_per_stack_px = 0;  // 0: the camera does not see the turntable's centre
};
std::vector<CameraSampling> StackSampling(const RigModel& rig, double pixel_mm);
inline constexpr double kFineSampling = 2.0;  // camera pixels per stack pixel

// Channel 0 of a camera image at `pixels` (camera pixel coordinates, centres at integers,
// resolved to 1/32 px); NaN for a pixel given as NaN, off the image, or where the interpolation
// reaches a NaN (a saturated or unread camera pixel). A camera that samples the stack finely
// (`camera_px_per_stack_px` ≥ kFineSampling) is interpolated bilinearly, which averages its noise
// over neighbouring camera pixels; a coarser one bicubically, since bilinear interpolation would
// blur its observations by up to half a stack pixel more, and a per-pixel fit of a fine weave
// reads that blur as lobe width and orientation (reconstruction/README.md).
std::vector<float> SampleCamera(const Image& image, const std::vector<Eigen::Vector2f>& pixels, double camera_px_per_stack_px);

struct Reconstruction {
  ObservationStack stack;
  std::vector<CameraSampling> sampling;  // every camera of the rig, StackSampling
  std::string heightmap_camera;
  int heightmap_filled = 0;                                // grid pixels without a triangulated height (filled from neighbours)
  int saturated_pixels = 0;                                // camera pixels saturated in every exposure, over all views
  double unseen_fraction = 0;                              // of observation samples: NaN (hidden or off the camera's image)
  std::vector<std::pair<int, double>> light_drift;         // (step, output) of each LED drift reference
  std::vector<std::pair<int, double>> linear_light_drift;  // the same for the strip's references
  bool light_drift_corrected = false;

  // The stack's size and what the fields above say, as reconstruction.json keeps them.
  nlohmann::json ToJson() const;
  nlohmann::json LightDriftJson() const;  // references, the largest drift (LEDs, strip), whether corrected
  // A note for the operator when a camera samples the stack coarsely (below kFineSampling: the
  // stack is then blurred, not wrong), and how to sharpen it; empty otherwise.
  std::string CoarseSamplingNote() const;
};

Result<Reconstruction> Reconstruct(const scan::CaptureStore& store, const RigModel& rig, const ReconstructOptions& options,
                                   const std::function<void(const ReconstructProgress&)>& progress = nullptr);

}  // namespace loom::reconstruction
