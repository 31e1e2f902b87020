#include "sim/plan_observations.h"

namespace loom::sim {
namespace {

using scan::Step;
using scan::StepKind;

template <typename Device>
Result<int> IndexOf(const std::vector<Device>& devices, const std::string& name, const Step& step) {
  for (size_t i = 0; i < devices.size(); ++i) {
    if (devices[i].name == name) return static_cast<int>(i);
  }
  return NotFoundError("plan step " + std::to_string(step.index), "'" + name + "' is not in the rig geometry");
}

Result<SceneState> StateOf(const RigModel& rig, const Step& step) {
  SceneState state;
  state.turntable_deg = step.turntable_deg;
  for (const scan::LedDrive& led : step.leds) state.leds.push_back({led.led, led.current_ma});
  if (step.filter) {
    LOOM_ASSIGN_OR_RETURN(const int wheel, IndexOf(rig.filter_wheels, step.filter->wheel, step));
    state.filter_slots[wheel] = step.filter->slot;
  }
  if (step.linear_light_mm) {
    state.linear_light_on = true;
    state.linear_light_mm = *step.linear_light_mm;
  }
  return state;
}

}  // namespace

Result<std::vector<Observation>> PlanObservations(const RigModel& rig, const scan::Plan& plan) {
  std::vector<Observation> observations;
  for (const Step& step : plan.steps) {
    if (!scan::IsObservationStep(step.kind)) continue;
    LOOM_ASSIGN_OR_RETURN(const SceneState state, StateOf(rig, step));
    for (const std::string& camera : step.cameras) {
      LOOM_ASSIGN_OR_RETURN(const int index, IndexOf(rig.cameras, camera, step));
      observations.push_back({index, state});
    }
  }
  return observations;
}

Result<std::vector<Observation>> PresetObservations(const RigModel& rig, const scan::Preset& preset) {
  LOOM_ASSIGN_OR_RETURN(const scan::Plan plan, scan::MakeMaterialPlan(rig, preset));
  return PlanObservations(rig, plan);
}

}  // namespace loom::sim
