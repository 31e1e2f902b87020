// Views for checking an export in another renderer: which observations, loom's rendering of the
// maps under them, and the files web/render-check.mjs reads.
#include "fitting/report/renderer_views.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>

#include <nlohmann/json.hpp>

#include "fitting/model/svbrdf_maps.h"
#include "fitting/model/ward_gd10.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

// Observation k: one LED at 300 mm, its stack radiance k everywhere; observation 3 has two
// emitters (a linear-light segment pair), which no renderer's point light stands for.
ObservationStack StackOfLeds() {
  std::vector<StackObservation> observations(4);
  for (int k = 0; k < 4; ++k) {
    observations[k].camera_mm = {0, 0, 500};
    observations[k].emitters = {{{100.0 * k, 0, 300}, -Eigen::Vector3d::UnitZ(), 2e4, 0}};
  }
  observations[3].emitters.push_back(observations[3].emitters.front());
  ObservationStack stack = MakeObservationStack(3, 2, 0.5, observations);
  for (int k = 0; k < 4; ++k) {
    for (float& v : stack.image.channel(ObservationStack::ObservationChannel(k))) v = static_cast<float>(k);
  }
  return stack;
}

Image Maps() {
  Image maps = MakeSvbrdfImage(3, 2, false);
  WardParams<double> p;
  p.a_d = {0.5, 0.3, 0.1};
  p.a_s = {0.2, 0.2, 0.2};
  p.sigma_x = 0.2;
  p.sigma_y = 0.1;
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 3; ++x) SetParams(maps, x, y, p);
  }
  return maps;
}

TEST(RendererViewsTest, ChoosesSingleEmitterObservationsFromTheBrightestDown) {
  const std::vector<RendererView> views = ChooseRendererViews(StackOfLeds(), 2);
  ASSERT_EQ(views.size(), 2u);
  EXPECT_EQ(views[0].observation, 2);  // the brightest with one emitter
  EXPECT_EQ(views[1].observation, 1);
  EXPECT_EQ(views[0].light_mm, Eigen::Vector3d(200, 0, 300));
  EXPECT_DOUBLE_EQ(views[0].intensity, 2e4);  // falloff exponent 0: isotropic
  EXPECT_EQ(views[0].view, Eigen::Vector3d::UnitZ());
  EXPECT_EQ(ChooseRendererViews(StackOfLeds(), 10).size(), 3u);
}

TEST(RendererViewsTest, RendersTheModelUnderAPointLightAtEachPixelsPosition) {
  const RendererView view{0, {100, 50, 300}, 2e4, Eigen::Vector3d(0.3, 0, 1).normalized()};
  const Image rendered = RenderView(Maps(), 0.5, view);
  // Pixel (2, 1) lies at (0.5, 0.25, 0) mm on the quad.
  const Eigen::Vector3d to_light = Eigen::Vector3d(100, 50, 300) - Eigen::Vector3d(0.5, 0.25, 0);
  const Eigen::Vector3d expected =
      EvaluateWardCos(GetParams(Maps(), 2, 1), Eigen::Vector3d(to_light.normalized()), view.view) * 2e4 / to_light.squaredNorm();
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(rendered.at(c, 1, 2), expected[c], 1e-6 * expected[c]) << c;
  EXPECT_NE(rendered.at(0, 0, 0), rendered.at(0, 1, 2));  // the light's direction varies over the quad
}

TEST(RendererViewsTest, WritesTheViewsInBothFramesWithLoomsRendering) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("renderer_views_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const ObservationStack stack = StackOfLeds();
  ASSERT_TRUE(WriteRendererViews(dir, Maps(), 0.5, stack, ChooseRendererViews(stack, 1)).ok());
  std::ifstream file(dir / "views.json");
  const nlohmann::json views = nlohmann::json::parse(file);
  EXPECT_EQ(views["width"], 3);
  const nlohmann::json& view = views["views"][0];
  EXPECT_EQ(view["name"], "obs0002");
  EXPECT_EQ(view["gltf"]["light_m"], nlohmann::json({0.2, 0.3, -0.0}));  // glTF: +y up, −z the sample's y
  EXPECT_DOUBLE_EQ(view["threejs_intensity"].get<double>(), 2e4 * 1e-6);
  EXPECT_EQ(fs::file_size(dir / view["loom"].get<std::string>()), 3u * 2 * 3 * sizeof(float));
  EXPECT_TRUE(fs::exists(dir / view["loom_png"].get<std::string>()));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace loom::fitting
