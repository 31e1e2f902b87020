#pragma once
// Whether a pixel's observations see its specular peak. GD10's lobe peaks where the half-vector
// meets the normal; where no observation's half-vector reaches that far, the fit sees only the
// lobe's flank, and a normal tilted toward the views with a reshaped lobe fits that flank as well
// as the true one does (out of GD10's model, better: a real highlight's shape differs from Ward's).
// There the normal is the diffuse term's to say, not the lobe's.

#include <vector>

#include <Eigen/Core>

#include "fitting/solve/pixel_fitter.h"

namespace loom::fitting::internal {

// The signed angle (rad) from `normal` (unit, local frame) to the edge of the cone that the
// observations' half-vectors span, seen from the normal: positive inside (the peak lies among
// the views), negative outside. A strip's samples count as its brightest's half-vector. Fewer
// than three half-vectors in front of the normal span no cone: −π/2.
double PeakCoverage(const Eigen::Vector3d& normal, const std::vector<PixelObservation>& observations);

}  // namespace loom::fitting::internal
