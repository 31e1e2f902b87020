// Radiometric calibration on views the simulator renders of tac7-mini as built: two LEDs and the
// linear light brighter or dimmer than the rig YAML says, the side camera less sensitive, both
// cameras vignetting more, one filter's band 12 nm off. The views are converted with the YAML's
// sensor model, as loom converts a scan's frames, and carry 1 % noise per pixel; calibration
// must find the differences and the chart's colours through them.
#include "calibration/radiometry.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>

#include "calibration/radiometry_yaml.h"
#include "core/config.h"
#include "core/spectra.h"
#include "core/testing/shipped_rig.h"
#include "sim/renderer.h"
#include "sim/test_materials.h"

namespace loom::calibration {
namespace {

RigModel Nominal() { return loom::testing::ShippedRigModel("tac7-mini"); }

constexpr double kLed3 = 0.85, kLed7 = 1.1, kStrip = 0.9, kCam1Sensitivity = 0.92, kShiftNm = 12;
constexpr double kVignetting[] = {0.15, 0.18};

RigModel AsBuilt(RigModel rig) {
  rig.leds[3].intensity *= kLed3;
  rig.leds[7].intensity *= kLed7;
  rig.linear_light->intensity_per_mm *= kStrip;
  rig.cameras[1].sensor.sensitivity *= kCam1Sensitivity;
  for (int c = 0; c < 2; ++c) rig.cameras[c].sensor.vignetting = kVignetting[c];
  rig.filter_wheels[0].filters[2].center_nm += kShiftNm;
  return rig;
}

class Views {
 public:
  Views(const RigModel& nominal, const RigModel& built, sim::Material material)
      : nominal_(nominal), scene_(built, std::move(material)) {}

  // What loom would make of the as-built camera's frame with the nominal sensor model.
  LitView Render(int camera, const LightingState& lighting) {
    sim::SceneState state;
    for (const auto& [led, current] : lighting.leds) state.leds.push_back({led, current});
    state.filter_slots = lighting.filter_slots;
    state.linear_light_on = lighting.linear_light_on;
    state.linear_light_mm = lighting.linear_light_mm;
    Image radiance = scene_.RenderRadiance(camera, state, {.supersampling = 1, .shadows = false, .threads = 0});
    const CameraModel& truth = scene_.rig().cameras[camera];
    const CameraModel& assumed = nominal_.cameras[camera];
    std::normal_distribution<double> noise(1.0, 0.01);
    for (int y = 0; y < radiance.height(); ++y) {
      for (int x = 0; x < radiance.width(); ++x) {
        const double response = truth.sensor.sensitivity * truth.sensor.RelativeResponse(x, y, truth.width, truth.height) /
                                (assumed.sensor.sensitivity * assumed.sensor.RelativeResponse(x, y, truth.width, truth.height));
        radiance.at(0, y, x) = static_cast<float>(radiance.at(0, y, x) * response * noise(rng_));
      }
    }
    return {camera, lighting, std::move(radiance), "view " + std::to_string(count_++), -1, {}};
  }

 private:
  const RigModel& nominal_;
  sim::Scene scene_;
  std::mt19937 rng_{7};
  int count_ = 0;
};

LightingState Led(const RigModel& rig, int led, int slot_or_open) {
  LightingState lighting;
  lighting.leds = {{led, 1000}};
  for (size_t w = 0; w < rig.filter_wheels.size(); ++w) {
    if (rig.filter_wheels[w].led == led) lighting.filter_slots[static_cast<int>(w)] = slot_or_open;
  }
  return lighting;
}

class RadiometryTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nominal_ = new RigModel(Nominal());
    const RigModel built = AsBuilt(*nominal_);
    Views tile(*nominal_, built, sim::WhiteTile({128, 128, 0.2}, nominal_->white_reference.albedo));
    Views chart(*nominal_, built, sim::ColourChart(nominal_->colour_chart, {128, 128, 0.2}));
    white_ = new std::vector<LitView>;
    chart_ = new std::vector<LitView>;
    for (int c = 0; c < 2; ++c) {
      for (int led = 0; led < static_cast<int>(nominal_->leds.size()); ++led) {
        white_->push_back(tile.Render(c, Led(*nominal_, led, 0)));
      }
      LightingState strip;
      strip.linear_light_on = true;
      strip.linear_light_mm = nominal_->linear_light->travel_mm / 2;
      white_->push_back(tile.Render(c, strip));
      for (const FilterWheelModel& wheel : nominal_->filter_wheels) {
        for (int slot = 1; slot < static_cast<int>(wheel.filters.size()); ++slot) {
          chart_->push_back(chart.Render(c, Led(*nominal_, wheel.led, slot)));
        }
      }
    }
  }
  static RigModel* nominal_;
  static std::vector<LitView>* white_;
  static std::vector<LitView>* chart_;
};

