#pragma once
// A pixel's observations into the refiner's lanes (refine_kernel.h): which observations the
// fit uses (as FitPixel: non-NaN radiance and at least one light), the batch slot of each (its
// `source`, else its position in the list), and the packing of their light samples with what
// does not depend on the parameters (the halfway vector h) computed once. Light
// samples the model zeroes whatever the parameters (l or v below the geometric horizon,
// l + v ≈ 0) are dropped here, as the Ceres cost drops them; an observation with more light
// samples than its slot holds has them merged (MergeLightSamples).

#include <vector>

#include "fitting/solve/internal/refine_kernel.h"
#include "fitting/solve/pixel_fitter.h"

namespace loom::fitting::internal {

struct UsableObservations {
  std::vector<const PixelObservation*> observations;  // into the list given to Usable
  std::vector<int> slots;
};

UsableObservations Usable(const std::vector<PixelObservation>& all);

// Empties `lane` and writes the observations into it; returns 1 / the mean |radiance| (1 if 0).
// CHECK-fails when an observation's slot is outside the data's layout.
double LoadLane(const UsableObservations& usable, int lane, LaneData& data);

}  // namespace loom::fitting::internal
