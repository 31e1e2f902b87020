#pragma once
// The grid search's pieces (grid_start.cc), shared by its scalar form (GridInitialParams, the
// Ceres fit's) and the batched one the refiner retries with (batch_refiner.h: GridStarts).

#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "fitting/model/ward_gd10.h"

namespace loom::fitting::internal {

// 13 normals (up to 20° tilt) × 28 lobe shapes (σ from 0.03 to 0.3, isotropic and anisotropic at
// 4 angles), albedos 0, F0 = f0.
std::vector<WardParams<double>> GridCandidates(double f0, bool isotropic_only = false);

// The `count` (at least 1) candidates of lowest cost, best first.
std::vector<WardParams<double>> Best(std::vector<std::pair<double, WardParams<double>>> scored, int count);

// The non-negative least-squares albedos (a_d RGB, a_s RGB) of a shape from its normal
// equations, one active-set pass, clamped to kMaxAlbedo.
Eigen::Matrix<double, 6, 1> SolveAlbedos(Eigen::Matrix<double, 6, 6> normal, Eigen::Matrix<double, 6, 1> rhs);

}  // namespace loom::fitting::internal
