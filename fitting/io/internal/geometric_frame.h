#pragma once
// The local geometric frame of a maps pixel (fitting/model/svbrdf_maps.h) in the sample frame, for exporters
// that carry the shading normal in the flat sample's frame (glTF, AxF-style).

#include <Eigen/Core>

#include "core/image.h"

namespace loom::fitting::internal {

// z the heightmap's normal (central differences, one-sided at the borders), x the sample's x
// made orthogonal to it. Identity without a height channel.
Eigen::Matrix3d SampleFromLocal(const Image& maps, int x, int y, double pixel_mm);

}  // namespace loom::fitting::internal
