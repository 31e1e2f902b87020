// The renderer against answers from first principles: analytic radiance of a white Lambertian
// target, the inverse-square law and LED falloff, a cast shadow where the geometry puts it, the
// sensor's noise and saturation statistics, determinism, lens distortion and filter colours.
#include "sim/renderer.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "fitting/model/svbrdf_maps.h"
#include "sim/test_materials.h"

namespace loom::sim {
namespace {

// One camera 500 mm straight above the sample (0.5 mm per pixel at the sample), no distortion.
RigModel TestRig() {
  RigModel rig;
  CameraModel camera;
  camera.name = "top";
  camera.width = camera.height = 101;
  camera.K << 1000, 0, 50, 0, 1000, 50, 0, 0, 1;
  Eigen::Matrix3d down;  // x → x, y → −y, z → −z: looking down
  down << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  camera.cam_from_rig = MakeRigid(down, -down * Eigen::Vector3d(0, 0, 500));
  camera.sensor.vignetting = 0;
  rig.cameras.push_back(camera);
  LedModel led;
  led.position_mm = {150, 0, 300};
  led.axis = -led.position_mm.normalized();
  led.intensity = 1e6;
  led.falloff_exponent = 2;
  rig.leds.push_back(led);
  return rig;
}

Material WhiteLambertian(int size_px = 128, double pixel_mm = 0.5) {
  fitting::WardParams<double> white;
  white.a_d = Eigen::Vector3d::Ones();
  white.a_s = Eigen::Vector3d::Zero();
  return UniformMaterial("white", white, {size_px, size_px, pixel_mm});
}

// Radiance of a white Lambertian surface point p (z = 0) lit by `led` at 1000 mA.
double AnalyticRadiance(const LedModel& led, const Eigen::Vector3d& p) {
  const Eigen::Vector3d to_light = led.position_mm - p;
  const double d = to_light.norm();
  const double falloff = std::pow(led.axis.dot(-to_light / d), led.falloff_exponent);
  return led.intensity * falloff / (d * d) * (to_light.z() / d) / kPi;
}

TEST(RendererTest, WhiteLambertianHasTheAnalyticRadiance) {
  const Scene scene(TestRig(), WhiteLambertian());
  const SceneState state{.leds = {{0, 1000}}};
  const Image radiance = scene.RenderRadiance(0, state, {.supersampling = 1});
  // Pixel (50, 50) sees the origin; pixel (70, 50) sees x = +10 mm; (50, 30) sees y = +10 mm.
  const LedModel& led = scene.rig().leds[0];
  EXPECT_NEAR(radiance.at(0, 50, 50), AnalyticRadiance(led, {0, 0, 0}), 1e-5 * AnalyticRadiance(led, {0, 0, 0}));
  EXPECT_NEAR(radiance.at(0, 50, 70), AnalyticRadiance(led, {10, 0, 0}), 1e-5 * AnalyticRadiance(led, {10, 0, 0}));
  EXPECT_NEAR(radiance.at(0, 30, 50), AnalyticRadiance(led, {0, 10, 0}), 1e-5 * AnalyticRadiance(led, {0, 10, 0}));
  EXPECT_GT(radiance.at(0, 50, 70), radiance.at(0, 50, 30));  // nearer the LED
}

TEST(RendererTest, ACameraFrameIsItsRadianceAndTheSensorsCountsAndAnUnknownCameraOrLedIsNamed) {
  const Scene scene(TestRig(), WhiteLambertian());
  const SceneState state{.leds = {{0, 1000}}};
  const Result<Image> frame = RenderCameraFrame(scene, "top", state, {.exposure_us = 5000}, 7);
  ASSERT_TRUE(frame.ok()) << frame.status().ToString();
  ASSERT_EQ(frame->channel_names(), (std::vector<std::string>{"radiance", "raw"}));
  const Image radiance = scene.RenderRadiance(0, state);
  EXPECT_TRUE(std::equal(radiance.channel(0).begin(), radiance.channel(0).end(), frame->channel(0).begin()));
  const std::vector<uint16_t> raw = CaptureRaw(radiance, scene.rig().cameras[0].sensor, {.exposure_us = 5000}, 7);
  EXPECT_TRUE(std::equal(raw.begin(), raw.end(), frame->channel(1).begin()));
  const Result<Image> unknown = RenderCameraFrame(scene, "side", state, {}, 7);
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.status().ToString().find("camera 'side'"), std::string::npos) << unknown.status().ToString();
  const int leds = static_cast<int>(scene.rig().leds.size());
  const Result<Image> no_such_led = RenderCameraFrame(scene, "top", {.leds = {{leds, 1000}}}, {}, 7);
  ASSERT_FALSE(no_such_led.ok());
  EXPECT_NE(no_such_led.status().ToString().find("LED " + std::to_string(leds)), std::string::npos)
      << no_such_led.status().ToString();
}

// A tile raised 30 mm: near-vertical rays find its top to within the shadow test's tolerance,
// so it is lit (not shadowed by itself) with the analytic radiance at its height.
TEST(RendererTest, ARaisedTileIsLitAtItsHeight) {
  const Scene scene(TestRig(), WhiteTileOnSpacer({128, 128, 0.5}, 1.0, 30));
  const SceneState state{.leds = {{0, 1000}}};
  const Image radiance = scene.RenderRadiance(0, state, {.supersampling = 1});
  const LedModel& led = scene.rig().leds[0];
  // Pixel (50, 50) looks straight down at the origin; (70, 50) meets z = 30 at x = 10 · 470/500.
  for (const auto& [column, p] : {std::pair{50, Eigen::Vector3d(0, 0, 30)}, std::pair{70, Eigen::Vector3d(9.4, 0, 30)}}) {
    EXPECT_NEAR(radiance.at(0, 50, column), AnalyticRadiance(led, p), 1e-4 * AnalyticRadiance(led, p)) << column;
  }
}

TEST(RendererTest, InverseSquareAndAngularFalloff) {
  RigModel rig = TestRig();
  const Eigen::Vector3d p(0, 0, 0);
  const Eigen::Vector3d eye(0, 0, 500);
  const SceneState state{.leds = {{0, 1000}}};
  const double near = Scene(rig, WhiteLambertian()).RadianceAt(p, eye, state, true);
  rig.leds[0].position_mm *= 2;  // same direction, twice as far
  const double far = Scene(rig, WhiteLambertian()).RadianceAt(p, eye, state, true);
  EXPECT_NEAR(far / near, 0.25, 1e-12);
  const double axis_angle = DegToRad(40);
  rig.leds[0].axis = Eigen::AngleAxisd(axis_angle, Eigen::Vector3d::UnitY()) * rig.leds[0].axis;
  const double tilted = Scene(rig, WhiteLambertian()).RadianceAt(p, eye, state, true);
  EXPECT_NEAR(tilted / far, std::pow(std::cos(axis_angle), 2), 1e-9);
  const SceneState half{.leds = {{0, 500}}};
  EXPECT_NEAR(Scene(rig, WhiteLambertian()).RadianceAt(p, eye, half, true) / tilted, 0.5, 1e-12);
}

TEST(RendererTest, CastShadowFallsWhereTheGeometryPutsIt) {
  RigModel rig = TestRig();
  rig.leds[0].position_mm = {400, 0, 400};  // 45° elevation from +x
  rig.leds[0].axis = -rig.leds[0].position_mm.normalized();
  Material block = WhiteLambertian(200, 0.1);  // 20 mm square
  block.provenance["loom.geometric_blur_mm"] = 0.2;
  const int height = *block.maps.ChannelIndex("height");
  for (int y = 0; y < 200; ++y) {
    for (int x = 0; x < 200; ++x) {
      const double cx = (x + 0.5 - 100) * 0.1, cy = (y + 0.5 - 100) * 0.1;
      if (std::abs(cx) < 5 && std::abs(cy) < 5) block.maps.at(height, y, x) = 2.0f;  // a 2 mm block
    }
  }
  const Scene scene(rig, block);
  const SceneState state{.leds = {{0, 1000}}};
  const Eigen::Vector3d eye(0, 0, 500);
  // The block's far edge is at x = −5; from 45°, its 2 mm cast a 2 mm shadow down to x = −7
  // (the light is not at infinity: at 400 mm the shadow ends 2.04 mm from the edge).
  const double edge = -5 - 2 * (400 + 5) / (400 - 2.0);
  for (double x : {-5.3, -6.0, edge + 0.15}) {
    EXPECT_EQ(scene.RadianceAt({x, 0, 0}, eye, state, true), 0.0) << "x = " << x;
  }
  for (double x : {edge - 0.15, -8.0, 6.0}) {
    EXPECT_GT(scene.RadianceAt({x, 0, 0}, eye, state, true), 0.0) << "x = " << x;
  }
  EXPECT_GT(scene.RadianceAt({-6.0, 0, 0}, eye, state, /*shadows=*/false), 0.0);
}

TEST(RendererTest, SameSeedSameFrameWhateverTheThreads) {
  const Scene scene(TestRig(), WhiteLambertian());
  const SceneState state{.leds = {{0, 1000}}};
  const Image one = scene.RenderRadiance(0, state, {.supersampling = 2, .threads = 1});
  const Image two = scene.RenderRadiance(0, state, {.supersampling = 2, .threads = 2});
  ASSERT_TRUE(std::equal(one.data(), one.data() + one.pixel_count(), two.data()));
  const SensorModel& sensor = scene.rig().cameras[0].sensor;
  const CaptureSettings unsaturated{.exposure_us = 100};
  const std::vector<uint16_t> frame = CaptureRaw(one, sensor, unsaturated, 7);
  EXPECT_EQ(frame, CaptureRaw(two, sensor, unsaturated, 7));
  EXPECT_NE(frame, CaptureRaw(one, sensor, unsaturated, 8));
  EXPECT_LT(*std::max_element(frame.begin(), frame.end()), (1 << sensor.adc_bits) - 1);
}

TEST(RendererTest, SensorNoiseAndSaturationFollowTheModel) {
  SensorModel sensor;
  sensor.vignetting = 0;
  const CaptureSettings settings{.exposure_us = 10000, .gain_db = 0};
  // Radiance giving 2000 electrons: well inside the range.
  const double mean_e = 2000;
  Image flat(200, 200, {"L"});
  std::fill(flat.channel(0).begin(), flat.channel(0).end(),
            static_cast<float>(mean_e / (sensor.sensitivity * settings.exposure_us * 1e-6)));
  const std::vector<uint16_t> raw = CaptureRaw(flat, sensor, settings, 1);
  double sum = 0, sum2 = 0;
  for (uint16_t v : raw) {
    sum += v;
    sum2 += static_cast<double>(v) * v;
  }
  const double n = raw.size();
  const double mean = sum / n;
  const double variance = sum2 / n - mean * mean;
  const double g = 1 / sensor.ElectronsPerDn();  // DN per electron
  EXPECT_NEAR(mean, sensor.dark_offset_dn + mean_e * g, 0.2);
  const double expected_variance = (mean_e + sensor.read_noise_e * sensor.read_noise_e) * g * g + 1.0 / 12;
  EXPECT_NEAR(variance / expected_variance, 1.0, 0.03);  // 40,000 samples: ±0.7 % standard error
  // Ten times the full well: every pixel at the ADC's top.
  std::fill(flat.channel(0).begin(), flat.channel(0).end(), flat.at(0, 0, 0) * 50);
  for (uint16_t v : CaptureRaw(flat, sensor, settings, 2)) ASSERT_EQ(v, (1 << sensor.adc_bits) - 1);
  // No light: the dark offset with read noise only.
  std::fill(flat.channel(0).begin(), flat.channel(0).end(), 0.0f);
  const std::vector<uint16_t> dark = CaptureRaw(flat, sensor, settings, 3, /*noise=*/false);
  EXPECT_EQ(dark[0], static_cast<uint16_t>(sensor.dark_offset_dn));
}

TEST(RendererTest, LensDistortionRoundTrips) {
  CameraModel camera = TestRig().cameras[0];
  camera.distortion << -0.12, 0.03, 0.001, -0.0007, 0.0;
  for (const Eigen::Vector2d& pixel : {Eigen::Vector2d(3, 4), Eigen::Vector2d(50, 50), Eigen::Vector2d(97.5, 12)}) {
    Eigen::Vector2d back;
    ASSERT_TRUE(camera.Project(camera.Unproject(pixel) * 10, &back));
    EXPECT_NEAR((back - pixel).norm(), 0.0, 1e-6) << pixel.transpose();
  }
}

LinearLightModel Strip(double length_mm, int segments) {
  LinearLightModel strip;
  strip.arm_radius_mm = 400;
  strip.strip_length_mm = length_mm;
  strip.sweep_axis = Eigen::Vector3d::UnitY();
  strip.start_deg = -60;
  strip.end_deg = 60;
  strip.travel_mm = 240;
  strip.intensity_per_mm = 5000;
  strip.falloff_exponent = 1;
  strip.segments = segments;
  return strip;
}

TEST(RendererTest, AShortStripIsAPointSourceAndALongOneIsIntegrated) {
  const Eigen::Vector3d p(3, -2, 0);
  const Eigen::Vector3d eye(0, 0, 500);
  RigModel rig = TestRig();
  rig.linear_light = Strip(1.0, 1);
  SceneState strip_on{.linear_light_on = true, .linear_light_mm = 60, .linear_light_intensity = 0.8};
  const double strip = Scene(rig, WhiteLambertian()).RadianceAt(p, eye, strip_on, false);
  // The same light as an LED at the strip centre, pointing along the strip's normal.
  LedModel led;
  led.position_mm = rig.linear_light->StripCentre(60);
  led.axis = rig.linear_light->StripNormal(60);
  led.intensity = 5000 * 1.0 * 0.8;
  led.falloff_exponent = 1;
  EXPECT_GT(strip, 0);
  EXPECT_NEAR(strip, AnalyticRadiance(led, p), 1e-9 * strip);
  // A 300 mm strip: 32 segments integrate it to within 0.5 % of 2000.
  rig.linear_light = Strip(300, 32);
  const double coarse = Scene(rig, WhiteLambertian()).RadianceAt(p, eye, strip_on, false);
  rig.linear_light = Strip(300, 2000);
  const double fine = Scene(rig, WhiteLambertian()).RadianceAt(p, eye, strip_on, false);
  EXPECT_NEAR(coarse, fine, 0.005 * fine);
  // The sweep: a white Lambertian point is lit most with the strip overhead (mid travel).
  const auto at = [&](double position) {
    SceneState state = strip_on;
    state.linear_light_mm = position;
    return Scene(rig, WhiteLambertian()).RadianceAt({0, 0, 0}, eye, state, false);
  };
  EXPECT_GT(at(120), at(60));
  EXPECT_GT(at(120), at(180));
  EXPECT_NEAR(at(60), at(180), 1e-9 * at(60));  // symmetric sweep
}

TEST(RendererTest, ProjectorLightFollowsThePatternsGreyLevel) {
  RigModel rig = TestRig();
  ProjectorModel projector;
  projector.width = 64;
  projector.height = 40;
  projector.K << 200, 0, 31.5, 0, 200, 19.5, 0, 0, 1;
  Eigen::Matrix3d down;
  down << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  projector.proj_from_rig = MakeRigid(down, -down * Eigen::Vector3d(0, 0, 400));
  rig.projector = projector;
  const Scene scene(rig, WhiteLambertian());
  const auto lit_by = [&](uint8_t left, uint8_t right, const Eigen::Vector3d& p) {
    auto image = std::make_shared<ProjectedImage>(ProjectedImage{64, 40, std::vector<uint8_t>(64 * 40)});
    for (int v = 0; v < 40; ++v) {
      for (int u = 0; u < 64; ++u) image->pixels[v * 64 + u] = u < 32 ? left : right;
    }
    return scene.RadianceAt(p, {0, 0, 500}, SceneState{.projector_image = image}, true);
  };
  // The projector looks straight down from 400 mm: image column u sees x = (u − 31.5) · 2 mm.
  const Eigen::Vector3d left_point(-20, 0, 0), right_point(20, 0, 0);
  EXPECT_GT(lit_by(255, 0, left_point), 0);
  EXPECT_EQ(lit_by(255, 0, right_point), 0);
  EXPECT_NEAR(lit_by(128, 0, left_point) / lit_by(255, 0, left_point), 128.0 / 255, 1e-12);
  EXPECT_EQ(scene.RadianceAt(left_point, {0, 0, 500}, SceneState{}, true), 0);  // dark projector
}

// A frame with every light off needs no rendering: Dark says so only where nothing can light
// the sample, and there the render is 0 everywhere.
TEST(RendererTest, OnlyAStateWithEveryLightOffIsDark) {
  RigModel rig = TestRig();
  LinearLightModel strip;
  rig.linear_light = strip;
  ProjectorModel projector;
  projector.width = projector.height = 4;
  rig.projector = projector;
  const Scene scene(rig, WhiteLambertian());
  const SceneState off{.leds = {{0, 0}}};
  EXPECT_TRUE(scene.Dark(SceneState{}));
  EXPECT_TRUE(scene.Dark(off));
  const Image radiance = scene.RenderRadiance(0, off, {.supersampling = 1});
  EXPECT_TRUE(std::ranges::all_of(radiance.channel(0), [](float v) { return v == 0; }));
  EXPECT_FALSE(scene.Dark(SceneState{.leds = {{0, 1000}}}));
  EXPECT_FALSE(scene.Dark(SceneState{.linear_light_on = true}));
  EXPECT_TRUE(scene.Dark(SceneState{.linear_light_on = true, .linear_light_intensity = 0}));
  EXPECT_FALSE(scene.Dark(
      SceneState{.projector_image = std::make_shared<ProjectedImage>(ProjectedImage{4, 4, std::vector<uint8_t>(16)})}));
}

}  // namespace
}  // namespace loom::sim
