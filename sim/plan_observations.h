#pragma once
// The observations a material plan makes, as the simulator's fast path renders them: one per
// camera of every colour, monochrome and linear-light step (dark and structured-light steps
// are not observations).

#include <vector>

#include "scan/plan.h"
#include "sim/stack.h"

namespace loom::sim {

// Cameras and wheels are looked up by name in `rig`; a name it lacks is an error naming it.
Result<std::vector<Observation>> PlanObservations(const RigModel& rig, const scan::Plan& plan);

// Those of the material plan `preset` makes on `rig` (what loom train and sim render --stack render).
Result<std::vector<Observation>> PresetObservations(const RigModel& rig, const scan::Preset& preset);

}  // namespace loom::sim