RigModel* RadiometryTest::nominal_ = nullptr;
std::vector<LitView>* RadiometryTest::white_ = nullptr;
std::vector<LitView>* RadiometryTest::chart_ = nullptr;

TEST_F(RadiometryTest, FindsTheLightsCamerasAndFiltersAsBuilt) {
  const Result<Radiometry> found = FitRadiometry(*nominal_, *white_, *chart_, {});
  ASSERT_TRUE(found.ok()) << found.status().ToString();
  EXPECT_EQ(found->reference_camera, "cam0");

  ASSERT_EQ(found->lights.size(), nominal_->leds.size() + 1);
  for (const LightRadiometry& light : found->lights) {
    std::cout << light.name << " x" << light.change << " spread " << light.camera_spread << "\n";
  }
  for (const CameraRadiometry& camera : found->cameras) {
    std::cout << camera.name << " sensitivity x" << camera.sensitivity_change << " vignetting " << camera.vignetting
              << " flat residual " << camera.flat_field_residual << " on " << camera.tile_pixels << " px\n";
  }
  for (const FilterRadiometry& f : found->filters) {
    std::cout << f.wheel << " slot " << f.slot << " weights " << f.weights.transpose() << " (nominal "
              << f.nominal_weights.transpose() << ") residual " << f.fit_residual << "\n";
  }
  for (const WheelColour& wheel : found->wheels) {
    std::cout << wheel.wheel << " chart rms " << wheel.chart_rms << " max " << wheel.chart_max << "\n";
  }
  std::cout << "tile subtends " << found->tile_subtends_deg << " deg\n";
  for (const LightRadiometry& light : found->lights) {
    const double truth = light.led == 3 ? kLed3 : light.led == 7 ? kLed7 : light.led < 0 ? kStrip : 1.0;
    EXPECT_NEAR(light.change, truth, 0.01) << light.name;
    EXPECT_LT(light.camera_spread, 0.01) << light.name;
  }
  ASSERT_EQ(found->cameras.size(), 2u);
  EXPECT_EQ(found->cameras[0].sensitivity_change, 1.0);  // the reference
  EXPECT_NEAR(found->cameras[1].sensitivity_change, kCam1Sensitivity, 0.01);
  for (int c = 0; c < 2; ++c) {
    EXPECT_NEAR(found->cameras[c].vignetting, kVignetting[c], 0.01) << c;
    EXPECT_LT(found->cameras[c].flat_field_residual, 0.02) << c;  // 1 % pixel noise, averaged over 13 lights
    EXPECT_GT(found->cameras[c].tile_pixels, 5000) << c;
  }
  EXPECT_LT(found->tile_subtends_deg, 5);

  ASSERT_EQ(found->filters.size(), 8u);
  for (const FilterRadiometry& filter : found->filters) {
    FilterModel truth = AsBuilt(*nominal_).filter_wheels[filter.wheel == "wheel0" ? 0 : 1].filters[filter.slot];
    const Eigen::Vector3d expected = FilterWeights(truth);
    EXPECT_LT((filter.weights - expected).norm(), 0.02 * expected.norm()) << filter.wheel << " slot " << filter.slot;
  }
  const FilterRadiometry& shifted = found->filters[1];  // wheel0 slot 2
  ASSERT_EQ(shifted.slot, 2);
  EXPECT_GT((shifted.nominal_weights - shifted.weights).norm(), 0.1 * shifted.weights.norm());
  ASSERT_EQ(found->wheels.size(), 2u);
  for (const WheelColour& wheel : found->wheels) {
    EXPECT_EQ(wheel.colour_matrix.rows(), 3);
    EXPECT_EQ(wheel.colour_matrix.cols(), 4);
    EXPECT_LT(wheel.chart_rms, 0.01) << wheel.wheel;
  }
}

TEST_F(RadiometryTest, TheCalibratedRigPredictsWhatWasMeasured) {
  const Result<Radiometry> found = FitRadiometry(*nominal_, *white_, *chart_, {});
  ASSERT_TRUE(found.ok()) << found.status().ToString();
  RigModel calibrated = *nominal_;
  ApplyRadiometry(*found, &calibrated);
  const RigModel truth = AsBuilt(*nominal_);
  EXPECT_NEAR(calibrated.leds[3].intensity / truth.leds[3].intensity, 1, 0.01);
  EXPECT_NEAR(calibrated.linear_light->intensity_per_mm / truth.linear_light->intensity_per_mm, 1, 0.01);
  EXPECT_NEAR(calibrated.cameras[1].sensor.sensitivity / truth.cameras[1].sensor.sensitivity, 1, 0.01);
  EXPECT_TRUE(calibrated.filter_wheels[0].filters[2].measured_weights.has_value());
  EXPECT_FALSE(calibrated.filter_wheels[0].filters[0].measured_weights.has_value());  // the open slot
}

