// Radiometric calibration on views the simulator renders of tac7-mini as built: two LEDs and the
// linear light brighter or dimmer than the rig YAML says (the strip unevenly along its length), the side camera less sensitive,
// both cameras vignetting more, the side camera's lens off its image centre (vignetting no quadratic model about the centre
// holds), one filter's band 12 nm off. The views are converted with the YAML's sensor model, as loom converts a scan's frames,
// and carry 1 % noise per pixel; calibration must find the differences and the chart's colours through them.
#include "calibration/radiometry.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>

#include "calibration/radiometry_yaml.h"
#include "core/config.h"
#include "core/exr_io.h"
#include "core/spectra.h"
#include "core/testing/shipped_rig.h"
#include "sim/renderer.h"
#include "sim/rig_scene.h"
#include "sim/test_materials.h"

namespace loom::calibration {
namespace {

RigModel Nominal() { return loom::testing::ShippedRigModel("tac7-mini"); }

constexpr double kLed3 = 0.85, kLed7 = 1.1, kStrip = 0.9, kCam1Sensitivity = 0.92, kShiftNm = 12;
constexpr double kVignetting[] = {0.15, 0.18};
const Eigen::Vector2d kCam1OpticalCentrePx(8, -5);
constexpr double kCam1Quartic = 0.1;
// The strip's LEDs 20 % dimmer at one end than the middle, 15 % brighter at the other, unevenly.
constexpr std::array<double, 5> kStripProfile = {0.8, 0.95, 1.0, 1.1, 1.15};

RigModel AsBuilt(RigModel rig) {
  rig.leds[3].intensity *= kLed3;
  rig.leds[7].intensity *= kLed7;
  rig.linear_light->intensity_per_mm *= kStrip;
  rig.linear_light->profile = {kStripProfile.begin(), kStripProfile.end()};
  rig.cameras[1].sensor.sensitivity *= kCam1Sensitivity;
  for (int c = 0; c < 2; ++c) rig.cameras[c].sensor.vignetting = kVignetting[c];
  rig.cameras[1].sensor.flat_field = sim::NonQuadraticVignetting(rig.cameras[1], kCam1OpticalCentrePx, kCam1Quartic);
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
    // cam1's quadratic takes up part of its lens's quartic term (the per-pixel flat field the rest).
    EXPECT_NEAR(found->cameras[c].vignetting, kVignetting[c], c == 0 ? 0.01 : 0.05) << c;
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
    ASSERT_TRUE(from_files.cameras[c].sensor.flat_field) << c;
    EXPECT_TRUE(
        std::ranges::equal(from_files.cameras[c].sensor.flat_field->channel(0), direct.cameras[c].sensor.flat_field->channel(0)))
        << c;
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
  // A flat field of another camera's size, or with a zero in it, is named.
  Image small(8, 8, {"flat"});
  for (float& v : small.channel(0)) v = 1;
  ASSERT_TRUE(WriteExr(dir / "radiometry" / "cam1-flat.exr", small).ok());
  const Result<Radiometry> wrong_size = ReadRadiometry(dir, *nominal_);
  ASSERT_FALSE(wrong_size.ok());
  EXPECT_NE(wrong_size.status().subject().find("cam1-flat.exr"), std::string::npos) << wrong_size.status().ToString();
  EXPECT_NE(wrong_size.status().ToString().find("8 x 8"), std::string::npos) << wrong_size.status().ToString();
  Image zero = *direct.cameras[1].sensor.flat_field;
  zero.at(0, 10, 10) = 0;
  ASSERT_TRUE(WriteExr(dir / "radiometry" / "cam1-flat.exr", zero).ok());
  const Result<Radiometry> with_zero = ReadRadiometry(dir, *nominal_);
  ASSERT_FALSE(with_zero.ok());
  EXPECT_NE(with_zero.status().subject().find("cam1-flat.exr"), std::string::npos) << with_zero.status().ToString();
  ASSERT_TRUE(WriteExr(dir / "radiometry" / "cam1-flat.exr", *direct.cameras[1].sensor.flat_field).ok());
  std::ofstream(dir / "radiometry" / "cam1.yaml", std::ios::app) << "sensitivty: 1\n";
  const Result<Radiometry> typo = ReadRadiometry(dir, *nominal_);
  ASSERT_FALSE(typo.ok());
  EXPECT_NE(typo.status().ToString().find("sensitivty"), std::string::npos) << typo.status().ToString();
  EXPECT_NE(typo.status().ToString().find("cam1.yaml"), std::string::npos) << typo.status().ToString();
  std::filesystem::remove_all(dir);
}

// The relative response over the tile, calibrated against as built, for each of the camera's
// pixels the white reference covers (well inside it): the rms departure from its median.
double ResponseErrorOnTile(const RigModel& calibrated, const RigModel& truth, const LitView& white) {
  const CameraModel& camera = truth.cameras[white.camera];
  std::vector<double> finite;
  for (float v : white.radiance.channel(0)) {
    if (std::isfinite(v)) finite.push_back(v);
  }
  std::ranges::sort(finite);
  const double bright = 0.6 * finite[finite.size() * 9 / 10];
  const auto on_tile = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < camera.width && y < camera.height && white.radiance.at(0, y, x) > bright;
  };
  std::vector<double> ratios;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      if (!on_tile(x, y) || !on_tile(x - 4, y) || !on_tile(x + 4, y) || !on_tile(x, y - 4) || !on_tile(x, y + 4)) continue;
      ratios.push_back(calibrated.cameras[white.camera].sensor.RelativeResponse(x, y, camera.width, camera.height) /
                       camera.sensor.RelativeResponse(x, y, camera.width, camera.height));
    }
  }
  std::vector<double> sorted = ratios;
  std::ranges::sort(sorted);
  const double median = sorted[sorted.size() / 2];
  double sum2 = 0;
  for (double r : ratios) sum2 += (r / median - 1) * (r / median - 1);
  return std::sqrt(sum2 / ratios.size());
}

