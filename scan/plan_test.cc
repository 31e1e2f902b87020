#include "scan/plan.h"
#include "core/testing/build_tree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>

#include "core/config.h"
#include "core/testing/shipped_rig.h"
#include "scan/patterns.h"

namespace loom::scan {
namespace {

using loom::testing::ShippedRigModel;

Preset LoadShippedPreset(const std::string& name) {
  Result<Preset> preset = LoadPreset(loom::testing::SourceDir() + "/configs/plans/" + name + ".yaml");
  EXPECT_TRUE(preset.ok()) << preset.status().ToString();
  return *preset;
}

TEST(PlanTest, Tac7PresetsHaveThePapersCounts) {
  const RigModel rig = ShippedRigModel("tac7");
  const std::pair<const char*, int> presets[] = {{"low", 280}, {"medium", 560}, {"high", 3300}};
  for (const auto& [name, linear] : presets) {
    const Result<Plan> plan = MakeMaterialPlan(rig, LoadShippedPreset(name));
    ASSERT_TRUE(plan.ok()) << plan.status().ToString();
    EXPECT_EQ(plan->Images(StepKind::kColour), 100) << name;
    EXPECT_EQ(plan->Images(StepKind::kMonochrome), 348) << name;
    EXPECT_EQ(plan->Images(StepKind::kLinearLight), linear) << name;
    EXPECT_GT(plan->Images(StepKind::kStructuredLight), 0) << name;
  }
}

TEST(PlanTest, ColourComesFromTheTopAndThe45DegreeCameras) {
  const Plan plan = *MakeMaterialPlan(ShippedRigModel("tac7"), LoadShippedPreset("low"));
  for (const Step& step : plan.steps) {
    if (step.kind != StepKind::kColour) continue;
    EXPECT_EQ(step.cameras, (std::vector<std::string>{"cam0", "cam2"}));
    ASSERT_TRUE(step.filter.has_value());
    ASSERT_EQ(step.leds.size(), 1u);
  }
}

TEST(PlanTest, StepsKeepSlowMovesFew) {
  const Plan plan = *MakeMaterialPlan(ShippedRigModel("tac7"), LoadShippedPreset("medium"));
  int turntable_moves = 0;
  double strip = -1;
  for (size_t i = 1; i < plan.steps.size(); ++i) {
    turntable_moves += plan.steps[i].turntable_deg != plan.steps[i - 1].turntable_deg;
    if (plan.steps[i].linear_light_mm) {
      EXPECT_GT(*plan.steps[i].linear_light_mm, strip);  // one sweep, one direction
      strip = *plan.steps[i].linear_light_mm;
    }
  }
  EXPECT_EQ(turntable_moves, 2);  // 0 → 120 → 240
  for (size_t i = 0; i < plan.steps.size(); ++i) EXPECT_EQ(plan.steps[i].index, static_cast<int>(i));
}

TEST(PlanTest, StructuredLightPatternsCoverTheProjectorWidth) {
  const std::vector<std::string> patterns = StructuredLightPatterns(1280, 0, 4);
  // white, black, 11 Gray bits (2^11 ≥ 1280) and their inverses, 4 phase shifts.
  EXPECT_EQ(patterns.size(), 2u + 22u + 4u);
  EXPECT_EQ(patterns[2], "gray_x_00");
  EXPECT_EQ(patterns[3], "gray_x_00_inv");
  EXPECT_EQ(patterns.back(), "phase_x_3");
}

TEST(PlanTest, APatternNameThatIsNotOneOfThePlansIsRefusedNamingIt) {
  EXPECT_TRUE(MakePattern("gray_x_03_inv", 64, 4, 4).ok());
  EXPECT_TRUE(MakePattern("phase_x_3", 64, 4, 4).ok());
  for (const char* name :
       {"gray_x_zz", "gray_x_", "gray_x_0x", "gray_x_99", "phase_x_", "phase_x_4", "phase_x_-1", "phase_x_1e9"}) {
    const Result<Pattern> pattern = MakePattern(name, 64, 4, 4);
    ASSERT_FALSE(pattern.ok()) << name;
    EXPECT_EQ(pattern.status().subject(), "pattern '" + std::string(name) + "'");
  }
}

TEST(PlanTest, APlanReportsItsCountsAndDurationAndEachStepInALine) {
  const RigModel rig = ShippedRigModel("tac7-mini");
  const Plan plan = *MakeMaterialPlan(rig, LoadShippedPreset("low"));
  std::ostringstream report;
  ReportPlan(report, plan);
  EXPECT_NE(report.str().find("material scan of rig 'tac7-mini' with preset 'low'"), std::string::npos) << report.str();
  EXPECT_NE(report.str().find(std::to_string(plan.Images(StepKind::kLinearLight)) + " images"), std::string::npos)
      << report.str();
  EXPECT_NE(report.str().find("estimated duration: "), std::string::npos) << report.str();
  const auto strip =
      std::find_if(plan.steps.begin(), plan.steps.end(), [](const Step& step) { return step.kind == StepKind::kLinearLight; });
  ASSERT_NE(strip, plan.steps.end());
  const std::string line = DescribeStep(*strip);
  EXPECT_NE(line.find("linear light"), std::string::npos) << line;
  EXPECT_NE(line.find("strip at"), std::string::npos) << line;
  EXPECT_NE(line.find("[sample]"), std::string::npos) << line;
  EXPECT_EQ(line.find('\n'), std::string::npos) << line;
}

TEST(PlanTest, MiniRigAndCalibrationPlan) {
  const RigModel rig = ShippedRigModel("tac7-mini");
  const Plan plan = *MakeMaterialPlan(rig, LoadShippedPreset("low"));
  EXPECT_EQ(plan.Images(StepKind::kMonochrome), 12 * 2 * 3);
  EXPECT_EQ(plan.Images(StepKind::kColour), 2 * 4 * 2);
  EXPECT_EQ(plan.Images(StepKind::kLinearLight), 70 * 2);
  const Plan calibration = *MakeCalibrationPlan(rig, LoadShippedPreset("low"));
  EXPECT_EQ(calibration.purpose, PlanPurpose::kCalibration);
  EXPECT_EQ(*MakePlan(rig, LoadShippedPreset("low"), PlanPurpose::kCalibration), calibration);
  EXPECT_EQ(*MakePlan(rig, LoadShippedPreset("low"), PlanPurpose::kMaterial), plan);
  EXPECT_EQ(calibration.Images(StepKind::kWhiteReference), (12 + 1) * 2);  // every LED and the linear light
  EXPECT_EQ(calibration.Images(StepKind::kTarget), 8 * 2);
  EXPECT_EQ(calibration.Images(StepKind::kDark), 2);
  EXPECT_EQ(calibration.Images(StepKind::kLightProbe), (12 + 3) * 2);  // every LED and the strip at 3 positions
  // The chrome sphere's mirrored highlights may take a deeper bracket than the diffuse objects.
  const int preset_exposures = LoadShippedPreset("low").exposure.max_exposures;
  for (const Step& step : calibration.steps) {
    EXPECT_EQ(step.exposure.max_exposures, preset_exposures + (step.kind == StepKind::kLightProbe ? 2 : 0)) << step.index;
  }
  // The projector's patterns (2 references, 9 Gray bits and their inverses, 4 phases for 320
  // columns) on the target at 3 angles, then on the white tile lying and on its spacer.
  EXPECT_EQ(calibration.Images(StepKind::kStructuredLight), (3 + 2) * 24 * 2);
  std::map<ScanObject, int> patterns_on;
  for (const Step& step : calibration.steps) patterns_on[step.object] += step.kind == StepKind::kStructuredLight;
  EXPECT_EQ(patterns_on[ScanObject::kTarget], 3 * 24);
  EXPECT_EQ(patterns_on[ScanObject::kWhiteTile], 24);
  EXPECT_EQ(patterns_on[ScanObject::kWhiteTileOnSpacer], 24);
  RigModel no_spacer = rig;
  no_spacer.white_reference.spacer_mm = 0;
  EXPECT_EQ(MakeCalibrationPlan(no_spacer, LoadShippedPreset("low"))->Images(StepKind::kStructuredLight), 3 * 24 * 2);
  EXPECT_GT(EstimateSeconds(plan), 0);
  // More positions, more time.
  EXPECT_GT(EstimateSeconds(*MakeMaterialPlan(rig, LoadShippedPreset("high"))), EstimateSeconds(plan));
}

TEST(PlanTest, LedsBehindAWheelLightMonochromeStepsThroughItsOpenSlot) {
  const RigModel rig = ShippedRigModel("tac7-mini");
  const Plan plan = *MakeMaterialPlan(rig, LoadShippedPreset("low"));
  for (const Step& step : plan.steps) {
    if (step.kind != StepKind::kMonochrome || step.leds.front().led != rig.filter_wheels[0].led) continue;
    ASSERT_TRUE(step.filter.has_value()) << step.index;
    EXPECT_EQ(step.filter->wheel, "wheel0");
    EXPECT_EQ(step.filter->slot, 0);
  }
  RigModel closed = rig;
  closed.filter_wheels[1].filters.erase(closed.filter_wheels[1].filters.begin());
  const Result<Plan> refused = MakeMaterialPlan(closed, LoadShippedPreset("low"));
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().ToString().find("filter wheel 'wheel1'"), std::string::npos) << refused.status().ToString();
  EXPECT_NE(refused.status().ToString().find("no open slot"), std::string::npos) << refused.status().ToString();
}

TEST(PlanTest, ARigWithoutALinearLightCannotScanWithIt) {
  RigModel rig = ShippedRigModel("tac7-mini");
  rig.linear_light.reset();
  const Result<Plan> plan = MakeMaterialPlan(rig, LoadShippedPreset("low"));
  ASSERT_FALSE(plan.ok());
  EXPECT_NE(plan.status().ToString().find("needs a linear light (70 positions)"), std::string::npos) << plan.status().ToString();
}

TEST(PlanTest, ARigFilesPlanIsItsModelsAndAMistypedKeyInItIsNamed) {
  const std::string rig_file = loom::testing::SourceDir() + "/configs/rig/tac7-mini.yaml";
  const std::string preset_file = loom::testing::SourceDir() + "/configs/plans/low.yaml";
  const Result<Plan> plan = MakePlanForRigFile(rig_file, preset_file, PlanPurpose::kMaterial);
  ASSERT_TRUE(plan.ok()) << plan.status().ToString();
  EXPECT_EQ(*plan, *MakeMaterialPlan(ShippedRigModel("tac7-mini"), LoadShippedPreset("low")));
  std::stringstream text;
  text << std::ifstream(rig_file).rdbuf() << "light_drfit: {}\n";
  const std::string typo = ::testing::TempDir() + "/typo-rig.yaml";
  std::ofstream(typo) << text.str();
  const Result<Plan> refused = MakePlanForRigFile(typo, preset_file, PlanPurpose::kMaterial);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().ToString().find("light_drfit"), std::string::npos) << refused.status().ToString();
}

