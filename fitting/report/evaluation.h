#pragma once
// Evaluation of fitted SVBRDF maps, as the paper evaluates its network (§Evaluation):
//  1. normalised RMS error of each parameter against a reference (the simulator's ground truth
//     or another fit), computed on the 14-d label (model/label.h) so that α compares without
//     wrap-around and small σ weigh as the network's loss weighs them; every label channel is
//     normalised by its range (1 for albedos, σ', F0; 2 for n_s and cos/sin 2α). Also the
//     shading normals' angle error and a_s·F0 (the product a fit can observe away from grazing);
//  2. map noise: the mean squared 4-neighbour Laplacian of the a_s, σ and α label channels (a
//     measure of high-frequency energy: salt-and-pepper speckle raises it, smooth maps keep it
//     low), for the fit and the reference, whose ratio says how much noisier the fit is;
//  3. relative L1 between the model re-rendered under every stack observation and the measured
//     value, per observation group (colour, monochrome, linear) — for the fit and for the
//     reference — over the observations the fitter uses (seen, not cast-shadowed).
// Both maps and the stack must share the grid (same width and height): an error otherwise.

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/observation_stack.h"
#include "fitting/model/ward_gd10.h"

#include <nlohmann/json.hpp>

namespace loom::fitting {

struct ParameterError {
  std::string name;  // a_d, a_s, n_s, sigma, alpha, F0, a_s*F0
  double nrmse = 0;
};

struct MapNoise {
  std::string name;      // a_s, sigma, alpha
  double fit = 0;        // mean squared Laplacian, label units²
  double reference = 0;  // 0 without a reference
};

struct RenderError {
  std::string group;  // colour, monochrome, linear, all
  int64_t values = 0;
  double relative_l1 = 0;  // Σ|rendered − measured| / Σ|measured|
};

// The anisotropy angle's error where the data can fix it: over the pixels whose reference lobe
// is anisotropic (σx ≥ kMinSigmaRatio σy). Of a lobe nearly round α is arbitrary, and those
// pixels would otherwise weigh in the α NRMSE as much as any other.
struct AnisotropicAlphaError {
  static constexpr double kMinSigmaRatio = kAnisotropicSigmaRatio;
  double nrmse = 0;        // as ParameterError's "alpha", over those pixels
  double pixel_share = 0;  // of all pixels
  // The lobe's angle off the truth's in degrees (0–90: α is defined modulo 180°), over those
  // pixels: a spread of small errors and a share of lobes turned across tell different stories.
  double median_deg = 0;
  double p90_deg = 0;
  double share_over_45_deg = 0;  // of those pixels
};

struct Evaluation {
  std::vector<ParameterError> parameters;   // empty without a reference
  AnisotropicAlphaError anisotropic_alpha;  // with a reference
  double normal_median_deg = 0;
  double normal_p90_deg = 0;
  std::vector<MapNoise> map_noise;
  std::vector<RenderError> fit_vs_measured;
  std::vector<RenderError> reference_vs_measured;  // empty without a reference
  double FitL1() const;                            // the "all" group
  double ReferenceL1() const;
  void Report(std::ostream& out) const;  // a few lines: parameter NRMSE, normal error, map noise, re-render L1
};

Result<Evaluation> Evaluate(const Image& maps, const std::optional<Image>& reference, const ObservationStack& stack);

// Shading normals against a reference normal map (a photometric-stereo benchmark's ground truth,
// or a simulated object's): the angle between them over the pixels both have, and the same by
// the reference's tilt (its angle off the stack's z axis) in bands of 10°.
struct NormalComparison {
  struct Band {
    double from_deg = 0, to_deg = 0;
    int pixels = 0;
    double mean_deg = 0;
  };
  int pixels = 0;  // compared: fitted, and a reference normal there
  double mean_deg = 0, median_deg = 0, p90_deg = 0;
  std::vector<Band> bands;  // 0–10°, …, 80–90° of true tilt; empty bands left out
  nlohmann::json ToJson() const;
  void Report(std::ostream& out) const;
};
// `reference`: channels X, Y, Z on the stack's grid, in the stack's sample frame (y down the
// image; a zero or NaN vector: no reference there). The fit's n_s, in each pixel's local
// geometric frame, is turned into the sample frame first. Grids must match.
Result<NormalComparison> CompareNormals(const Image& maps, const ObservationStack& stack, const Image& reference);

// The mean of observation `observation`'s measured values over the pixels that see it (0 when
// none does).
double MeanObservedRadiance(const ObservationStack& stack, int observation);

// The model re-rendered for the given stack observations: one channel per observation, named
// as in the stack; NaN where the stack has no usable value (unseen or cast-shadowed).
Image RenderObservations(const Image& maps, const ObservationStack& stack, const std::vector<int>& observations);

}  // namespace loom::fitting
