// The stack's observation table is a complete light model: with a pixel's true parameters the
// model predicts every value of the simulator's fast-path stack — colour, point-lit and linear
// light, at three turntable angles — and the observations the heightmap says are shadowed are
// exactly the dark ones.
#include "fitting/model/stack_pixels.h"

#include <set>

#include <gtest/gtest.h>

#include "core/parallel.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/testing/tac7_mini.h"
#include "sim/fabric.h"
#include "sim/stack.h"

namespace loom::fitting {
namespace {

void ExpectSameObservations(const std::vector<PixelObservation>& got, const std::vector<PixelObservation>& expected, int pixel) {
  ASSERT_EQ(got.size(), expected.size()) << "pixel " << pixel;
  for (size_t k = 0; k < expected.size(); ++k) {
    EXPECT_EQ(got[k].source, expected[k].source);
    EXPECT_EQ(got[k].radiance, expected[k].radiance);
    EXPECT_EQ(got[k].v_local, expected[k].v_local);
    EXPECT_EQ(got[k].rgb_weights, expected[k].rgb_weights);
    ASSERT_EQ(got[k].lights.size(), expected[k].lights.size()) << "pixel " << pixel << ", observation " << k;
    for (size_t l = 0; l < expected[k].lights.size(); ++l) {
      EXPECT_EQ(got[k].lights[l].l_local, expected[k].lights[l].l_local);
      EXPECT_EQ(got[k].lights[l].irradiance, expected[k].lights[l].irradiance);
    }
  }
}

TEST(StackPixelsTest, TheTableAndTrueParametersReproduceTheFastPathStack) {
  const sim::Material fabric = sim::GenerateFabric(7, {.width_px = 24, .height_px = 24, .pixel_mm = 0.2});
  const sim::Scene scene(testing::TacMiniGeometry(), fabric);
  const ObservationStack stack = sim::RenderStack(scene, testing::TacMiniObservations(scene.rig(), 5), {});
  const StackPixels pixels(stack);
  int compared = 0;
  int shadowed = 0;
  double worst = 0;
  for (int y = 0; y < stack.image.height(); ++y) {
    for (int x = 0; x < stack.image.width(); ++x) {
      const WardLobe<double> lobe(GetParams(fabric.maps, x, y));
      std::vector<bool> kept(stack.observations.size(), false);
      for (const PixelObservation& o : pixels.Observations(x, y)) {
        kept[o.source] = true;
        const double predicted = PredictRadiance(lobe, o);
        worst = std::max(worst, std::abs(predicted - o.radiance) / (std::abs(o.radiance) + 1e-3));
        ++compared;
      }
      for (size_t k = 0; k < kept.size(); ++k) {
        const float value = stack.image.at(ObservationStack::ObservationChannel(static_cast<int>(k)), y, x);
        if (kept[k] || std::isnan(value)) continue;
        EXPECT_EQ(value, 0.0f) << "observation " << k << " left out as shadowed at " << x << "," << y;
        ++shadowed;
      }
    }
  }
  EXPECT_LT(worst, 1e-4);  // float storage of the stack
  EXPECT_GT(compared, 24 * 24 * 80);
  EXPECT_GT(shadowed, 0) << "the fabric's relief should shadow some grazing LEDs";
}

// Kept frames change nothing: every pixel's observations, asked for twice from two threads (the
// second time from the kept frame and hidden emitters), equal those computed afresh, light by
// light, on a relief that hides some of them.
TEST(StackPixelsTest, KeptFramesGiveTheSameObservationsOnEveryCall) {
  const sim::Material fabric = sim::GenerateFabric(7, {.width_px = 16, .height_px = 16, .pixel_mm = 0.2});
  const sim::Scene scene(testing::TacMiniGeometry(), fabric);
  const ObservationStack stack = sim::RenderStack(scene, testing::TacMiniObservations(scene.rig(), 5), {});
  const StackPixels fresh(stack);
  const StackPixels kept(stack, {.cast_shadows = true, .strip_quadrature = std::nullopt, .keep_frames = true});
  const StackPixels unshadowed(stack, {.cast_shadows = false, .strip_quadrature = std::nullopt, .keep_frames = false});
  const int count = stack.image.width() * stack.image.height();
  const auto light_count = [&](const StackPixels& pixels) {
    size_t lights = 0;
    for (int i = 0; i < count; ++i) {
      for (const PixelObservation& o : pixels.Observations(i % stack.image.width(), i / stack.image.width())) {
        lights += o.lights.size();
      }
    }
    return lights;
  };
  ASSERT_LT(light_count(fresh), light_count(unshadowed)) << "the relief should hide some emitters";
  std::vector<std::vector<PixelObservation>> first(count), second(count);
  for (int round = 0; round < 2; ++round) {
    std::vector<std::vector<PixelObservation>>& into = round == 0 ? first : second;
    ParallelFor(count, 2, [&](int i) { into[i] = kept.Observations(i % stack.image.width(), i / stack.image.width()); });
  }
  for (int i = 0; i < count; ++i) {
    const std::vector<PixelObservation> expected = fresh.Observations(i % stack.image.width(), i / stack.image.width());
    ExpectSameObservations(first[i], expected, i);
    ExpectSameObservations(second[i], expected, i);
  }
}

// One vector reused from pixel to pixel, as the refiner does, whatever the last pixel left in
// it (more observations or fewer: the relief shadows some): each pixel's own, with the stack's
// emitters and with strips integrated around a lobe.
TEST(StackPixelsTest, ObservationsIntoAReusedVectorAreThePixelsOwn) {
  const sim::Material fabric = sim::GenerateFabric(7, {.width_px = 16, .height_px = 16, .pixel_mm = 0.2});
  const sim::Scene scene(testing::TacMiniGeometry(), fabric);
  const ObservationStack stack = sim::RenderStack(scene, testing::TacMiniObservations(scene.rig(), 5), {});
  const StackPixels emitters(stack);
  const StackPixels nodes(stack, {.cast_shadows = true, .strip_quadrature = StripQuadratureOptions{}, .keep_frames = false});
  const int width = stack.image.width(), count = width * stack.image.height();
  std::vector<PixelObservation> into;
  std::set<size_t> sizes;
  for (int i = 0; i < count; ++i) {
    const WardParams<double> lobe = GetParams(fabric.maps, i % width, i / width);
    emitters.ObservationsInto(i % width, i / width, nullptr, into);
    ExpectSameObservations(into, emitters.Observations(i % width, i / width), i);
    sizes.insert(into.size());
    nodes.ObservationsInto(i % width, i / width, &lobe, into);
    ExpectSameObservations(into, nodes.Observations(i % width, i / width, lobe), i);
  }
  EXPECT_GT(sizes.size(), 1u) << "every pixel kept as many observations: the reuse of a longer list is untested";
}

}  // namespace
}  // namespace loom::fitting