TEST(PlanTest, PresetTyposAreErrors) {
  const std::string path = ::testing::TempDir() + "/typo.yaml";
  std::ofstream(path) << "schema_version: 1\npreset: low\nlinear_light_positons: 70\n";
  const Result<Preset> preset = LoadPreset(path);
  ASSERT_FALSE(preset.ok());
  EXPECT_NE(preset.status().message().find("did you mean 'linear_light_positions'"), std::string::npos)
      << preset.status().ToString();
}

TEST(PlanTest, TheExpandedPlanRoundTripsThroughYaml) {
  for (const char* preset : {"low", "high"}) {
    const Plan plan = *MakeMaterialPlan(ShippedRigModel("tac7"), LoadShippedPreset(preset));
    const Result<Plan> back = ParsePlanYaml(PlanToYaml(plan), "plan.yaml");
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    EXPECT_EQ(*back, plan) << preset;
  }
  Plan calibration = *MakeCalibrationPlan(ShippedRigModel("tac7-mini"), LoadShippedPreset("low"));
  EXPECT_EQ(*ParsePlanYaml(PlanToYaml(calibration), "plan.yaml"), calibration);
  // A step that reads its cameras through windows keeps them.
  calibration.steps[1].windows = {{calibration.steps[1].cameras[0], Roi{8, 16, 96, 64}}};
  EXPECT_EQ(*ParsePlanYaml(PlanToYaml(calibration), "plan.yaml"), calibration);
}

