#include "scan/plan.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

#include "core/config.h"
#include "core/duration.h"
#include "scan/patterns.h"

namespace loom::scan {
namespace {

constexpr int kPresetSchemaVersion = 1;

std::vector<std::string> AllCameras(const RigModel& rig) {
  std::vector<std::string> names;
  for (const CameraModel& camera : rig.cameras) names.push_back(camera.name);
  return names;
}

double ZenithDeg(const CameraModel& camera) {
  return RadToDeg(std::acos(std::clamp(camera.CentreInRig().normalized().z(), -1.0, 1.0)));
}

// The camera nearest each wanted view angle (each camera at most once), in the rig's order.
std::vector<std::string> ColourCameras(const RigModel& rig, const std::vector<double>& views_deg) {
  std::set<int> chosen;
  for (double view : views_deg) {
    int best = -1;
    for (int i = 0; i < static_cast<int>(rig.cameras.size()); ++i) {
      if (chosen.contains(i)) continue;
      if (best < 0 || std::abs(ZenithDeg(rig.cameras[i]) - view) < std::abs(ZenithDeg(rig.cameras[best]) - view)) best = i;
    }
    if (best >= 0) chosen.insert(best);
  }
  std::vector<std::string> names;
  for (int i : chosen) names.push_back(rig.cameras[i].name);
  return names;
}

// Every LED lights monochrome steps, so a wheel in front of one needs an open slot: through a
// band-pass filter the "monochrome" image would be coloured.
Status CheckOpenSlots(const RigModel& rig) {
  for (const FilterWheelModel& wheel : rig.filter_wheels) {
    if (!wheel.OpenSlot()) {
      return FailedPreconditionError(
          "rig '" + rig.name + "', filter wheel '" + wheel.name + "'",
          "has no open slot for LED " + std::to_string(wheel.led) + "'s monochrome steps: add {open: true} to its filters");
    }
  }
  return {};
}

// The LED nearest the zenith (the first of several as near).
int ZenithLed(const RigModel& rig) {
  int zenith = 0;
  for (int led = 1; led < static_cast<int>(rig.leds.size()); ++led) {
    if (rig.leds[led].position_mm.normalized().z() > rig.leds[zenith].position_mm.normalized().z()) zenith = led;
  }
  return zenith;
}

// Exposures of a linearity series: from 90 % of full scale down to 1/64 of that (~60 DN at 12 bits).
constexpr int kLinearitySeries = 7;
// Carriage positions at which the chrome sphere is seen under the linear light.
constexpr int kProbeStripPositions = 3;
// The chrome sphere mirrors each LED's (and the strip's) emitting surface: its highlight
// outshines the diffuse objects that a preset's bracket is sized for by orders of magnitude (on
// tac7, still saturated after 5 exposures, each 4x shorter, from 10 ms). Its brackets may reach
// this many exposures further; like every bracket they stop once nothing saturates.
constexpr int kProbeExtraExposures = 2;

class PlanBuilder {
 public:
  PlanBuilder(const RigModel& rig, const Preset& preset, PlanPurpose purpose) : rig_(rig), preset_(preset) {
    plan_.rig = rig.name;
    plan_.preset = preset.name;
    plan_.purpose = purpose;
  }

  Step& Add(StepKind kind, std::vector<std::string> cameras, double turntable_deg, ScanObject object) {
    Step step;
    step.index = static_cast<int>(plan_.steps.size());
    step.kind = kind;
    step.cameras = std::move(cameras);
    step.turntable_deg = turntable_deg;
    step.object = object;
    step.exposure = preset_.exposure;
    if (kind == StepKind::kLightProbe) step.exposure.max_exposures += kProbeExtraExposures;
    plan_.steps.push_back(std::move(step));
    return plan_.steps.back();
  }

  void StructuredLight(double angle, ScanObject object) {
    if (!rig_.projector) return;
    for (const std::string& pattern : StructuredLightPatterns(rig_.projector->width, preset_.gray_bits, preset_.phase_steps)) {
      Add(StepKind::kStructuredLight, AllCameras(rig_), angle, object).projector_pattern = pattern;
    }
  }

