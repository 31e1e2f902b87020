#pragma once
// The simulator's captures (sim/object_capture.h) written in the layouts other rigs write
// (capture_export.h), with their truth in the stored images' units, so that `loom import` →
// `loom fit` → `loom eval` runs against ground truth (`loom sim capture`).
//
// The stored scale: a curved object's radiance 1 is the top value unless a highlight is brighter,
// which is then stored just below it (nothing clips); a flash capture's brightest half percent of
// values clip, as a phone's highlights do. The truth's albedos are divided by that top value,
// which is what `loom import --scale 1` reads back.

#include <filesystem>
#include <optional>
#include <string>

#include "core/image.h"
#include "core/status.h"
#include "photos/capture_import.h"
#include "sim/object_capture.h"
#include "sim/sample.h"

namespace loom::photos {

// A fabric of 64 px of 1 mm, seed 1: a phone photograph's sample.
inline sim::SampleSpec FlashSample() {
  sim::SampleSpec sample;
  sample.seed = 1;
  sample.size_px = 64;
  sample.pixel_mm = 1.0;
  return sample;
}

struct SimulatedCaptureRequest {
  Layout layout = Layout::kPhotometricStereo;  // as loom import reads them
  sim::ObjectCaptureOptions object;            // ps and lp: the curved object
  sim::FlashCaptureOptions flash;              // flash: the flash and the photographs
  sim::SampleSpec sample = FlashSample();      // flash: the planar material
  // ps and lp: the files' lights as a dome's calibration errs, the images taken under the true
  // ones: each direction turned by |N(0, light_error_deg)| about a random axis, each light's
  // intensity off by a factor N(1, intensity_error) from the one the files say (its image scaled).
  double light_error_deg = 0;
  double intensity_error = 0;
  Status Check() const;  // the error fields; the layout's own options are checked where written
};

struct SimulatedCapture {
  Image truth;                   // SVBRDF maps on the images' grid, albedos in the stored units
  std::optional<Image> normals;  // ps and lp: the true normals (x right, y up, z towards the camera)
  double white = 1;              // the radiance stored as the top value
  int images = 0;
  std::string description;  // what was written, for a person
};

// Writes the capture into `dir` (the layout's writer: a new folder) and returns its truth.
Result<SimulatedCapture> WriteSimulatedCapture(const SimulatedCaptureRequest& request, const std::filesystem::path& dir);

}  // namespace loom::photos
