// loom plan: what a scan of a rig with a gloss preset captures, and how long it will take.
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>

#include "apps/command.h"
#include "apps/rig_loader.h"
#include "scan/plan.h"

namespace loom::apps {
namespace {

using scan::Plan;
using scan::Step;
using scan::StepKind;

void PrintStep(const Step& step) {
  std::cout << "  " << std::setw(5) << step.index << "  " << std::left << std::setw(17) << scan::StepKindName(step.kind)
            << std::right << " table " << std::setw(5) << step.turntable_deg << " deg";
  for (const scan::LedDrive& led : step.leds) {
    if (step.leds.size() <= 3) std::cout << "  LED " << led.led << " @ " << led.current_ma << " mA";
  }
  if (step.leds.size() > 3) std::cout << "  " << step.leds.size() << " LEDs";
  if (step.filter) {
    std::cout << "  " << step.filter->wheel << " slot " << step.filter->slot << " (" << step.filter->center_nm << " nm)";
  }
  if (step.linear_light_mm) std::cout << "  strip at " << *step.linear_light_mm << " mm";
  if (!step.projector_pattern.empty()) std::cout << "  pattern " << step.projector_pattern;
  std::cout << "  cameras";
  for (const std::string& camera : step.cameras) std::cout << " " << camera;
  std::cout << "  [" << scan::ScanObjectName(step.object) << "]\n";
}

}  // namespace

int RunPlan(int argc, char** argv) {
  CLI::App app("Show the measurement plan of a rig and a gloss preset, with its estimated duration", "loom plan");
  AddCommonOptions(app);
  std::string rig_path;
  std::string preset_name = "low";
  bool calibration = false;
  bool steps = false;
  bool yaml = false;
  app.add_option("--rig", rig_path, "Rig YAML with a geometry: section")->required();
  app.add_option("--preset", preset_name, "low, medium, high (configs/plans/) or a preset file");
  app.add_flag("--calibration", calibration, "The calibration scan instead of a material scan");
  app.add_flag("--steps", steps, "List every step");
  app.add_flag("--yaml", yaml, "Print the expanded plan as YAML (what a scan keeps in SCAN/plan.yaml)");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;

  Result<RigModel> rig = LoadRigModel(rig_path);
  if (!rig.ok()) return ReportFailure(rig.status());
  Result<scan::Preset> preset = scan::LoadPreset(ResolvePresetPath(preset_name));
  if (!preset.ok()) return ReportFailure(preset.status());
  Result<Plan> plan = calibration ? scan::MakeCalibrationPlan(*rig, *preset) : scan::MakeMaterialPlan(*rig, *preset);
  if (!plan.ok()) return ReportFailure(plan.status());
  if (yaml) {
    std::cout << scan::PlanToYaml(*plan);
    return kExitOk;
  }

  std::cout << scan::PlanPurposeName(plan->purpose) << " scan of rig '" << plan->rig << "' with preset '" << plan->preset
            << "': " << plan->steps.size() << " steps, " << plan->Images() << " images (before HDR bracketing)\n";
  std::map<StepKind, std::pair<int, int>> by_kind;
  for (const Step& step : plan->steps) {
    ++by_kind[step.kind].first;
    by_kind[step.kind].second += step.images();
  }
  for (const auto& [kind, counts] : by_kind) {
    std::cout << "  " << std::left << std::setw(17) << scan::StepKindName(kind) << std::right << std::setw(6) << counts.first
              << " steps " << std::setw(6) << counts.second << " images\n";
  }
  const scan::DurationModel model;
  std::cout << "estimated duration: " << FormatDuration(scan::EstimateSeconds(*plan, model)) << " ("
            << model.exposures_per_bracket << " exposures per bracket, " << model.frame_overhead_s << " s per frame, turntable "
            << model.turntable_deg_s << " deg/s, strip " << model.linear_light_mm_s << " mm/s)\n";
  if (steps) {
    for (const Step& step : plan->steps) PrintStep(step);
  }
  return kExitOk;
}

}  // namespace loom::apps