  // Every filter of every wheel, for `cameras`.
  void Filtered(StepKind kind, const std::vector<std::string>& cameras, ScanObject object) {
    for (const FilterWheelModel& wheel : rig_.filter_wheels) {
      for (int slot = 0; slot < static_cast<int>(wheel.filters.size()); ++slot) {
        if (wheel.filters[slot].open) continue;
        Step& step = Add(kind, cameras, 0, object);
        step.leds = {{wheel.led, preset_.led_current_ma}};
        step.filter = FilterSetting{wheel.name, slot, wheel.filters[slot].center_nm};
      }
    }
  }

  // An LED behind a filter wheel shines through the wheel's open slot (MakeMaterialPlan and
  // MakeCalibrationPlan check that there is one).
  void EveryLed(StepKind kind, double angle, ScanObject object) {
    for (int led = 0; led < static_cast<int>(rig_.leds.size()); ++led) LightOnly(led, Add(kind, AllCameras(rig_), angle, object));
  }

  // `led` alone lights `step`, through its wheel's open slot.
  void LightOnly(int led, Step& step) const {
    step.leds = {{led, preset_.led_current_ma}};
    if (const FilterWheelModel* wheel = rig_.WheelOfLed(led)) step.filter = FilterSetting{wheel->name, *wheel->OpenSlot(), 0};
  }

  void LinearLight(double angle) {
    const int n = preset_.linear_light_positions;
    const double travel = rig_.linear_light->travel_mm;
    for (int k = 0; k < n; ++k) {
      Add(StepKind::kLinearLight, AllCameras(rig_), angle, ScanObject::kSample).linear_light_mm =
          n == 1 ? travel / 2 : travel * k / (n - 1);
    }
  }

  // The chrome sphere under the linear light alone at kProbeStripPositions carriage positions,
  // spread over the travel but short of its ends, where the strip's streak nears the sphere's
  // rim in some camera: for the sweep's angles (calibration/light_positions.h).
  void StripOverProbe() {
    const double travel = rig_.linear_light->travel_mm;
    for (int k = 0; k < kProbeStripPositions; ++k) {
      const double fraction = 0.1 + 0.8 * k / (kProbeStripPositions - 1);
      Add(StepKind::kLightProbe, AllCameras(rig_), 0, ScanObject::kChromeSphere).linear_light_mm = travel * fraction;
    }
  }

  // The white reference under the LED nearest the zenith also takes a linearity series.
  void LinearitySeries() {
    const int zenith = ZenithLed(rig_);
    for (Step& step : plan_.steps) {
      if (step.kind == StepKind::kWhiteReference && step.leds.size() == 1 && step.leds[0].led == zenith) {
        step.exposure.linearity_series = kLinearitySeries;
        return;
      }
    }
  }

  // Drift references (plan.h) among the steps built so far, which are renumbered.
  void InsertDriftReferences(int every) {
    const bool strip = std::ranges::any_of(plan_.steps, [](const Step& s) { return s.kind == StepKind::kLinearLight; });
    std::vector<Step> steps;
    bool started = false;
    int since = 0;
    double angle = 0;
    for (Step& step : plan_.steps) {
      if (!started && IsObservationStep(step.kind)) {
        AddDriftReferences(step.turntable_deg, strip, steps);
        started = true;
      } else if (started && step.turntable_deg != angle) {
        AddDriftReferences(angle, strip, steps);  // the same light just before and after the move
        AddDriftReferences(step.turntable_deg, strip, steps);
        since = 0;
      } else if (started && since >= every) {
        AddDriftReferences(step.turntable_deg, strip, steps);
        since = 0;
      }
      angle = step.turntable_deg;
      if (started) ++since;
      steps.push_back(std::move(step));
    }
    if (started) AddDriftReferences(angle, strip, steps);
    for (size_t i = 0; i < steps.size(); ++i) steps[i].index = static_cast<int>(i);
    plan_.steps = std::move(steps);
  }

  Plan Finish() { return std::move(plan_); }

