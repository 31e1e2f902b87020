#pragma once
// HDR merge: a bracket of raw frames of one view (same camera, same lights, different exposure
// times) → linear radiance in DN per microsecond above black, with its standard deviation.
//
// Every reading v at exposure t gives an estimate s/t of the radiance, s = v − black. Readings
// at or near saturation are excluded; readings under the noise floor are excluded too when any
// other reading of the pixel is above it (a pixel dark in every exposure is dark: its readings
// are kept, so black stays black instead of becoming unknown). The rest are
// averaged with inverse-variance weights from the sensor's noise model,
//   var(s/t) = (L·t / g + σ_read²) / t²   (g electrons per DN, L the radiance in DN/µs)
// evaluated at a first estimate of L (the longest valid exposure's), not at each reading: weights
// from the readings themselves would favour readings that came out low, a bias in the merge.
// A pixel saturated in every exposure is NaN (radiance unknown) and counted.
// OpenCV's cv::MergeDebevec & co. take 8-bit images and a fitted response curve: raw 12/16-bit
// frames of a linear sensor need neither, hence this.

#include <vector>

#include "core/image.h"
#include "core/status.h"
#include "scan/frame.h"

namespace loom::calibration {

// What the merge needs to know of a camera: from dark frames (black, read noise), the
// datasheet or a photon transfer curve (gain) and the pixel format (saturation).
struct SensorNoise {
  double black_dn = 64;
  double read_noise_dn = 1;
  double electrons_per_dn = 2.5;
  double saturation_dn = 4094;  // readings at or above are clipped
  double floor_sigmas = 3;      // readings under floor_sigmas × read noise are too weak
};

struct HdrImage {
  Image image;               // channels "L" (DN/µs above black) and "L.sigma" (its standard deviation)
  int saturated_pixels = 0;  // saturated in every exposure (NaN)
};

// `bracket`: frames of one camera and view, any exposure order; all the same size. An empty
// bracket, mixed sizes or a non-positive exposure time are errors naming the frame.
Result<HdrImage> MergeBracket(const std::vector<scan::RawFrame>& bracket, const SensorNoise& sensor);

// Camera linearity from a bracket of a steady scene: for each pair of consecutive exposures, the
// mean count rate (reading above black over exposure time) of the pixels both read well — above
// 10 × the noise floor, below 90 % of full scale, judged on the shorter exposure's local mean —
// should agree. `deviation` is the worst
// |rate ratio − 1| over the pairs; `pairs` = 0 when no pair shares such pixels (not measured).
struct Linearity {
  double deviation = 0;
  double max_dn = 0;  // the highest mean reading (above black) a pair was compared at
  int pairs = 0;
};
// `mask`: the pixels to use (row-major, nonzero = use), or empty for all.
Result<Linearity> MeasureLinearity(const std::vector<scan::RawFrame>& bracket, const SensorNoise& sensor,
                                   const std::vector<uint8_t>& mask = {});

}  // namespace loom::calibration
