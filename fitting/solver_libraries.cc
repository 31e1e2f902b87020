#include "fitting/solver_libraries.h"

#include <ceres/version.h>
#include <torch/version.h>

namespace loom::fitting {

std::vector<LinkedLibrary> SolverLibraries() { return {{"Ceres", CERES_VERSION_STRING}, {"LibTorch", TORCH_VERSION}}; }

}  // namespace loom::fitting