 private:
  // The LED nearest the zenith, through its wheel's open slot, every camera, one exposure; and,
  // in a plan with linear-light steps, the strip alone at the middle of its travel likewise.
  void AddDriftReferences(double angle, bool strip, std::vector<Step>& steps) const {
    Step step;
    step.kind = StepKind::kDriftReference;
    step.cameras = AllCameras(rig_);
    step.turntable_deg = angle;
    step.exposure = preset_.exposure;
    step.exposure.max_exposures = 1;  // every reference at the same exposure: their ratios are the drift
    Step led = step;
    LightOnly(ZenithLed(rig_), led);
    steps.push_back(std::move(led));
    if (!strip) return;
    step.linear_light_mm = rig_.linear_light->travel_mm / 2;
    steps.push_back(std::move(step));
  }

  const RigModel& rig_;
  const Preset& preset_;
  Plan plan_;
};

}  // namespace

std::string_view StepKindName(StepKind kind) {
  switch (kind) {
    case StepKind::kDark:
      return "dark";
    case StepKind::kTarget:
      return "target";
    case StepKind::kLightProbe:
      return "light probe";
    case StepKind::kWhiteReference:
      return "white reference";
    case StepKind::kColourChart:
      return "colour chart";
    case StepKind::kStructuredLight:
      return "structured light";
    case StepKind::kColour:
      return "colour";
    case StepKind::kMonochrome:
      return "monochrome";
    case StepKind::kLinearLight:
      return "linear light";
    case StepKind::kDriftReference:
      return "drift reference";
  }
  return "unknown";
}

bool IsObservationStep(StepKind kind) {
  return kind == StepKind::kColour || kind == StepKind::kMonochrome || kind == StepKind::kLinearLight;
}

std::string ViewId::ToString() const { return "step " + std::to_string(step) + " " + camera; }

std::vector<std::string> ViewNames(const std::vector<ViewId>& views) {
  std::vector<std::string> names;
  for (const ViewId& view : views) names.push_back(view.ToString());
  return names;
}

std::string_view ScanObjectName(ScanObject object) {
  switch (object) {
    case ScanObject::kNothing:
      return "nothing (lights off)";
    case ScanObject::kSample:
      return "sample";
    case ScanObject::kTarget:
      return "target";
    case ScanObject::kChromeSphere:
      return "chrome sphere";
    case ScanObject::kWhiteTile:
      return "white tile";
    case ScanObject::kWhiteTileOnSpacer:
      return "white tile on its spacer";
    case ScanObject::kColourChart:
      return "colour chart";
  }
  return "unknown";
}

std::optional<ScanObject> ParseScanObject(std::string_view name) {
  for (ScanObject object : {ScanObject::kNothing, ScanObject::kSample, ScanObject::kTarget, ScanObject::kChromeSphere,
                            ScanObject::kWhiteTile, ScanObject::kWhiteTileOnSpacer, ScanObject::kColourChart}) {
    if (ScanObjectName(object) == name) return object;
  }
  return std::nullopt;
}

std::string_view PlanPurposeName(PlanPurpose purpose) {
  return purpose == PlanPurpose::kCalibration ? "calibration" : "material";
}

std::optional<PlanPurpose> ParsePlanPurpose(std::string_view name) {
  for (PlanPurpose purpose : {PlanPurpose::kMaterial, PlanPurpose::kCalibration}) {
    if (PlanPurposeName(purpose) == name) return purpose;
  }
  return std::nullopt;
}

std::optional<StepKind> ParseStepKind(std::string_view name) {
  for (StepKind kind : {StepKind::kDark, StepKind::kTarget, StepKind::kLightProbe, StepKind::kWhiteReference,
                        StepKind::kColourChart, StepKind::kStructuredLight, StepKind::kColour, StepKind::kMonochrome,
                        StepKind::kLinearLight, StepKind::kDriftReference}) {
    if (StepKindName(kind) == name) return kind;
  }
  return std::nullopt;
}

namespace {

// A preset's counts multiply into the plan's steps and images: each is bounded where it is read,
// so that a typo is an error naming its key, not a plan of billions of images.
void CheckPresetRanges(const ConfigNode& root, const Preset& preset) {
  constexpr int kMaxLinearLightPositions = 100000, kMaxAngles = 360, kMaxExposures = 32, kMaxGrayBits = 16, kMaxPhaseSteps = 64;
  if (preset.linear_light_positions < 0 || preset.linear_light_positions > kMaxLinearLightPositions) {
    root.AddError("linear_light_positions", "must be in [0, " + std::to_string(kMaxLinearLightPositions) + "]");
  }
  if (preset.turntable_deg.empty()) root.AddError("turntable_deg", "needs at least one angle");
  for (const auto& [key, angles] :
       {std::pair{"turntable_deg", &preset.turntable_deg}, {"colour_views_deg", &preset.colour_views_deg}}) {
    if (angles->size() > kMaxAngles) root.AddError(key, "at most " + std::to_string(kMaxAngles) + " angles");
    if (!std::ranges::all_of(*angles, [](double a) { return a >= -360 && a <= 360; }))
      root.AddError(key, "angles must be in [-360, 360]");
  }
  if (!(preset.led_current_ma > 0 && preset.led_current_ma <= 10000)) root.AddError("led_current_ma", "must be in (0, 10000] mA");
  if (!(preset.exposure.probe_us > 0 && preset.exposure.probe_us <= 1e8)) {
    root.AddError("probe_exposure_us", "must be in (0, 1e8] µs (100 s)");
  }
  if (preset.exposure.max_exposures < 1 || preset.exposure.max_exposures > kMaxExposures) {
    root.AddError("max_exposures", "must be in [1, " + std::to_string(kMaxExposures) + "]");
  }
  if (preset.gray_bits < 0 || preset.gray_bits > kMaxGrayBits) {
    root.AddError("structured_light.gray_bits",
                  "must be in [0, " + std::to_string(kMaxGrayBits) + "] (0: enough for the projector)");
  }
  if (preset.phase_steps < 0 || preset.phase_steps > kMaxPhaseSteps) {
    root.AddError("structured_light.phase_steps", "must be in [0, " + std::to_string(kMaxPhaseSteps) + "]");
  }
}

}  // namespace

Result<Preset> LoadPreset(const std::filesystem::path& path) {
  LOOM_ASSIGN_OR_RETURN(const ConfigDocument doc, ConfigDocument::LoadFile(path, kPresetSchemaVersion));
  const ConfigNode root = doc.root();
  Preset preset;
  root.Required("preset", &preset.name);
  root.Optional("turntable_deg", &preset.turntable_deg);
  root.Optional("colour_views_deg", &preset.colour_views_deg);
  root.Required("linear_light_positions", &preset.linear_light_positions);
  root.Optional("led_current_ma", &preset.led_current_ma);
  root.Optional("probe_exposure_us", &preset.exposure.probe_us);
  root.Optional("max_exposures", &preset.exposure.max_exposures);
  if (std::optional<ConfigNode> structured = root.OptionalChild("structured_light")) {
    structured->Optional("gray_bits", &preset.gray_bits);
    structured->Optional("phase_steps", &preset.phase_steps);
  }
  CheckPresetRanges(root, preset);
  LOOM_RETURN_IF_ERROR(doc.Finish());
  return preset;
}

int Plan::Images(StepKind kind) const {
  int count = 0;
  for (const Step& step : steps) {
    if (step.kind == kind) count += step.images();
  }
  return count;
}

int Plan::Images() const {
  int count = 0;
  for (const Step& step : steps) count += step.images();
  return count;
}

std::vector<std::string> StructuredLightPatterns(int projector_width, int gray_bits, int phase_steps) {
  int bits = gray_bits;
  if (bits <= 0) bits = GrayCodeBits(projector_width);
  std::vector<std::string> patterns = {"white", "black"};
  for (int b = 0; b < bits; ++b) {
    patterns.push_back(GrayPatternName(b, false));
    patterns.push_back(GrayPatternName(b, true));
  }
  for (int k = 0; k < phase_steps; ++k) patterns.push_back("phase_x_" + std::to_string(k));
  return patterns;
}

LightDriftSettings ReadLightDriftSettings(const ConfigNode& node) {
  LightDriftSettings settings;
  node.Optional("reference_every_steps", &settings.reference_every_steps);
  node.Optional("warn_percent", &settings.warn_percent);
  if (settings.reference_every_steps < 0 || settings.reference_every_steps > 100000) {
    node.AddError("reference_every_steps", "must be in [0, 100000] (0: no drift references)");
  }
  if (!(settings.warn_percent > 0 && settings.warn_percent <= 100)) node.AddError("warn_percent", "must be in (0, 100]");
  return settings;
}

LightDriftSettings ReadLightDriftSettings(const RigFile& file) {
  const std::optional<ConfigNode> node = file.Section("light_drift");
  return node ? ReadLightDriftSettings(*node) : LightDriftSettings{};
}

Result<Plan> MakeMaterialPlan(const RigModel& rig, const Preset& preset, const LightDriftSettings& drift) {
  if (rig.cameras.empty() || rig.leds.empty()) {
    return FailedPreconditionError("rig '" + rig.name + "'", "a material scan needs cameras and LEDs");
  }
  LOOM_RETURN_IF_ERROR(CheckOpenSlots(rig));
  if (preset.linear_light_positions > 0 && !rig.linear_light) {
    return FailedPreconditionError("rig '" + rig.name + "'", "preset '" + preset.name + "' needs a linear light (" +
                                                                 std::to_string(preset.linear_light_positions) +
                                                                 " positions), the rig has none");
  }
  PlanBuilder builder(rig, preset, PlanPurpose::kMaterial);
  // Everything at the first angle first: the turntable moves once per further angle.
  const double first = preset.turntable_deg.front();
  // Lights off first: the sequencer takes each camera's black level and noise from it.
  builder.Add(StepKind::kDark, AllCameras(rig), first, ScanObject::kSample);
  builder.StructuredLight(first, ScanObject::kSample);
  builder.Filtered(StepKind::kColour, ColourCameras(rig, preset.colour_views_deg), ScanObject::kSample);
  builder.EveryLed(StepKind::kMonochrome, first, ScanObject::kSample);
  if (preset.linear_light_positions > 0) builder.LinearLight(first);
  for (size_t a = 1; a < preset.turntable_deg.size(); ++a) {
    builder.EveryLed(StepKind::kMonochrome, preset.turntable_deg[a], ScanObject::kSample);
  }
  if (drift.reference_every_steps > 0) builder.InsertDriftReferences(drift.reference_every_steps);
  return builder.Finish();
}

Result<Plan> MakePlan(const RigModel& rig, const Preset& preset, PlanPurpose purpose, const LightDriftSettings& drift) {
  return purpose == PlanPurpose::kCalibration ? MakeCalibrationPlan(rig, preset) : MakeMaterialPlan(rig, preset, drift);
}

Result<Plan> MakePlanForRigFile(const std::filesystem::path& rig_file, const std::filesystem::path& preset_file,
                                PlanPurpose purpose) {
  LOOM_ASSIGN_OR_RETURN(const RigFile file, RigFile::Load(rig_file));
  LOOM_ASSIGN_OR_RETURN(const RigModel rig, file.Model());
  const LightDriftSettings drift = ReadLightDriftSettings(file);
  LOOM_RETURN_IF_ERROR(file.Finish());
  LOOM_ASSIGN_OR_RETURN(const Preset preset, LoadPreset(preset_file));
  return MakePlan(rig, preset, purpose, drift);
}

Result<Plan> MakeCalibrationPlan(const RigModel& rig, const Preset& preset) {
  if (rig.cameras.empty()) return FailedPreconditionError("rig '" + rig.name + "'", "calibration needs cameras");
  LOOM_RETURN_IF_ERROR(CheckOpenSlots(rig));
  PlanBuilder builder(rig, preset, PlanPurpose::kCalibration);
  builder.Add(StepKind::kDark, AllCameras(rig), 0, ScanObject::kNothing);
  // The target at 8 turntable angles, lit evenly by every LED at a quarter of the current; at
  // three of them the projector's patterns on it, for the projector's calibration.
  for (int k = 0; k < 8; ++k) {
    Step& step = builder.Add(StepKind::kTarget, AllCameras(rig), 45.0 * k, ScanObject::kTarget);
    for (int led = 0; led < static_cast<int>(rig.leds.size()); ++led) step.leds.push_back({led, preset.led_current_ma / 4});
    if (k % 3 == 0) builder.StructuredLight(45.0 * k, ScanObject::kTarget);
  }
  if (rig.light_probe) {
    builder.EveryLed(StepKind::kLightProbe, 0, ScanObject::kChromeSphere);
    if (rig.linear_light) builder.StripOverProbe();
  }
  builder.EveryLed(StepKind::kWhiteReference, 0, ScanObject::kWhiteTile);
  builder.LinearitySeries();
  if (rig.linear_light) {
    builder.Add(StepKind::kWhiteReference, AllCameras(rig), 0, ScanObject::kWhiteTile).linear_light_mm =
        rig.linear_light->travel_mm / 2;
  }
  // The projector's patterns on the tile lying on the table and raised on the spacer: a flat
  // board at two heights, for the projector's focal length (calibration/projector.h).
  if (rig.white_reference.spacer_mm > 0) {
    builder.StructuredLight(0, ScanObject::kWhiteTile);
    builder.StructuredLight(0, ScanObject::kWhiteTileOnSpacer);
  }
  builder.Filtered(StepKind::kColourChart, ColourCameras(rig, preset.colour_views_deg), ScanObject::kColourChart);
  return builder.Finish();
}

double EstimateSeconds(const Plan& plan, const DurationModel& model) {
  double seconds = 0;
  double angle = 0;
  double strip_mm = 0;
  std::map<std::string, int> slots;
  for (const Step& step : plan.steps) {
    double move = std::abs(step.turntable_deg - angle) / model.turntable_deg_s;
    angle = step.turntable_deg;
    if (step.filter) {
      const int from = slots.contains(step.filter->wheel) ? slots[step.filter->wheel] : 0;
      move = std::max(move, std::abs(step.filter->slot - from) * model.wheel_s_per_slot);
      slots[step.filter->wheel] = step.filter->slot;
    }
    if (step.linear_light_mm) {
      move = std::max(move, std::abs(*step.linear_light_mm - strip_mm) / model.linear_light_mm_s);
      strip_mm = *step.linear_light_mm;
    }
    seconds += move + model.exposures_per_bracket * (step.exposure.probe_us * 1e-6 + model.frame_overhead_s);
  }
  return seconds;
}

std::string DescribeStep(const Step& step) {
  std::ostringstream out;
  out << "  " << std::setw(5) << step.index << "  " << std::left << std::setw(17) << StepKindName(step.kind) << std::right
      << " table " << std::setw(5) << step.turntable_deg << " deg";
  for (const LedDrive& led : step.leds) {
    if (step.leds.size() <= 3) out << "  LED " << led.led << " @ " << led.current_ma << " mA";
  }
  if (step.leds.size() > 3) out << "  " << step.leds.size() << " LEDs";
  if (step.filter) {
    out << "  " << step.filter->wheel << " slot " << step.filter->slot << " (" << step.filter->center_nm << " nm)";
  }
  if (step.linear_light_mm) out << "  strip at " << *step.linear_light_mm << " mm";
  if (!step.projector_pattern.empty()) out << "  pattern " << step.projector_pattern;
  out << "  cameras";
  for (const std::string& camera : step.cameras) out << " " << camera;
  out << "  [" << ScanObjectName(step.object) << "]";
  return out.str();
}

void ReportPlan(std::ostream& out, const Plan& plan, const DurationModel& model) {
  out << PlanPurposeName(plan.purpose) << " scan of rig '" << plan.rig << "' with preset '" << plan.preset
      << "': " << plan.steps.size() << " steps, " << plan.Images() << " images (before HDR bracketing)\n";
  std::map<StepKind, std::pair<int, int>> by_kind;
  for (const Step& step : plan.steps) {
    ++by_kind[step.kind].first;
    by_kind[step.kind].second += step.images();
  }
  for (const auto& [kind, counts] : by_kind) {
    out << "  " << std::left << std::setw(17) << StepKindName(kind) << std::right << std::setw(6) << counts.first << " steps "
        << std::setw(6) << counts.second << " images\n";
  }
  out << "estimated duration: " << FormatDuration(EstimateSeconds(plan, model)) << " (" << model.exposures_per_bracket
      << " exposures per bracket, " << model.frame_overhead_s << " s per frame, turntable " << model.turntable_deg_s
      << " deg/s, strip " << model.linear_light_mm_s << " mm/s)\n";
}

}  // namespace loom::scan