// What loom calibrate radiometry writes is what reconstruct --calib applies; a file for another
// rig, or with a typo, is named.
TEST_F(RadiometryTest, FilesRoundTripAndBadOnesAreNamed) {
  const Result<Radiometry> found = FitRadiometry(*nominal_, *white_, *chart_, {});
  ASSERT_TRUE(found.ok()) << found.status().ToString();
  const std::filesystem::path dir =
      std::filesystem::path(::testing::TempDir()) / ("radiometry_yaml_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  ASSERT_TRUE(WriteRadiometry(dir, *found, "scan/").ok());
  RigModel direct = *nominal_, from_files = *nominal_;
  ApplyRadiometry(*found, &direct);
  const Result<std::optional<Radiometry>> applied = ApplyRadiometryCalibration(dir, &from_files);
  ASSERT_TRUE(applied.ok()) << applied.status().ToString();
  EXPECT_TRUE(applied->has_value());
  for (size_t l = 0; l < direct.leds.size(); ++l) EXPECT_DOUBLE_EQ(from_files.leds[l].intensity, direct.leds[l].intensity);
  EXPECT_DOUBLE_EQ(from_files.linear_light->intensity_per_mm, direct.linear_light->intensity_per_mm);
  for (size_t c = 0; c < direct.cameras.size(); ++c) {
    EXPECT_DOUBLE_EQ(from_files.cameras[c].sensor.sensitivity, direct.cameras[c].sensor.sensitivity);
    EXPECT_DOUBLE_EQ(from_files.cameras[c].sensor.vignetting, direct.cameras[c].sensor.vignetting);
  }
  EXPECT_EQ(*from_files.filter_wheels[0].filters[2].measured_weights, *direct.filter_wheels[0].filters[2].measured_weights);
  // No radiometry/ folder: nothing applied, no error.
  RigModel untouched = *nominal_;
  EXPECT_FALSE(ApplyRadiometryCalibration(dir / "elsewhere", &untouched)->has_value());

  RigModel more_leds = *nominal_;
  more_leds.leds.push_back(more_leds.leds.back());
  const Result<Radiometry> other_rig = ReadRadiometry(dir, more_leds);
  ASSERT_FALSE(other_rig.ok());
  EXPECT_NE(other_rig.status().subject().find("radiometry/leds.yaml"), std::string::npos) << other_rig.status().ToString();
  std::ofstream(dir / "radiometry" / "cam1.yaml", std::ios::app) << "sensitivty: 1\n";
  const Result<Radiometry> typo = ReadRadiometry(dir, *nominal_);
  ASSERT_FALSE(typo.ok());
  EXPECT_NE(typo.status().ToString().find("sensitivty"), std::string::npos) << typo.status().ToString();
  EXPECT_NE(typo.status().ToString().find("cam1.yaml"), std::string::npos) << typo.status().ToString();
  std::filesystem::remove_all(dir);
}

TEST_F(RadiometryTest, MissingViewsAreNamed) {
  std::vector<LitView> without_led5;
  for (const LitView& view : *white_) {
    if (view.camera != 0 || view.lighting.leds.empty() || view.lighting.leds.front().first != 5) without_led5.push_back(view);
  }
  const Result<Radiometry> no_led = FitRadiometry(*nominal_, without_led5, *chart_, {});
  ASSERT_FALSE(no_led.ok());
  EXPECT_EQ(no_led.status().subject(), "led 5");

  std::vector<LitView> only_cam0;
  for (const LitView& view : *white_) {
    if (view.camera == 0) only_cam0.push_back(view);
  }
  const Result<Radiometry> no_camera = FitRadiometry(*nominal_, only_cam0, {}, {});
  ASSERT_FALSE(no_camera.ok());
  EXPECT_EQ(no_camera.status().subject(), "camera 'cam1'");

  LitView mixed = white_->front();
  mixed.lighting.leds.push_back({4, 1000});
  const Result<Radiometry> two_lights = FitRadiometry(*nominal_, {mixed}, {}, {});
  ASSERT_FALSE(two_lights.ok());
  EXPECT_EQ(two_lights.status().subject(), mixed.source);
}

TEST(RadiometryOptionsTest, ANegativeEdgeIsRefusedNamingTheField) {
  EXPECT_TRUE(RadiometryOptions{}.Check().ok());
  RadiometryOptions bad;
  bad.edge_px = -1;
  EXPECT_NE(bad.Check().message().find("edge_px"), std::string::npos) << bad.Check().message();
}

}  // namespace
}  // namespace loom::calibration