// cam1's lens vignettes about a point 8 px right and 5 px up of its image centre, with a
// quartic term: the quadratic model about the centre leaves a gradient over the tile, which the
// per-pixel flat field takes out, to within the 1 % pixel noise averaged over the lights.
TEST_F(RadiometryTest, ThePerPixelFlatFieldHoldsVignettingTheQuadraticModelCannot) {
  const Result<Radiometry> found = FitRadiometry(*nominal_, *white_, *chart_, {});
  ASSERT_TRUE(found.ok()) << found.status().ToString();
  RigModel calibrated = *nominal_;
  ApplyRadiometry(*found, &calibrated);
  RigModel quadratic_only = calibrated;
  for (CameraModel& camera : quadratic_only.cameras) camera.sensor.flat_field.reset();
  const RigModel truth = AsBuilt(*nominal_);
  for (int c = 0; c < 2; ++c) {
    const auto white = std::ranges::find_if(*white_, [&](const LitView& v) { return v.camera == c; });
    const double per_pixel = ResponseErrorOnTile(calibrated, truth, *white);
    const double quadratic = ResponseErrorOnTile(quadratic_only, truth, *white);
    std::cout << "cam" << c << ": response error on the tile " << 100 * quadratic << " % with the quadratic model, "
              << 100 * per_pixel << " % with the per-pixel flat field (its largest departure "
              << 100 * found->cameras[c].flat_field_max << " %)\n";
    EXPECT_LT(per_pixel, 0.0015) << c;
    if (c == 1) {
      EXPECT_GT(quadratic, 0.004);
      EXPECT_GT(found->cameras[c].flat_field_max, 0.01);
    }
  }
}

// The linear light's radiance on the white reference over its extent along the strip (±12 mm),
// predicted by `rig` for a unit albedo, relative to its value at the centre.
std::vector<double> StripRadianceAcrossTile(const RigModel& rig) {
  LightingState strip;
  strip.linear_light_on = true;
  strip.linear_light_mm = rig.linear_light->travel_mm / 2;
  const StackObservation observation = *DescribeRigObservation(rig, 0, strip);
  std::vector<double> radiance;
  for (double along = -12; along <= 12; along += 4) {
    const Eigen::Vector3d p = rig.linear_light->sweep_axis * along;
    double sum = 0;
    for (const PointEmitter& e : observation.emitters) {
      const Eigen::Vector3d to_light = e.position_mm - p;
      sum += e.IntensityTowards(p) * to_light.z() / std::pow(to_light.norm(), 3);
    }
    radiance.push_back(sum);
  }
  const double centre = radiance[radiance.size() / 2];
  for (double& r : radiance) r /= centre;
  return radiance;
}

// The strip, 20 % dimmer at one end and 15 % brighter at the other, tilts its light across the
// tile by a few tenths of a percent: what the calibrated profile must reproduce, and its slope
// near the strip's middle, where a sample's highlights come from.
TEST_F(RadiometryTest, TheStripsProfileIsFoundAlongTheTile) {
  const Result<Radiometry> found = FitRadiometry(*nominal_, *white_, *chart_, {});
  ASSERT_TRUE(found.ok()) << found.status().ToString();
  RigModel calibrated = *nominal_;
  ApplyRadiometry(*found, &calibrated);
  const RigModel truth = AsBuilt(*nominal_);
  ASSERT_EQ(calibrated.linear_light->profile.size(), 9u);
  std::cout << "profile:";
  for (double p : calibrated.linear_light->profile) std::cout << " " << p;
  std::cout << "\n";
  const std::vector<double> as_built = StripRadianceAcrossTile(truth), even = StripRadianceAcrossTile(*nominal_),
                            with_profile = StripRadianceAcrossTile(calibrated);
  double even_error = 0, profile_error = 0;
  for (size_t i = 0; i < as_built.size(); ++i) {
    even_error = std::max(even_error, std::abs(even[i] / as_built[i] - 1));
    profile_error = std::max(profile_error, std::abs(with_profile[i] / as_built[i] - 1));
  }
  std::cout << "the strip's light across the tile against as built: " << 100 * even_error << " % even, " << 100 * profile_error
            << " % with the profile\n";
  EXPECT_GT(even_error, 0.0015);
  EXPECT_LT(profile_error, 0.25 * even_error);
  const LinearLightModel& strip = *calibrated.linear_light;
  const double slope = (strip.ProfileAt(30) - strip.ProfileAt(-30)) / 60,
               truth_slope = (truth.linear_light->ProfileAt(30) - truth.linear_light->ProfileAt(-30)) / 60;
  std::cout << "slope near the middle " << slope << " per mm (as built " << truth_slope << ")\n";
  EXPECT_NEAR(slope, truth_slope, 0.2 * truth_slope);
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
