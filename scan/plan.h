#pragma once
// Measurement plans: what a scan captures, step by step, generated from a rig's description
// (core/rig_model.h) and a gloss preset (configs/plans/{low,medium,high}.yaml).
//
// A material scan (the paper's counts on configs/rig/tac7.yaml):
// | kind        | steps                                                     | tac7 images       |
// |-------------|-----------------------------------------------------------|-------------------|
// | dark        | lights off, all cameras (black level and noise)           | 4                 |
// | structured  | Gray-code + phase-shift patterns, all cameras at once     | (heightmap)       |
// | colour      | each filtered LED × each filter, colour-view cameras      | 5 × 10 × 2 = 100  |
// | monochrome  | each LED × each turntable angle, all cameras              | 29 × 3 × 4 = 348  |
// | linear      | each strip position, all cameras                          | 70/140/825 × 4    |
// With `light_drift: reference_every_steps: N` in the rig YAML, drift references (the LED
// nearest the zenith, all cameras, one exposure) come before the first lit step, every N steps,
// on both sides of each turntable move and at the end: what scan/light_drift.h measures the
// lights' drift from.
// A calibration scan: dark frames, the calibration target at several turntable angles (at three
// of them with the structured-light patterns on it), the
// light probe (a chrome sphere) under every LED when the rig has one, the white reference under every LED and under the linear
// light (mid-travel) — and, when the rig gives a spacer for it, under the projector's patterns lying on the table and raised on
// the spacer — the colour chart through every filter.
//
// Steps come in capture order, grouped to keep slow moves few: one turntable angle at a time,
// wheel slots in order, the strip swept in one direction. Every step carries an HDR bracket
// (probe exposure, bounded count) that the sequencer refines.

#include <filesystem>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "core/rig_file.h"
#include "core/rig_model.h"
#include "core/status.h"
#include "scan/frame.h"
#include "scan/rig_state.h"

namespace loom::scan {

enum class StepKind {
  kDark,
  kTarget,
  kLightProbe,
  kWhiteReference,
  kColourChart,
  kStructuredLight,
  kColour,
  kMonochrome,
  kLinearLight,
  kDriftReference
};
std::string_view StepKindName(StepKind kind);
std::optional<StepKind> ParseStepKind(std::string_view name);
// Colour, monochrome and linear-light steps: the ones whose images become a stack's observations.
bool IsObservationStep(StepKind kind);

struct ExposureBracket {
  double probe_us = 10000;  // the first exposure; the sequencer brackets around it
  int max_exposures = 5;
  // After the bracket, this many more exposures for the cameras' linearity: the first brings the
  // brightest pixels to 90 % of full scale, each next one is half as long.
  int linearity_series = 0;
  bool operator==(const ExposureBracket&) const = default;
};

struct FilterSetting {
  std::string wheel;
  int slot = 0;
  double center_nm = 0;
  bool operator==(const FilterSetting&) const = default;
};

// What must lie on the turntable for a step. Its name is how plan.yaml writes it and what an
// operator is asked to place; code matches the enum, never the name.
enum class ScanObject {
  kNothing,            // a dark frame needs none
  kSample,             // the material scanned
  kTarget,             // the rig's calibration_target
  kChromeSphere,       // its light_probe
  kWhiteTile,          // its white_reference
  kWhiteTileOnSpacer,  // the same raised by the reference's spacer_mm
  kColourChart,
};
std::string_view ScanObjectName(ScanObject object);  // "sample", "white tile on its spacer", ...
std::optional<ScanObject> ParseScanObject(std::string_view name);

enum class PlanPurpose { kMaterial, kCalibration };
std::string_view PlanPurposeName(PlanPurpose purpose);  // "material", "calibration"
std::optional<PlanPurpose> ParsePlanPurpose(std::string_view name);

// One camera's images of one plan step: a view, as calibration reports and files name it
// ("step 12 cam0").
struct ViewId {
  int step = 0;
  std::string camera;
  std::string ToString() const;
  bool operator==(const ViewId&) const = default;
};
std::vector<std::string> ViewNames(const std::vector<ViewId>& views);

struct Step {
  int index = 0;
  StepKind kind = StepKind::kMonochrome;
  std::vector<std::string> cameras;  // triggered together
  std::vector<LedDrive> leds;        // lit; all others off
  std::optional<FilterSetting> filter;
  double turntable_deg = 0;
  std::optional<double> linear_light_mm;    // strip on at this position
  std::string projector_pattern;            // empty: projector dark
  ScanObject object = ScanObject::kSample;  // what must lie on the turntable
  ExposureBracket exposure;
  // Cameras that read only a region of interest for this step (a calibration object's window,
  // acquisition/crop_windows.h), by name; the others read the scan's own region.
  std::map<std::string, Roi> windows;

