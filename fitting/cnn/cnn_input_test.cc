#include "fitting/cnn/cnn_input.h"
#include "core/testing/build_tree.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/testing/shipped_rig.h"
#include "fitting/cnn/cnn.h"
#include "fitting/testing/tac7_mini.h"
#include "scan/plan.h"
#include "sim/plan_observations.h"
#include "sim/stack.h"

namespace loom::fitting {
namespace {

bool Contains(const Status& status, const std::string& text) { return status.ToString().find(text) != std::string::npos; }

// A stack of `observations` on a 3 × 2 grid whose every radiance is `radiance(observation)`: no
// rendering, so the resampling's arithmetic can be checked exactly.
template <typename Radiance>
ObservationStack StackOf(const RigModel& rig, const std::vector<sim::Observation>& observations, Radiance radiance) {
  std::vector<StackObservation> described;
  for (const sim::Observation& o : observations) described.push_back(sim::DescribeObservation(rig, o));
  ObservationStack stack = MakeObservationStack(3, 2, 0.2, described);
  stack.rig = rig.name;
  stack.source = "test stack";
  for (int k = 0; k < static_cast<int>(described.size()); ++k) {
    const float value = radiance(described[k]);
    for (float& v : stack.image.channel(ObservationStack::ObservationChannel(k))) v = value;
  }
  return stack;
}

std::vector<sim::Observation> PresetObservations(const RigModel& rig, const std::string& preset_name) {
  const Result<scan::Preset> preset = scan::LoadPreset(loom::testing::SourceDir() + "/configs/plans/" + preset_name + ".yaml");
  EXPECT_TRUE(preset.ok()) << preset.status().ToString();
  const Result<std::vector<sim::Observation>> observations = sim::PresetObservations(rig, *preset);
  EXPECT_TRUE(observations.ok()) << observations.status().ToString();
  return *observations;
}

// A smooth function of the strip's angle, as a matte sample's radiance under the strip is.
float SmoothInAngle(const StackObservation& o) {
  return o.group == ObservationGroup::kLinearLight ? static_cast<float>(2 + std::cos(StripAngleDeg(o) * M_PI / 180)) : 1.0f;
}

// 100 + the strip's angle: a sweep linear in the angle, whose mean over any bin is exact.
float LinearInAngle(const StackObservation& o) {
  return o.group == ObservationGroup::kLinearLight ? static_cast<float>(100 + StripAngleDeg(o)) : 1.0f;
}

// The input's linear-light channels of sweep `s` (of `layout`) at pixel (0, 0), as radiance.
std::vector<double> SweepRadiance(const CnnTensor& input, const PaperInputLayout& layout, int s) {
  int channel = kCnnGeometryChannels + 3 * layout.colour_observations + layout.monochrome_observations;
  for (int i = 0; i < s; ++i) channel += static_cast<int>(layout.sweeps[i].angles_deg.size());
  std::vector<double> radiance;
  for (size_t j = 0; j < layout.sweeps[s].angles_deg.size(); ++j) radiance.push_back(std::expm1(input.at(channel++, 0, 0)));
  return radiance;
}

TEST(PaperInputTest, TacSevensPresetsAllMakeThePapersChannelsLessXAndY) {
  const RigModel rig = loom::testing::ShippedRigModel("tac7");
  const ObservationStack low = StackOf(rig, PresetObservations(rig, "low"), SmoothInAngle);
  const Result<PaperInputLayout> layout = PaperLayoutOf(low);
  ASSERT_TRUE(layout.ok()) << layout.status().ToString();
  EXPECT_EQ(layout->colour_observations, 100);
  EXPECT_EQ(layout->monochrome_observations, 348);
  ASSERT_EQ(layout->sweeps.size(), 4u);  // every camera at turntable 0
  for (const PaperLinearSweep& sweep : layout->sweeps) {
    EXPECT_EQ(sweep.angles_deg.size(), 70u) << sweep.camera;
    EXPECT_NEAR(sweep.angles_deg.front(), -70, 1e-6) << "tac7.yaml's arm starts at -70 deg";
    EXPECT_NEAR(sweep.angles_deg.back(), 70, 1e-6);
  }
  EXPECT_EQ(layout->Channels(), 932);  // 934 − x, y

  for (const std::string preset : {"low", "medium", "high"}) {
    const ObservationStack stack = StackOf(rig, PresetObservations(rig, preset), SmoothInAngle);
    const Result<CnnTensor> input = PaperInputFromStack(stack, *layout, 1.0);
    ASSERT_TRUE(input.ok()) << preset << ": " << input.status().ToString();
    EXPECT_EQ(input->channels, 932) << preset;
    // Each bin's mean of a smooth sweep is its value at the layout angle, to the curvature
    // over a bin and a sampling step: ≤ ((Δθ)² / 24 + (Δθ)² / 8) · |f''| ≈ 2e-4 for 2° bins.
    const std::vector<double> radiance = SweepRadiance(*input, *layout, 1);
    const std::vector<double>& angles = layout->sweeps[1].angles_deg;
    for (size_t j = 1; j + 1 < radiance.size(); ++j) {
      EXPECT_NEAR(radiance[j], 2 + std::cos(angles[j] * M_PI / 180), 3e-4) << preset << " angle " << angles[j];
    }
  }
}

TEST(PaperInputTest, TheLayoutsOwnSweepIsFilteredOneSixOneAndColourIsPutIntoRgb) {
  const RigModel rig = testing::TacMiniGeometry();
  int next = 0;
  const ObservationStack stack = StackOf(rig, testing::TacMiniObservations(rig, 5), [&](const StackObservation&) {
    return static_cast<float>(++next);  // every observation its own value
  });
  const Result<PaperInputLayout> layout = PaperLayoutOf(stack);
  ASSERT_TRUE(layout.ok()) << layout.status().ToString();
  const Result<CnnTensor> input = PaperInputFromStack(stack, *layout, 1.0);
  ASSERT_TRUE(input.ok()) << input.status().ToString();
  ASSERT_EQ(input->channels, layout->Channels());

  int channel = kCnnGeometryChannels, colour = 0;
  for (int k = 0; k < static_cast<int>(stack.observations.size()); ++k) {
    if (stack.observations[k].group != ObservationGroup::kColour) continue;
    // The triple records as the observation did: w · rgb = L.
    const Eigen::Vector3d& w = stack.observations[k].rgb_weights;
    double recorded = 0;
    for (int c = 0; c < 3; ++c) recorded += w[c] * std::expm1(input->at(channel++, 1, 2));
    EXPECT_NEAR(recorded, k + 1, 1e-4 * (k + 1)) << "colour observation " << k;
    ++colour;
  }
  EXPECT_EQ(colour, layout->colour_observations);
  for (int s = 0; s < static_cast<int>(layout->sweeps.size()); ++s) {
    // The sweep's values in angle order: each channel is the bin's mean of the sweep, linear
    // between positions and constant beyond the ends.
    std::vector<std::pair<double, double>> own;
    for (int k = 0; k < static_cast<int>(stack.observations.size()); ++k) {
      const StackObservation& o = stack.observations[k];
      if (o.group == ObservationGroup::kLinearLight && o.camera == layout->sweeps[s].camera)
        own.emplace_back(StripAngleDeg(o), k + 1);
    }
    std::sort(own.begin(), own.end());
    const std::vector<double> radiance = SweepRadiance(*input, *layout, s);
    ASSERT_EQ(radiance.size(), 5u);
    EXPECT_NEAR(radiance[0], (7 * own[0].second + own[1].second) / 8, 1e-3 * own[0].second);
    for (size_t j = 1; j + 1 < own.size(); ++j) {
      const double expected = (own[j - 1].second + 6 * own[j].second + own[j + 1].second) / 8;
      EXPECT_NEAR(radiance[j], expected, 1e-3 * expected) << "sweep " << s << " position " << j;
    }
    EXPECT_NEAR(radiance[4], (own[3].second + 7 * own[4].second) / 8, 1e-3 * own[4].second);
  }
}

TEST(PaperInputTest, FinerSweepsAreAveragedOverEachBinAndCoarserOnesInterpolated) {
  const RigModel rig = testing::TacMiniGeometry();
  const ObservationStack layout_stack = StackOf(rig, testing::TacMiniObservations(rig, 5), LinearInAngle);
  const Result<PaperInputLayout> layout = PaperLayoutOf(layout_stack);
  ASSERT_TRUE(layout.ok()) << layout.status().ToString();
  // Whether finer (13 positions), coarser (3) or the same, a sweep linear in the angle has its
  // value at each interior layout angle as the bin's mean.
  for (const int positions : {13, 3, 5, 9}) {
    const ObservationStack stack = StackOf(rig, testing::TacMiniObservations(rig, positions), LinearInAngle);
    const Result<CnnTensor> input = PaperInputFromStack(stack, *layout, 1.0);
    ASSERT_TRUE(input.ok()) << input.status().ToString();
    const std::vector<double> radiance = SweepRadiance(*input, *layout, 0);
    const std::vector<double>& angles = layout->sweeps[0].angles_deg;
    for (size_t j = 1; j + 1 < angles.size(); ++j) {
      EXPECT_NEAR(radiance[j], 100 + angles[j], 1e-3) << positions << " positions, layout angle " << angles[j];
    }
  }
  // The end bins reach half a bin beyond the sweep, where it is held at its end value.
  const ObservationStack fine = StackOf(rig, testing::TacMiniObservations(rig, 13), LinearInAngle);
  const std::vector<double> radiance = SweepRadiance(*PaperInputFromStack(fine, *layout, 1.0), *layout, 0);
  const std::vector<double>& angles = layout->sweeps[0].angles_deg;
  EXPECT_NEAR(radiance[0], 100 + angles[0] + (angles[1] - angles[0]) / 8, 1e-3);
  EXPECT_NEAR(radiance[4], 100 + angles[4] - (angles[4] - angles[3]) / 8, 1e-3);
}

// A calibrated arm never sweeps its nominal range (tac7 built 1.5° turned: −68.5° to 71.5°). Up
// to a bin short of the layout's outermost angle, the sweep is held at its end value there; a
// shortfall beyond that would invent a whole bin and is refused.
TEST(PaperInputTest, ASweepUpToABinShortOfTheLayoutIsHeldAtItsEndAndFurtherIsRefused) {
  const RigModel rig = testing::TacMiniGeometry();
  const ObservationStack stack = StackOf(rig, testing::TacMiniObservations(rig, 5), LinearInAngle);
  const Result<PaperInputLayout> layout = PaperLayoutOf(stack);
  ASSERT_TRUE(layout.ok()) << layout.status().ToString();
  const std::vector<double>& own = layout->sweeps[0].angles_deg;
  const double step = own[1] - own[0];
  const auto shifted = [&](double bins) {
    PaperInputLayout moved = *layout;
    for (PaperLinearSweep& sweep : moved.sweeps) {
      for (double& angle : sweep.angles_deg) angle -= bins * step;
    }
    return moved;
  };
  // Three quarters of a bin short: the first bin lies wholly before the sweep's first position.
  const PaperInputLayout short_of_it = shifted(0.75);
  const Result<CnnTensor> input = PaperInputFromStack(stack, short_of_it, 1.0);
  ASSERT_TRUE(input.ok()) << input.status().ToString();
  const std::vector<double> radiance = SweepRadiance(*input, short_of_it, 0);
  EXPECT_NEAR(radiance[0], 100 + own[0], 1e-3);
  EXPECT_NEAR(radiance[2], 100 + short_of_it.sweeps[0].angles_deg[2], 1e-3);  // inside, as ever

  const Status too_short = PaperInputFromStack(stack, shifted(1.25), 1.0).status();
  EXPECT_TRUE(Contains(too_short, "test stack") && Contains(too_short, "spans")) << too_short.ToString();
}

TEST(PaperInputTest, UnseenPositionsAreLeftOutOfABinsMean) {
  const RigModel rig = testing::TacMiniGeometry();
  const Result<PaperInputLayout> layout = PaperLayoutOf(StackOf(rig, testing::TacMiniObservations(rig, 5), LinearInAngle));
  ASSERT_TRUE(layout.ok());
  ObservationStack fine = StackOf(rig, testing::TacMiniObservations(rig, 13), LinearInAngle);
  // Unseen at pixel (0, 0): every linear observation of the finer sweep but one per bin (the
  // one at the layout's angle), so that only a mean of what is seen gives the sweep's value.
  std::vector<std::pair<double, int>> sweep;
  for (int k = 0; k < static_cast<int>(fine.observations.size()); ++k) {
    const StackObservation& o = fine.observations[k];
    if (o.group == ObservationGroup::kLinearLight && o.camera == layout->sweeps[0].camera)
      sweep.emplace_back(StripAngleDeg(o), k);
  }
  std::sort(sweep.begin(), sweep.end());
  for (size_t i = 0; i < sweep.size(); ++i) {
    if (i % 3 != 0) fine.image.channel(ObservationStack::ObservationChannel(sweep[i].second))[0] = NAN;
  }
  const Result<CnnTensor> input = PaperInputFromStack(fine, *layout, 1.0);
  ASSERT_TRUE(input.ok());
  const std::vector<double> radiance = SweepRadiance(*input, *layout, 0);
  for (size_t j = 1; j + 1 < radiance.size(); ++j) EXPECT_NEAR(radiance[j], 100 + sweep[3 * j].first, 1e-3) << j;
  EXPECT_TRUE(std::isfinite(input->at(kCnnGeometryChannels, 0, 0)));
}

TEST(PaperInputTest, StacksThatDoNotFitTheLayoutAreRefusedNamingTheStack) {
  const RigModel rig = testing::TacMiniGeometry();
  const auto one = [](const StackObservation&) { return 1.0f; };
  const ObservationStack stack = StackOf(rig, testing::TacMiniObservations(rig, 5), one);
  const Result<PaperInputLayout> layout = PaperLayoutOf(stack);
  ASSERT_TRUE(layout.ok());

  PaperInputLayout more_colour = *layout;
  ++more_colour.colour_observations;
  const Status colour = PaperInputFromStack(stack, more_colour, 1.0).status();
  EXPECT_TRUE(Contains(colour, "test stack") && Contains(colour, "colour")) << colour.ToString();

  PaperInputLayout other_camera = *layout;
  other_camera.sweeps[0].camera = "cam9";
  const Status missing = PaperInputFromStack(stack, other_camera, 1.0).status();
  EXPECT_TRUE(Contains(missing, "test stack") && Contains(missing, "cam9")) << missing.ToString();

  PaperInputLayout wider = *layout;
  for (double& angle : wider.sweeps[0].angles_deg) angle += 40;
  const Status narrow = PaperInputFromStack(stack, wider, 1.0).status();
  EXPECT_TRUE(Contains(narrow, "test stack") && Contains(narrow, "spans")) << narrow.ToString();

  // No linear light at all: no paper layout.
  std::vector<sim::Observation> point_lit = testing::TacMiniObservations(rig, 2);
  point_lit.resize(point_lit.size() - 2 * rig.cameras.size());
  const Status no_sweep = PaperLayoutOf(StackOf(rig, point_lit, one)).status();
  EXPECT_TRUE(Contains(no_sweep, "test stack") && Contains(no_sweep, "linear")) << no_sweep.ToString();
}

TEST(PaperInputTest, TheLayoutSurvivesJson) {
  const RigModel rig = testing::TacMiniGeometry();
  const Result<PaperInputLayout> layout =
      PaperLayoutOf(StackOf(rig, testing::TacMiniObservations(rig, 4), [](const StackObservation&) { return 1.0f; }));
  ASSERT_TRUE(layout.ok());
  const PaperInputLayout back = PaperInputLayout::FromJson(layout->ToJson());
  EXPECT_EQ(back.ToJson(), layout->ToJson());
  EXPECT_EQ(back.Channels(), layout->Channels());
  nlohmann::json descending = layout->ToJson();
  std::reverse(descending["linear_sweeps"][0]["angles_deg"].begin(), descending["linear_sweeps"][0]["angles_deg"].end());
  EXPECT_THROW(PaperInputLayout::FromJson(descending), std::invalid_argument);
}

}  // namespace
}  // namespace loom::fitting
