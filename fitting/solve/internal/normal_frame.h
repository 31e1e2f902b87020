#pragma once
// A pixel's observations turned into the frame of its photometric-stereo normal (lambert_fit.h),
// and fits made there turned back. On a curved surface, pixels of one appearance cluster have
// different normals: pooled as they are, their observations make one broad lobe that fits none
// of them; turned each onto its own normal first, they share one lobe. A grid search around the
// turned observations searches around that normal, not around the geometric one.

#include <vector>

#include <Eigen/Core>

#include "fitting/solve/pixel_fitter.h"

namespace loom::fitting::internal {

// The smallest rotation taking `normal` (unit, the pixel's local frame) to +z.
Eigen::Matrix3d TurnOntoZ(const Eigen::Vector3d& normal);

// Every view and light direction of `observations` turned by `turn`.
void TurnObservations(const Eigen::Matrix3d& turn, std::vector<PixelObservation>& observations);

// A fit made in the turned frame, back in the pixel's local frame (its n_s turned back).
WardParams<double> TurnedBack(const Eigen::Matrix3d& turn, WardParams<double> params);

}  // namespace loom::fitting::internal