  // Images this step produces before bracketing (one per camera).
  int images() const { return static_cast<int>(cameras.size()); }
  bool operator==(const Step&) const = default;
};

struct Preset {
  std::string name;  // low, medium, high
  std::vector<double> turntable_deg = {0, 120, 240};
  std::vector<double> colour_views_deg = {0, 45};  // colour from the cameras nearest these
  int linear_light_positions = 70;
  double led_current_ma = 1000;
  ExposureBracket exposure;
  int gray_bits = 0;  // 0: enough for the projector width
  int phase_steps = 4;
};

// Reads configs/plans/<name>.yaml (strict keys).
Result<Preset> LoadPreset(const std::filesystem::path& path);

// The rig YAML's `light_drift:` section: how often a material scan measures its lights' drift,
// and beyond what drift the scan and the reconstruction warn.
struct LightDriftSettings {
  int reference_every_steps = 0;  // 0: no drift references
  double warn_percent = 1.0;
};
// Reads the section (problems are recorded in its document).
LightDriftSettings ReadLightDriftSettings(const ConfigNode& node);
// The rig file's `light_drift:`, or the defaults (no references) when it has none.
LightDriftSettings ReadLightDriftSettings(const RigFile& file);

struct Plan {
  std::string rig;
  std::string preset;
  PlanPurpose purpose = PlanPurpose::kMaterial;
  std::vector<Step> steps;

  int Images(StepKind kind) const;
  int Images() const;
  bool operator==(const Plan&) const = default;
};

// The expanded plan as YAML (one flow mapping per step; doubles round-trip exactly), as a scan
// directory keeps it in plan.yaml, and back. Reading is strict: unknown keys, a step out of
// order or an unknown kind are errors naming the file and the step.
std::string PlanToYaml(const Plan& plan);
Result<Plan> ParsePlanYaml(std::string_view text, const std::string& source_name);

Result<Plan> MakeMaterialPlan(const RigModel& rig, const Preset& preset, const LightDriftSettings& drift = {});
Result<Plan> MakeCalibrationPlan(const RigModel& rig, const Preset& preset);
// One of the two (a calibration scan takes no drift references).
Result<Plan> MakePlan(const RigModel& rig, const Preset& preset, PlanPurpose purpose, const LightDriftSettings& drift = {});
// The same from a rig YAML (its geometry: and light_drift:, read strictly) and a preset file.
Result<Plan> MakePlanForRigFile(const std::filesystem::path& rig_file, const std::filesystem::path& preset_file,
                                PlanPurpose purpose);

// The structured-light pattern names for a projector width: gray_x_NN and their inverses,
// phase_x_K, plus "white" and "black" references.
std::vector<std::string> StructuredLightPatterns(int projector_width, int gray_bits, int phase_steps);

// What the scan will take on a rig with these speeds (moves + exposures + frame readout).
struct DurationModel {
  double turntable_deg_s = 30;
  double wheel_s_per_slot = 0.25;
  double linear_light_mm_s = 50;
  double frame_overhead_s = 0.4;  // readout and storage of one frame of every camera (GigE, 3 MP)
  double exposures_per_bracket = 3;
};
double EstimateSeconds(const Plan& plan, const DurationModel& model = {});

// A step in one line: kind, turntable angle, lights, filter, strip, pattern, cameras, object.
std::string DescribeStep(const Step& step);
// What a plan captures and how long it will take: steps and images per kind, the duration
// estimated with `model` and the speeds it assumed.
void ReportPlan(std::ostream& out, const Plan& plan, const DurationModel& model = {});

}  // namespace loom::scan
