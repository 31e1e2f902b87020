// Plans as YAML: what a scan directory keeps in plan.yaml, so that resuming, calibration and
// reconstruction read the steps that were really planned, whatever the presets say today.
#include <yaml-cpp/yaml.h>

#include <algorithm>

#include "core/config.h"
#include "scan/plan.h"

namespace loom::scan {
namespace {

constexpr int kPlanSchemaVersion = 1;

void EmitStep(YAML::Emitter& out, const Step& step) {
  out << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "index" << YAML::Value << step.index;
  out << YAML::Key << "kind" << YAML::Value << std::string(StepKindName(step.kind));
  out << YAML::Key << "cameras" << YAML::Value << YAML::Flow << step.cameras;
  if (!step.leds.empty()) {
    std::vector<int> leds;
    std::vector<double> currents;
    for (const LedDrive& led : step.leds) {
      leds.push_back(led.led);
      currents.push_back(led.current_ma);
    }
    out << YAML::Key << "leds" << YAML::Value << YAML::Flow << leds;
    out << YAML::Key << "currents_ma" << YAML::Value << YAML::Flow << currents;
  }
  if (step.filter) {
    out << YAML::Key << "filter" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "wheel" << YAML::Value
        << step.filter->wheel << YAML::Key << "slot" << YAML::Value << step.filter->slot << YAML::Key << "center_nm"
        << YAML::Value << step.filter->center_nm << YAML::EndMap;
  }
  out << YAML::Key << "turntable_deg" << YAML::Value << step.turntable_deg;
  if (step.linear_light_mm) out << YAML::Key << "linear_light_mm" << YAML::Value << *step.linear_light_mm;
  if (!step.projector_pattern.empty()) out << YAML::Key << "pattern" << YAML::Value << step.projector_pattern;
  out << YAML::Key << "object" << YAML::Value << std::string(ScanObjectName(step.object));
  out << YAML::Key << "probe_exposure_us" << YAML::Value << step.exposure.probe_us;
  out << YAML::Key << "max_exposures" << YAML::Value << step.exposure.max_exposures;
  if (step.exposure.linearity_series > 0) out << YAML::Key << "linearity_series" << YAML::Value << step.exposure.linearity_series;
  if (!step.windows.empty()) {
    out << YAML::Key << "windows" << YAML::Value << YAML::Flow << YAML::BeginMap;
    for (const auto& [camera, roi] : step.windows) {
      out << YAML::Key << camera << YAML::Value << YAML::Flow << std::vector<int>{roi.x, roi.y, roi.width, roi.height};
    }
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
}

// A step's windows: camera name → [x, y, width, height] inside the sensor, for a camera the
// step uses.
void ReadWindows(const ConfigNode& windows, Step& step) {
  for (const std::string& camera : windows.Keys()) {
    std::vector<int> roi;
    windows.Required(camera, &roi);
    if (std::find(step.cameras.begin(), step.cameras.end(), camera) == step.cameras.end()) {
      windows.AddError(camera, "is not one of the step's cameras");
    } else if (roi.size() != 4 || roi[0] < 0 || roi[1] < 0 || roi[2] < 1 || roi[3] < 1) {
      windows.AddError(camera, "must be [x, y, width, height] with x, y >= 0 and width, height >= 1");
    } else {
      step.windows[camera] = {roi[0], roi[1], roi[2], roi[3]};
    }
  }
}

Step ReadStep(const ConfigNode& node, int expected_index) {
  Step step;
  node.Required("index", &step.index);
  if (step.index != expected_index) node.AddError("index", "is out of order: expected " + std::to_string(expected_index));
  std::string kind;
  node.Required("kind", &kind);
  if (std::optional<StepKind> parsed = ParseStepKind(kind)) {
    step.kind = *parsed;
  } else {
    node.AddError("kind", "unknown step kind '" + kind + "'");
  }
  node.Required("cameras", &step.cameras);
  if (node.Has("cameras") && step.cameras.empty()) node.AddError("cameras", "is empty: every step is taken by a camera");
  std::vector<int> leds;
  std::vector<double> currents;
  node.Optional("leds", &leds);
  node.Optional("currents_ma", &currents);
  if (leds.size() != currents.size()) node.AddError("currents_ma", "needs one current per LED");
  for (size_t i = 0; i < std::min(leds.size(), currents.size()); ++i) step.leds.push_back({leds[i], currents[i]});
  if (std::optional<ConfigNode> filter = node.OptionalChild("filter")) {
    FilterSetting setting;
    filter->Required("wheel", &setting.wheel);
    filter->Required("slot", &setting.slot);
    filter->Required("center_nm", &setting.center_nm);
    step.filter = setting;
  }
  node.Required("turntable_deg", &step.turntable_deg);
  if (node.Has("linear_light_mm")) {
    double mm = 0;
    node.Required("linear_light_mm", &mm);
    step.linear_light_mm = mm;
  }
  node.Optional("pattern", &step.projector_pattern);
  std::string object;
  node.Required("object", &object);
  if (std::optional<ScanObject> parsed = ParseScanObject(object)) {
    step.object = *parsed;
  } else {
    node.AddError("object", "unknown object '" + object + "'");
  }
  node.Required("probe_exposure_us", &step.exposure.probe_us);
  if (!(step.exposure.probe_us > 0)) node.AddError("probe_exposure_us", "must be > 0");
  node.Required("max_exposures", &step.exposure.max_exposures);
  if (step.exposure.max_exposures < 1) node.AddError("max_exposures", "must be >= 1");
  node.Optional("linearity_series", &step.exposure.linearity_series);
  if (step.exposure.linearity_series < 0) node.AddError("linearity_series", "must be >= 0");
  if (std::optional<ConfigNode> windows = node.OptionalChild("windows")) ReadWindows(*windows, step);
  return step;
}

}  // namespace

std::string PlanToYaml(const Plan& plan) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);  // positions and currents come back bit for bit
  out << YAML::BeginMap;
  out << YAML::Key << "schema_version" << YAML::Value << kPlanSchemaVersion;
  out << YAML::Key << "rig" << YAML::Value << plan.rig;
  out << YAML::Key << "preset" << YAML::Value << plan.preset;
  out << YAML::Key << "purpose" << YAML::Value << std::string(PlanPurposeName(plan.purpose));
  out << YAML::Key << "steps" << YAML::Value << YAML::BeginSeq;
  for (const Step& step : plan.steps) EmitStep(out, step);
  out << YAML::EndSeq << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

Result<Plan> ParsePlanYaml(std::string_view text, const std::string& source_name) {
  LOOM_ASSIGN_OR_RETURN(const ConfigDocument doc, ConfigDocument::LoadString(text, source_name, kPlanSchemaVersion));
  Plan plan;
  doc.root().Required("rig", &plan.rig);
  doc.root().Required("preset", &plan.preset);
  std::string purpose;
  doc.root().Required("purpose", &purpose);
  if (std::optional<PlanPurpose> parsed = ParsePlanPurpose(purpose)) {
    plan.purpose = *parsed;
  } else {
    doc.root().AddError("purpose", "expected material or calibration, got '" + purpose + "'");
  }
  for (const ConfigNode& node : doc.root().Sequence("steps")) {
    plan.steps.push_back(ReadStep(node, static_cast<int>(plan.steps.size())));
  }
  LOOM_RETURN_IF_ERROR(doc.Finish());
  return plan;
}

}  // namespace loom::scan
