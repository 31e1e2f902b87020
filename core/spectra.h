#pragma once
// A spectral model just detailed enough for colour through filters: a material's linear-sRGB
// albedo is turned into a reflectance spectrum as a sum of three smooth basis spectra (red,
// green, blue bumps), lit by a white phosphor LED and seen by a panchromatic sensor. What a
// monochrome camera records of albedo a through filter f is then linear in a: w_f · a. Weights
// are normalised so that, unfiltered, a grey albedo g records as g.
// This is a rig's nominal colour response: the simulator renders with it, and reconstruction
// uses it for a rig without a colour calibration.

#include <Eigen/Core>

#include "core/rig_model.h"

namespace loom {

// Weights of (R, G, B) albedo seen without a filter: they sum to 1.
Eigen::Vector3d PanchromaticWeights();
// Weights seen through a band-pass filter (Gaussian transmission): small, they sum to the
// filter's share of the panchromatic signal. An open slot sees the panchromatic weights (the
// white reference defines them); a band-pass slot with measured weights (radiometric
// calibration) sees those.
Eigen::Vector3d FilterWeights(const FilterModel& filter);

}  // namespace loom
