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

// The table's rows gathered by index give the batch MakeRerenderBatch makes of the same pixels:
// the same loss and gradient; a pixel of weight 0 is left out, and a batch of nothing but such
// pixels weighs nothing.
TEST(RerenderLossTest, AGatheredBatchOfTableRowsIsTheBatchOfThosePixels) {
  const Simulated simulated = FabricStack();
  const StackPixels pixels(simulated.stack);
  std::vector<std::vector<PixelObservation>> all;
  std::vector<WardParams<double>> params;
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 4; ++x) {
      all.push_back(pixels.Observations(x, y));
      WardParams<double> p = GetParams(simulated.fabric.maps, x, y);
      p.a_d *= 1.2;
      params.push_back(p);
    }
  }
  // Rows of unequal widths: pixel 2 without its first 30 observations, and a second table without
  // strips, so narrower than the first.
  all[2].erase(all[2].begin(), all[2].begin() + 30);
  for (size_t p = 8; p < all.size(); ++p) {
    std::erase_if(all[p], [](const PixelObservation& o) { return o.lights.size() > 1; });
  }
  const RerenderTable first = MakeRerenderTable({all.begin(), all.begin() + 8}, 8);
  const RerenderTable second = MakeRerenderTable({all.begin() + 8, all.end()}, 8);
  ASSERT_LT(second.v.size(1), first.v.size(1));
  const RerenderTable table = ConcatRerenderTables({first, second});
  ASSERT_EQ(table.rows(), 16);
  const std::vector<int64_t> rows = {3, 9, 9, 2, 12};
  const at::Tensor row_index = at::tensor(rows, at::kLong);
  std::vector<std::vector<PixelObservation>> drawn;
  std::vector<WardParams<double>> drawn_params;
  for (int64_t r : rows) drawn.push_back(all[static_cast<size_t>(r)]), drawn_params.push_back(params[static_cast<size_t>(r)]);

  const auto loss_and_gradient = [](const std::vector<WardParams<double>>& labels_of, const RerenderBatch& batch) {
    at::Tensor labels = LabelsOf(labels_of).requires_grad_(true);
    const at::Tensor loss = RerenderLoss(labels, batch, 0.1);
    loss.backward();
    return std::make_pair(loss.item<double>(), labels.grad());
  };
  const auto [expected, expected_gradient] = loss_and_gradient(drawn_params, MakeRerenderBatch(drawn, 8));
  const auto [gathered, gathered_gradient] =
      loss_and_gradient(drawn_params, GatherRerenderBatch(table, row_index, at::ones({5}, at::kFloat)));
  EXPECT_GT(expected, 1e-4);
  EXPECT_NEAR(gathered, expected, 1e-5 * expected);
  EXPECT_TRUE(at::allclose(gathered_gradient, expected_gradient, 1e-4, 1e-7));

  // The last pixel weighs nothing: the batch of the first four.
  const at::Tensor four = at::tensor(std::vector<float>{1, 1, 1, 1, 0});
  const double first_four = loss_and_gradient(drawn_params, GatherRerenderBatch(table, row_index, four)).first;
  const double expected_four =
      loss_and_gradient({drawn_params.begin(), drawn_params.end() - 1}, MakeRerenderBatch({drawn.begin(), drawn.end() - 1}, 8))
          .first;
  EXPECT_NEAR(first_four, expected_four, 1e-5 * expected_four);
  const auto [nothing, nothing_gradient] =
      loss_and_gradient(drawn_params, GatherRerenderBatch(table, row_index, at::zeros({5}, at::kFloat)));
  EXPECT_EQ(nothing, 0);
  EXPECT_TRUE(at::isfinite(nothing_gradient).all().item<bool>());
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

// The same tile as a row of DrawRows, with a second row of zeros, which draws uniformly.
TEST(RerenderLossTest, DrawsRowsInProportionToTheirWeightsAndARowOfZerosUniformly) {
  at::Tensor weights = at::ones({2, 16}, at::kFloat);
  weights[0][6] = 100;
  weights[0][12] = 0;
  weights[1].zero_();
  std::mt19937_64 rng(5);
  const at::Tensor drawn = DrawRows(weights, 4000, rng);
  ASSERT_EQ(drawn.sizes(), (at::IntArrayRef{2, 4000}));
  EXPECT_EQ(drawn.scalar_type(), at::kLong);
  EXPECT_NEAR(drawn[0].eq(6).sum().item<double>() / 4000, 100.0 / 114, 0.02);
  EXPECT_EQ(drawn[0].eq(12).sum().item<int64_t>(), 0);
  EXPECT_TRUE(drawn.ge(0).all().item<bool>() && drawn.lt(16).all().item<bool>());
  for (int64_t column = 0; column < 16; ++column) {  // 250 expected each; the spread is 15
    EXPECT_NEAR(drawn[1].eq(column).sum().item<double>(), 250, 75) << column;
  }
  std::mt19937_64 again(5);
  EXPECT_TRUE(DrawRows(weights, 4000, again).equal(drawn));
}

}  // namespace
}  // namespace loom::fitting::internal