TEST(PlanTest, BadWindowsAreNamed) {
  const std::string text =
      "schema_version: 1\nrig: r\npreset: low\npurpose: calibration\nsteps:\n"
      "  - {index: 0, kind: target, cameras: [a, b], turntable_deg: 0, object: target, probe_exposure_us: 1, max_exposures: 1,"
      " windows: {a: [0, 0, 0, 8], b: [1, 2, 3], c: [0, 0, 8, 8]}}\n";
  const Result<Plan> plan = ParsePlanYaml(text, "SCAN/plan.yaml");
  ASSERT_FALSE(plan.ok());
  const std::string message = plan.status().ToString();
  for (const char* part : {"steps[0].windows.a", "steps[0].windows.b", "steps[0].windows.c", "not one of the step's cameras"}) {
    EXPECT_NE(message.find(part), std::string::npos) << part << " in " << message;
  }
}

// Drift references: before the first lit step, at most every N steps after, on both sides of
// each turntable move and at the end; the LED nearest the zenith, every camera, one exposure,
// and the strip at the middle of its travel right after it.
TEST(PlanTest, DriftReferencesSurroundTurntableMovesAndComeEveryNSteps) {
  const RigModel rig = ShippedRigModel("tac7");
  const Plan plain = *MakeMaterialPlan(rig, LoadShippedPreset("low"));
  const Plan plan = *MakeMaterialPlan(rig, LoadShippedPreset("low"), {.reference_every_steps = 30});
  ASSERT_GT(plan.steps.size(), plain.steps.size());
  EXPECT_EQ(plan.Images(StepKind::kMonochrome), plain.Images(StepKind::kMonochrome));
  EXPECT_EQ(*ParsePlanYaml(PlanToYaml(plan), "plan.yaml"), plan);
  int since = -1;  // steps since the last reference; −1 before the first
  int led_references = 0, strip_references = 0;
  bool lit_seen = false;
  for (size_t i = 0; i < plan.steps.size(); ++i) {
    const Step& step = plan.steps[i];
    EXPECT_EQ(step.index, static_cast<int>(i));
    if (step.kind == StepKind::kDriftReference) {
      EXPECT_EQ(step.cameras.size(), rig.cameras.size());
      EXPECT_EQ(step.exposure.max_exposures, 1);
      if (step.linear_light_mm) {
        // The strip's reference follows the LED's, at the middle of its travel, nothing else lit.
        EXPECT_TRUE(step.leds.empty());
        EXPECT_EQ(*step.linear_light_mm, rig.linear_light->travel_mm / 2);
        ASSERT_GT(i, 0u);
        EXPECT_EQ(plan.steps[i - 1].kind, StepKind::kDriftReference);
        EXPECT_FALSE(plan.steps[i - 1].linear_light_mm.has_value());
        ++strip_references;
      } else {
        ASSERT_EQ(step.leds.size(), 1u);
        EXPECT_GT(rig.leds[step.leds[0].led].position_mm.normalized().z(), 0.99);  // the zenith LED
        ++led_references;
      }
      since = 0;
      continue;
    }
    const bool lit = IsObservationStep(step.kind);
    if (lit && !lit_seen) {
      EXPECT_EQ(since, 0) << "no reference before the first lit step " << i;
    }
    lit_seen = lit_seen || lit;
    if (i > 0 && since >= 0 && step.turntable_deg != plan.steps[i - 1].turntable_deg) {
      ADD_FAILURE() << "step " << i << " turns the turntable right after a measured step, not a reference";
    }
    if (since >= 0) {
      EXPECT_LE(++since, 30) << i;
    }
  }
  EXPECT_EQ(plan.steps.back().kind, StepKind::kDriftReference);
  EXPECT_GE(led_references, 10);
  EXPECT_EQ(strip_references, led_references);  // the low preset sweeps the strip
}

