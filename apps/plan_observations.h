#pragma once
// The observations a material plan makes, as the simulator's fast path renders them: one per
// camera of every colour, monochrome and linear-light step (dark and structured-light steps
// are not observations). apps is where acquisition's plans and the simulator meet.

#include <vector>

#include "scan/plan.h"
#include "sim/stack.h"

namespace loom::apps {

// Cameras and wheels are looked up by name in `rig`; a name it lacks is an error naming it.
Result<std::vector<sim::Observation>> PlanObservations(const RigModel& rig, const scan::Plan& plan);

}  // namespace loom::apps
