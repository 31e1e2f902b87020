// The re-rendering loss's torch GD10 against the fitters' PredictRadiance, on a simulated
// tac7-mini stack: equal radiance for the truth's labels (and so a loss of 0 there), a strip
// merged as MergeLightSamples merges it, and gradients that lead back to the truth.
#include "fitting/cnn/torch/rerender_loss.h"

#include <gtest/gtest.h>

#include <algorithm>

#include <random>

#include "fitting/model/label.h"
#include "fitting/model/stack_pixels.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/solve/batch_refiner.h"
#include "fitting/testing/tac7_mini.h"
#include "sim/fabric.h"

namespace loom::fitting::internal {
namespace {

struct Simulated {
  sim::Material fabric;
  ObservationStack stack;
};

Simulated FabricStack() {
  sim::Material fabric = sim::GenerateFabric(21, {.width_px = 4, .height_px = 4, .pixel_mm = 0.2});
  const sim::Scene scene(testing::TacMiniGeometry(), fabric);
  ObservationStack stack = sim::RenderStack(scene, testing::TacMiniObservations(scene.rig(), 12), {});
  return {std::move(fabric), std::move(stack)};
}

at::Tensor LabelsOf(const std::vector<WardParams<double>>& params) {
  at::Tensor labels = at::empty({static_cast<int64_t>(params.size()), kLabelSize}, at::kFloat);
  for (size_t p = 0; p < params.size(); ++p) {
    const Label label = EncodeLabel(params[p]);
    for (int c = 0; c < kLabelSize; ++c) labels[p][c] = static_cast<float>(label[c]);
  }
  return labels;
}

TEST(RerenderLossTest, RendersWhatPredictRadianceDoes) {
  const Simulated simulated = FabricStack();
  const StackPixels pixels(simulated.stack);
  std::vector<std::vector<PixelObservation>> observations;
  std::vector<WardParams<double>> params;
  for (int i = 0; i < 4; ++i) {
    observations.push_back(pixels.Observations(i, 3 - i));
    params.push_back(GetParams(simulated.fabric.maps, i, 3 - i));
  }
  const at::Tensor labels = LabelsOf(params);
  for (const int max_lights : {0, 8}) {
    const RerenderBatch batch = MakeRerenderBatch(observations, max_lights);
    const at::Tensor rendered = RenderObservations(labels, batch);
    int64_t k = 0;
    for (size_t p = 0; p < observations.size(); ++p) {
      // Through the float label, as the network's output would carry it.
      at::Tensor row = labels[static_cast<int64_t>(p)];
      Label label;
      for (int c = 0; c < kLabelSize; ++c) label[c] = row[c].item<float>();
      const WardLobe<double> lobe(DecodeLabel(label));
      for (PixelObservation o : observations[p]) {
        if (!std::isfinite(o.radiance) || o.lights.empty()) continue;
        if (max_lights > 0) o.lights = MergeLightSamples(o.lights, max_lights);
        const double expected = PredictRadiance(lobe, o);
        // Rendered in float: within its rounding of the double prediction.
        ASSERT_NEAR(rendered[k].item<double>(), expected, 2e-5 * (1 + std::abs(expected)))
            << "pixel " << p << ", observation " << k;
        ++k;
      }
    }
    EXPECT_EQ(k, rendered.size(0));
    EXPECT_GT(k, 4 * 100);  // 88 point-lit and 24 strip observations per pixel, some shadowed
  }
}

TEST(RerenderLossTest, IsZeroAtTheTruthAndItsGradientPointsBackToIt) {
  const Simulated simulated = FabricStack();
  const StackPixels pixels(simulated.stack);
  std::vector<std::vector<PixelObservation>> observations;
  std::vector<WardParams<double>> truth, off;
  for (int i = 0; i < 4; ++i) {
    observations.push_back(pixels.Observations(i, i));
    truth.push_back(GetParams(simulated.fabric.maps, i, i));
    WardParams<double> p = truth.back();
    p.a_d *= 1.3;
    p.a_s *= 0.8;
    off.push_back(p);
  }
  const RerenderBatch batch = MakeRerenderBatch(observations, 0);
  // Float labels and rendering: the truth to ~1e-6, so its loss is ~0 but not exactly.
  EXPECT_LT(RerenderLoss(LabelsOf(truth), batch, 0.1).item<double>(), 1e-10);
  at::Tensor labels = LabelsOf(off).requires_grad_(true);
  const at::Tensor loss = RerenderLoss(labels, batch, 0.1);
  EXPECT_GT(loss.item<double>(), 1e-3);
  loss.backward();
  const at::Tensor gradient = labels.grad();
  ASSERT_TRUE(at::isfinite(gradient).all().item<bool>());
  // Too much diffuse albedo: the gradient lowers it; and a small step against the gradient
  // lowers the loss.
  EXPECT_GT(gradient.narrow(1, 0, 3).sum().item<double>(), 0);
  const at::Tensor stepped = (labels - 1e-3 * gradient / gradient.norm()).detach();
  EXPECT_LT(RerenderLoss(stepped, batch, 0.1).item<double>(), loss.item<double>());
}

// A 4 × 4 tile: one pixel weighed 100, one not valid (0), the rest 1. 4,000 draws land on the
// heavy one 100/114 of the time (the share's own spread is 0.005), never on the invalid one.
TEST(RerenderLossTest, DrawsPixelsInProportionToTheirWeightsAndNeverAnInvalidOne) {
  at::Tensor weights = at::ones({4, 4}, at::kFloat);
  weights[1][2] = 100;
  weights[3][0] = 0;
  std::mt19937_64 rng(5);
  const std::vector<int64_t> drawn = DrawPixels(weights, 4000, rng);
  ASSERT_EQ(drawn.size(), 4000u);
  const auto heavy = std::count(drawn.begin(), drawn.end(), 1 * 4 + 2);
  EXPECT_NEAR(static_cast<double>(heavy) / drawn.size(), 100.0 / 114, 0.02);
  EXPECT_EQ(std::count(drawn.begin(), drawn.end(), 3 * 4 + 0), 0);
  EXPECT_TRUE(std::all_of(drawn.begin(), drawn.end(), [](int64_t p) { return p >= 0 && p < 16; }));
  EXPECT_TRUE(DrawPixels(at::zeros({4, 4}, at::kFloat), 8, rng).empty());
}

}  // namespace
}  // namespace loom::fitting::internal
