#pragma once
// What the refiner's smoothing pass (fitting/solve/stack_fitter.cc) pulls each pixel's lobe toward:
// the median lobe of its neighbours' fits. A weave's yarns are about a stack pixel wide and
// differ in their anisotropy angle (often by ~90°, ±45°), so a plain median over a pixel's
// neighbours mixes both yarns; the mean of 2α over two yarns 90° apart is meaningless and drew
// the angle toward 0°/180°. A guide (the CNN's maps, which see a 15 × 15 neighbourhood and so
// tell the yarns apart) weighs each neighbour by how alike it and the pixel are in the guide.

#include <vector>

#include "core/image.h"
#include "fitting/model/ward_gd10.h"

namespace loom::fitting::internal {

// The smoothing pass's neighbourhood: the (2 r + 1)² square around a pixel, the pixel left out.
// On the training fabric (fabric:1003, docs/benchmarks.md) 5 × 5 against 3 × 3, at the same
// weight: σ NRMSE 0.118 → 0.103, α 0.297 → 0.257 and a lower re-render L1; a one-pixel speckle
// outvotes a 3 × 3 median's 8 noisy neighbours more often than a 5 × 5 one's 24.
inline constexpr int kSmoothingRadius = 2;

// For each pixel of a width × height grid of fits (row-major): the median lobe of its
// neighbours within kSmoothingRadius — a_s, σx, σy and F0 each the median (σ compared with
// σx ≥ σy), α the mean direction of (cos 2α, sin 2α); normal and a_d left at their defaults (the
// pass keeps the pixel's own). `guide`: maps on the same grid (fitting/model/svbrdf_maps.h) whose anisotropy
// angles weigh each neighbour's α by cos⁴ of the angle between its guide α and the pixel's
// (weighing the medians too made σ worse on all three training fabrics); nullptr: every
// neighbour alike.
std::vector<WardParams<double>> NeighbourLobes(const std::vector<WardParams<double>>& fits, int width, int height,
                                               const Image* guide);

}  // namespace loom::fitting::internal