TEST(PlanTest, ABadPlanFileNamesTheStepAndKey) {
  const std::string text =
      "schema_version: 1\nrig: r\npreset: low\npurpose: materials\nsteps:\n"
      "  - {index: 0, kind: dark, cameras: [c], turntable_deg: 0, object: sample, probe_exposure_us: 1, max_exposures: 1}\n"
      "  - {index: 1, kind: sparkle, cameras: [c], turntable_deg: 0, object: teapot, probe_exposure_us: 1, max_exposures: 1}\n"
      "  - {index: 2, kind: dark, cameras: [], turntable_deg: 0, object: sample, probe_exposure_us: .nan, max_exposures: 0}\n";
  const Result<Plan> plan = ParsePlanYaml(text, "SCAN/plan.yaml");
  ASSERT_FALSE(plan.ok());
  const std::string message = plan.status().ToString();
  for (const char* part : {"SCAN/plan.yaml", "steps[1].kind", "sparkle", "steps[1].object", "teapot", "'purpose'", "materials",
                           "steps[2].cameras", "steps[2].probe_exposure_us", "steps[2].max_exposures"}) {
    EXPECT_NE(message.find(part), std::string::npos) << part << " in " << message;
  }
}

TEST(PlanTest, ObjectsAndPurposesAreReadByTheNamesTheyAreWrittenWith) {
  for (ScanObject object : {ScanObject::kNothing, ScanObject::kSample, ScanObject::kTarget, ScanObject::kChromeSphere,
                            ScanObject::kWhiteTile, ScanObject::kWhiteTileOnSpacer, ScanObject::kColourChart}) {
    EXPECT_EQ(ParseScanObject(ScanObjectName(object)), object) << ScanObjectName(object);
  }
  EXPECT_EQ(ParseScanObject("white-tile-on-spacer"), std::nullopt);  // the simulator's sample kind, not a plan's object
  for (PlanPurpose purpose : {PlanPurpose::kMaterial, PlanPurpose::kCalibration}) {
    EXPECT_EQ(ParsePlanPurpose(PlanPurposeName(purpose)), purpose);
  }
}

TEST(PlanTest, AMaterialScanStartsWithDarkFrames) {
  const Plan plan = *MakeMaterialPlan(ShippedRigModel("tac7"), LoadShippedPreset("low"));
  EXPECT_EQ(plan.steps.front().kind, StepKind::kDark);
  EXPECT_TRUE(plan.steps.front().leds.empty());
  EXPECT_EQ(plan.Images(StepKind::kDark), 4);
}

}  // namespace
}  // namespace loom::scan
