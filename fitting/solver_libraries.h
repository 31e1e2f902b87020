#pragma once
// The Ceres and LibTorch libraries this build uses.
#include <vector>

#include "core/version.h"

namespace loom::fitting {
std::vector<LinkedLibrary> SolverLibraries();
}
