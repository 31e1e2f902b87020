#pragma once
// Self-calibration of a capture's directional lights: each light's direction and its intensity
// per colour channel re-estimated from the fitted maps. A light dome's or photometric-stereo rig's
// calibration errs by a degree or two and a few per cent (chrome-sphere directions, white-target
// intensities); a GD10 fit places a highlight by the few lights near the mirror direction, so
// their errors tilt its normals where photometric stereo averages them over every light. Held
// fixed the maps of a first fit, every light's correction is a small least-squares problem over
// thousands of pixels; the stack's lights corrected, the fit runs again.

#include <vector>

#include <nlohmann/json.hpp>

#include "core/image.h"
#include "core/observation_stack.h"
#include "core/status.h"

namespace loom::fitting {

struct LightCorrection {
  std::vector<int> observations;                             // the view's observations (one per colour channel), one light
  Eigen::Vector3d towards_light = Eigen::Vector3d::UnitZ();  // corrected, unit
  std::vector<double> gains;                                 // per observation: the corrected intensity ÷ the stack's
  double turn_deg = 0;                                       // between the stack's direction and the corrected one
  int pixels = 0;                                            // the pixels the estimate used
};

struct LightRefinement {
  std::vector<LightCorrection> lights;
  // The common rotation and gain taken out of the corrections: a rotation of every light and
  // every normal together, or a gain of every light against every albedo, renders the same
  // images, so the stack's calibration keeps its frame and its scale.
  double common_turn_deg = 0;
  double normal_spread = 0;  // the smallest eigenvalue of the fitted normals' mean n nᵀ
  double seconds = 0;
  double MeanTurnDeg() const;
  double MaxTurnDeg() const;
  // The spread of the gains (the standard deviation of their logarithms).
  double GainSpread() const;
  // Whether the corrections are larger than what a fit's own bias makes of a calibration without
  // errors (kMinMeanTurnDeg, kMinGainSpread): on simulated objects whose files hold the true
  // lights, the estimate turned them 0.01–0.08° on average and spread their gains by at most
  // 0.1 %, and relighting by that made a broad lobe's normals worse (0.67° → 0.70°); with a dome's
  // errors (1.5°, 3 %) it turned them 0.6–1.1° and spread the gains by 2 %.
  bool WorthApplying() const;
  nlohmann::json ToJson() const;
};

// The corrections of the stack's directional lights given maps fitted to it. A view with too few
// lit pixels (kMinLightPixels) keeps its light. No corrections (an empty `lights`) where the
// stack has a point light or a view with more than one light, or where the fitted normals span
// too little (normal_spread < kMinNormalSpread): a Lambertian surface's shading tells a light's
// direction only along the normals it has, so on a cylinder a light's elevation trades against its
// intensity (a calibrated one's was turned 6° along that valley), and on a flat sample its
// azimuth is not seen at all.
inline constexpr int kMinLightPixels = 50;
inline constexpr double kMinMeanTurnDeg = 0.2;
inline constexpr double kMinGainSpread = 0.01;
inline constexpr double kMinNormalSpread = 0.05;
Result<LightRefinement> EstimateLightCorrections(const ObservationStack& stack, const Image& maps, int threads);

// The stack with the corrected lights.
ObservationStack WithCorrectedLights(ObservationStack stack, const LightRefinement& refinement);

// Whether every observation of the stack is lit by one directional light (loom import's ps and lp
// layouts): what EstimateLightCorrections corrects.
bool HasOnlyDirectionalLights(const ObservationStack& stack);

}  // namespace loom::fitting
