#pragma once
// The paper's input layout for the CNN (Merzbach et al. 2019, §4): one fixed set of channels for
// every gloss preset of a rig, so that one network serves them all.
//
// | part          | channels                    | from the stack                                          |
// |---------------|-----------------------------|---------------------------------------------------------|
// | geometry      | 4                           | height above the median, geometric normal (as cnn.h)    |
// | colour        | 3 × colour observations     | each observation's radiance put into RGB (below)        |
// | monochrome    | monochrome observations     | as they are, in the stack's order                       |
// | linear light  | Σ sweep positions           | each sweep resampled to the layout's strip angles       |
//
// On tac7 that is 4 + 3·100 + 348 + 4·70 = 932 channels: the paper's 934 without x and y, which
// say where on the holder a pixel lies, not how it reflects (cnn.h).
//
// Colour: an observation records w · a of an RGB albedo a (its colour weights w, from the
// radiometric calibration's colour matrix). Its channel triple is L · w / |w|², the least-norm
// RGB that records as L: the paper's three channels per colour image, each in the labels' RGB
// space, and defined for any colour plan (no assumption that an observation's ten filter bands
// share one geometry).
//
// Linear light: a sweep is one camera's linear-light observations at one turntable angle,
// ordered by the strip's angle about its own direction (StripAngleDeg). A layout keeps each
// sweep's angles from the stack it was made from (the coarsest: tac7's low preset, 70 per
// camera), and each of them stands for its bin, from midway to the previous angle to midway to
// the next. A channel is the mean over its bin of the stack's sweep, linear between the sweep's
// positions and constant beyond its ends (which may stop up to a bin short of the layout's
// outermost angles: a calibrated arm never sweeps exactly its nominal range). So the medium and
// high presets' sweeps (140 and 825 positions) are averaged over each bin, as the paper
// downsamples them, without the first-order error of averaging samples that do not lie
// symmetrically in a bin; a coarser sweep is in effect interpolated; and the layout's own sweep
// is filtered by (1, 6, 1)/8, the same anti-aliasing for every preset (a smooth sweep gives every
// preset the same channels to O(bin²)).

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/observation_stack.h"
#include "core/status.h"

namespace loom::fitting {

inline constexpr int kCnnGeometryChannels = 4;  // height, normal.XYZ

// Planar C × H × W floats.
struct CnnTensor {
  int channels = 0;
  int height = 0;
  int width = 0;
  std::vector<float> values;
  float at(int c, int y, int x) const { return values[(static_cast<size_t>(c) * height + y) * width + x]; }
};

struct PaperLinearSweep {
  std::string camera;
  double turntable_deg = 0;
  std::vector<double> angles_deg;  // ascending
};

struct PaperInputLayout {
  int colour_observations = 0;
  int monochrome_observations = 0;
  std::vector<PaperLinearSweep> sweeps;

  int Channels() const;  // the CNN's input channels, geometry included
  nlohmann::json ToJson() const;
  // Throws std::exception on a missing key or a wrong type (model.json's reader reports it).
  static PaperInputLayout FromJson(const nlohmann::json& json);
};

// The angle in degrees of a linear-light observation's strip about the strip's own direction,
// 0 at the zenith: the arm angle of a strip swept about an axis through the sample.
double StripAngleDeg(const StackObservation& observation);

// The layout of `stack`'s observations; an error naming the stack when it has no observations
// of a group or a sweep of fewer than two positions.
Result<PaperInputLayout> PaperLayoutOf(const ObservationStack& stack);

// The layout's input channels from `stack` (radiance channels as log(1 + L / radiance_scale),
// unseen 0): an error naming the stack when its colour or monochrome observations are not the
// layout's counts, or a sweep of the layout is missing or stops more than a bin short of its outermost angles.
Result<CnnTensor> PaperInputFromStack(const ObservationStack& stack, const PaperInputLayout& layout, double radiance_scale);

}  // namespace loom::fitting
