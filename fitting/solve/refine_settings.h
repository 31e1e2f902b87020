#pragma once
// The refiner's settings picked for a model's rig on its training fabrics, in the model
// directory beside the CNN (refine.json): the smoothing pass's weight and a_s scale, whether poor
// fits are retried, the function tolerance that ends a pixel's fit, and F0 (docs/benchmarks.md).
// They differ by rig: tac7-mini's speckled maps gain from the pass, which restarts every pixel
// from its neighbours' median lobe and so leaves the retries nothing to gain there (nor the first
// fit's last small steps), while on tac7's richer stacks the same prior over-smooths σ and α. A
// model without the file leaves the built-in defaults (retries, no smoothing pass, 1e-4).

#include <filesystem>

#include "core/status.h"
#include "fitting/solve/stack_fitter.h"

namespace loom::fitting {

inline constexpr const char* kRefineSettingsFile = "refine.json";

// What the user set explicitly (loom fit's --smoothing-weight, --retries / --no-retries,
// --function-tolerance, --f0): those win over the file.
struct RefineSettingsGiven {
  bool smoothing_weight = false;
  bool retries = false;
  bool function_tolerance = false;
  bool f0 = false;
};

// Applies `model_dir`'s refine.json (if it has one) to `options`; the retries and F0 only where the
// method fits with the batched refiner (`refiner`). An unknown key or a value out of range is an
// error naming the file and the key, and leaves `options` as they were.
Status ApplyRefineSettings(const std::filesystem::path& model_dir, bool refiner, RefineSettingsGiven given,
                           StackFitOptions& options);

}  // namespace loom::fitting
