// The fast path against the full renderer: a stack pixel holds what a camera's raw render shows
// at that point when re-projected through the true camera model; occluded points are NaN.
#include "sim/stack.h"

#include <gtest/gtest.h>

#include "core/spectra.h"
#include "sim/fabric.h"
#include "sim/test_materials.h"

namespace loom::sim {
namespace {

// Two cameras 500 mm away (top and 45° from the normal on the −x side), two LEDs.
RigModel TwoCameraRig() {
  RigModel rig;
  for (double inclination : {0.0, 45.0}) {
    CameraModel camera;
    camera.name = inclination == 0 ? "top" : "side";
    camera.width = camera.height = 120;
    camera.K << 1500, 0, 59.5, 0, 1500, 59.5, 0, 0, 1;
    camera.distortion << -0.1, 0.02, 0, 0, 0;
    const Eigen::Vector3d position = 500 * DirectionFromSpherical(DegToRad(inclination), kPi);
    const Eigen::Vector3d z = -position.normalized();
    const Eigen::Vector3d y = -(Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitY().dot(z) * z).normalized();
    Eigen::Matrix3d r;
    r.row(0) = y.cross(z).transpose();
    r.row(1) = y.transpose();
    r.row(2) = z.transpose();
    camera.cam_from_rig = MakeRigid(r, -r * position);
    rig.cameras.push_back(camera);
  }
  for (double azimuth : {30.0, 200.0}) {
    LedModel led;
    led.position_mm = 600 * DirectionFromSpherical(DegToRad(40), DegToRad(azimuth));
    led.axis = -led.position_mm.normalized();
    rig.leds.push_back(led);
  }
  return rig;
}

double Bilinear(const Image& image, const Eigen::Vector2d& pixel) {
  const int x0 = static_cast<int>(std::floor(pixel.x()));
  const int y0 = static_cast<int>(std::floor(pixel.y()));
  const double fx = pixel.x() - x0, fy = pixel.y() - y0;
  const auto at = [&](int x, int y) { return static_cast<double>(image.at(0, y, x)); };
  return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) + fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

TEST(StackTest, AgreesWithRawRendersReprojectedByTheCameraModel) {
  fitting::WardParams<double> glossy;
  glossy.a_d = Eigen::Vector3d::Constant(0.5);
  glossy.a_s = Eigen::Vector3d::Constant(0.2);
  glossy.sigma_x = glossy.sigma_y = 0.3;
  const Scene scene(TwoCameraRig(), UniformMaterial("glossy", glossy, {60, 60, 0.5}));
  const std::vector<Observation> observations = {{1, {.leds = {{0, 1000}}}}, {0, {.leds = {{1, 1000}}, .turntable_deg = 30}}};
  const Image stack = RenderStack(scene, observations, {}).image;
  for (size_t o = 0; o < observations.size(); ++o) {
    const Observation& obs = observations[o];
    const Image raw = scene.RenderRadiance(obs.camera, obs.state, {.supersampling = 4});
    const CameraModel& camera = scene.rig().cameras[obs.camera];
    const Rigid3d cam_from_sample = camera.cam_from_rig * scene.rig().turntable.RigFromSample(obs.state.turntable_deg);
    int compared = 0;
    for (int y = 10; y < 50; y += 3) {
      for (int x = 10; x < 50; x += 3) {
        const Eigen::Vector3d p(stack.at(0, y, x), stack.at(1, y, x), stack.at(2, y, x));
        Eigen::Vector2d pixel;
        ASSERT_TRUE(camera.Project(cam_from_sample * p, &pixel));
        const double expected = Bilinear(raw, pixel);
        const double actual = stack.at(6 + static_cast<int>(o), y, x);
        ASSERT_NEAR(actual, expected, 0.01 * expected) << "obs " << o << " at " << x << "," << y;
        ++compared;
      }
    }
    EXPECT_GT(compared, 100);
  }
}

TEST(StackTest, PointsTheCameraCannotSeeAreNaN) {
  Material block = WhiteTile({80, 80, 0.25});  // 20 mm
  const int height = *block.maps.ChannelIndex("height");
  for (int y = 0; y < 80; ++y) {
    for (int x = 30; x < 50; ++x) block.maps.at(height, y, x) = 3.0f;  // a 3 mm ridge along y
  }
  const Scene scene(TwoCameraRig(), block);
  // The side camera looks from −x: the floor just beyond the ridge (x > +2.5 mm) is hidden.
  const Image stack = RenderStack(scene, {{1, {.leds = {{0, 1000}}}}, {0, {.leds = {{0, 1000}}}}}, {}).image;
  const int hidden_x = 52;   // x ≈ +3.1 mm, behind the ridge for the 45° camera
  const int visible_x = 20;  // x ≈ −4.9 mm, in front of it
  EXPECT_TRUE(std::isnan(stack.at(6, 40, hidden_x)));
  EXPECT_FALSE(std::isnan(stack.at(6, 40, visible_x)));
  EXPECT_FALSE(std::isnan(stack.at(7, 40, hidden_x)));  // the top camera sees it
  EXPECT_NEAR(stack.at(2, 40, 40), 3.0, 1e-6);          // pos.Z on the ridge
}

TEST(StackTest, DefaultObservationsCoverCamerasLightsAnglesAndFilters) {
  RigModel rig = TwoCameraRig();
  rig.filter_wheels.push_back(
      {"wheel0",
       1,
       {FilterModel::Open(), FilterModel::BandPass(450, 30), FilterModel::BandPass(550, 30), FilterModel::BandPass(650, 30)}});
  const std::vector<Observation> observations = DefaultObservations(rig, {0, 120, 240});
  EXPECT_EQ(observations.size(), 2u * 2u * 3u + 3u * 2u);
  const StackObservation side = DescribeObservation(rig, observations[3]);  // angle 0, side camera, LED 1
  EXPECT_EQ(side.description, "side, turntable 0 deg, led 1 at 1000 mA");
  EXPECT_EQ(side.group, ObservationGroup::kMonochrome);
  EXPECT_LT((side.camera_mm - Eigen::Vector3d(-353.55, 0, 353.55)).norm(), 0.01);
  ASSERT_EQ(side.emitters.size(), 1u);
  EXPECT_LT((side.emitters[0].position_mm - rig.leds[1].position_mm).norm(), 1e-9);
  const StackObservation filtered = DescribeObservation(rig, observations[12 + 2]);
  EXPECT_EQ(filtered.group, ObservationGroup::kColour);
  EXPECT_NE(filtered.description.find("wheel0 slot 2 (550 nm)"), std::string::npos) << filtered.description;
  EXPECT_EQ(filtered.rgb_weights, FilterWeights(rig.filter_wheels[0].filters[2]));
  // Through the open slot the LED behind the wheel lights a monochrome observation.
  const StackObservation open = DescribeObservation(rig, {0, {.leds = {{1, 1000}}, .filter_slots = {{0, 0}}}});
  EXPECT_EQ(open.group, ObservationGroup::kMonochrome);
  EXPECT_EQ(open.rgb_weights, PanchromaticWeights());
  EXPECT_NE(open.description.find("wheel0 slot 0 (open)"), std::string::npos) << open.description;
}

TEST(StackTest, TheTurntableAngleMovesLightsAndCamerasIntoTheSampleFrame) {
  RigModel rig = TwoCameraRig();
  const StackObservation turned = DescribeObservation(rig, {0, {.leds = {{0, 500}}, .turntable_deg = 90}});
  const Rigid3d sample_from_rig = rig.turntable.RigFromSample(90).inverse();
  EXPECT_LT((turned.emitters[0].position_mm - sample_from_rig * rig.leds[0].position_mm).norm(), 1e-9);
  EXPECT_NEAR(turned.emitters[0].intensity, 0.5 * rig.leds[0].intensity, 1e-9);
  // At 90° the LED's azimuth of 30° becomes −60° in the sample frame.
  EXPECT_NEAR(RadToDeg(std::atan2(turned.emitters[0].position_mm.y(), turned.emitters[0].position_mm.x())), -60, 1e-9);
}

TEST(StackTest, TheLinearLightIsOneEmitterPerSegment) {
  RigModel rig = TwoCameraRig();
  rig.linear_light = LinearLightModel{};
  const StackObservation strip =
      DescribeObservation(rig, {0, {.linear_light_on = true, .linear_light_mm = 100, .linear_light_intensity = 0.5}});
  EXPECT_EQ(strip.group, ObservationGroup::kLinearLight);
  ASSERT_EQ(strip.emitters.size(), static_cast<size_t>(rig.linear_light->segments));
  const double segment_mm = rig.linear_light->strip_length_mm / rig.linear_light->segments;
  EXPECT_NEAR(strip.emitters[0].intensity, 0.5 * rig.linear_light->intensity_per_mm * segment_mm, 1e-9);
  EXPECT_NEAR((strip.emitters[1].position_mm - strip.emitters[0].position_mm).norm(), segment_mm, 1e-9);
}

// The simulator's options name every bad field, and its makers refuse them (a CheckError: these
// come from code, a rig's `sample:` is checked before, in SampleSpec).
TEST(SimOptionsTest, BadGridsRenderingsAndStacksAreRefusedNamingEachField) {
  const GridOptions grid{.width_px = 0, .height_px = 20000, .pixel_mm = std::nan("")};
  for (const char* field : {"width_px", "height_px", "pixel_mm"}) {
    EXPECT_NE(grid.Check().ToString().find(field), std::string::npos) << field << " in " << grid.Check().ToString();
  }
  EXPECT_THROW(WhiteTile(grid), CheckError);
  const FabricOptions fabric{.width_px = 8, .height_px = 8, .pixel_mm = 1e-300, .geometric_blur_mm = -1, .supersampling = 0};
  for (const char* field : {"pixel_mm", "geometric_blur_mm", "supersampling"}) {
    EXPECT_NE(fabric.Check().ToString().find(field), std::string::npos) << field << " in " << fabric.Check().ToString();
  }
  EXPECT_THROW(GenerateFabric(1, fabric), CheckError);
  const RenderOptions render{.supersampling = 0, .threads = -1};
  EXPECT_NE(render.Check().ToString().find("supersampling"), std::string::npos);
  EXPECT_NE(render.Check().ToString().find("threads"), std::string::npos);
  StackOptions stack;
  EXPECT_TRUE(stack.Check().ok()) << "0 means the material's grid";
  stack.pixel_mm = -0.1;
  EXPECT_NE(stack.Check().ToString().find("pixel_mm"), std::string::npos) << stack.Check().ToString();
}

}  // namespace
}  // namespace loom::sim
