// loom plan: what a scan of a rig with a gloss preset captures, and how long it will take.
#include <iostream>

#include "apps/command.h"
#include "apps/config_paths.h"
#include "scan/plan.h"

namespace loom::apps {
namespace {

Status ShowPlan(const std::string& rig_path, const std::string& preset_name, bool calibration, bool steps, bool yaml) {
  const scan::PlanPurpose purpose = calibration ? scan::PlanPurpose::kCalibration : scan::PlanPurpose::kMaterial;
  LOOM_ASSIGN_OR_RETURN(const scan::Plan plan,
                        scan::MakePlanForRigFile(ResolveRigPath(rig_path), ResolvePresetPath(preset_name), purpose));
  if (yaml) {
    std::cout << scan::PlanToYaml(plan);
    return Status::Ok();
  }
  scan::ReportPlan(std::cout, plan);
  if (steps) {
    for (const scan::Step& step : plan.steps) std::cout << scan::DescribeStep(step) << "\n";
  }
  return Status::Ok();
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
  app.add_option("--rig", rig_path, "Rig YAML with a geometry: section, or its name in configs/rig/")->required();
  app.add_option("--preset", preset_name, "low, medium, high (configs/plans/) or a preset file");
  app.add_flag("--calibration", calibration, "The calibration scan instead of a material scan");
  app.add_flag("--steps", steps, "List every step");
  app.add_flag("--yaml", yaml, "Print the expanded plan as YAML (what a scan keeps in SCAN/plan.yaml)");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;

  return ExitCode(ShowPlan(rig_path, preset_name, calibration, steps, yaml));
}

}  // namespace loom::apps
