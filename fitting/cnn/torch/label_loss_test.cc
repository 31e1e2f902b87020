#include "fitting/cnn/torch/label_loss.h"

#include <gtest/gtest.h>

#include "fitting/model/label.h"

namespace loom::fitting::internal {
namespace {

// Labels of three pixels (1 × 14 × 1 × 3) whose narrower lobes are `sigma_min`, the other 0.3.
at::Tensor LabelsWithLobes(const std::array<double, 3>& sigma_min) {
  at::Tensor labels = at::full({1, kLabelSize, 1, 3}, 0.5, at::kFloat);
  for (int x = 0; x < 3; ++x) {
    labels[0][9][0][x] = static_cast<float>(EncodeSigma(0.3));
    labels[0][10][0][x] = static_cast<float>(EncodeSigma(sigma_min[x]));
  }
  return labels;
}

TEST(LabelLossTest, ChannelWeightsAreThePapersWithTheAngleScaled) {
  const at::Tensor w = LabelChannelWeights(4).flatten();
  for (int c = 0; c < kLabelSize; ++c) {
    const float expected = c < 3 ? 20 : c < 6 ? 10 : (c == 11 || c == 12) ? 4 : 1;
    EXPECT_FLOAT_EQ(w[c].item<float>(), expected) << "channel " << c;
  }
}

TEST(LabelLossTest, OnlyValidPixelsWithALobeWiderOneWayThanTheOtherHaveAnAngle) {
  // σ_min 0.3 (round), 0.25 (1.2:1), 0.2 (1.5:1, the threshold), 0.1 (3:1, but off the material).
  at::Tensor labels = at::full({1, kLabelSize, 1, 4}, 0.5, at::kFloat);
  const std::array<double, 4> sigma_min = {0.3, 0.25, 0.2, 0.1};
  for (int x = 0; x < 4; ++x) {
    labels[0][9][0][x] = static_cast<float>(EncodeSigma(sigma_min[x]));  // the narrower either way round
    labels[0][10][0][x] = static_cast<float>(EncodeSigma(0.3));
  }
  at::Tensor valid = at::ones({1, 1, 1, 4}, at::kFloat);
  valid[0][0][0][3] = 0;
  const at::Tensor anisotropic = AnisotropicPixels(labels, valid, 1.5).flatten();
  const float expected[4] = {0, 0, 1, 0};
  for (int x = 0; x < 4; ++x) EXPECT_EQ(anisotropic[x].item<float>(), expected[x]) << "pixel " << x;
  // The same lobes with σx and σy swapped.
  const at::Tensor swapped =
      AnisotropicPixels(labels.index_select(1, at::tensor({0, 1, 2, 3, 4, 5, 6, 7, 8, 10, 9, 11, 12, 13})), valid, 1.5).flatten();
  for (int x = 0; x < 4; ++x) EXPECT_EQ(swapped[x].item<float>(), expected[x]) << "pixel " << x;
}

TEST(LabelLossTest, NarrowLobesWeighTheirNormalsByTheSquaredWidthRatioUpToTheCap) {
  const at::Tensor channels = LabelChannelWeights();
  const at::Tensor labels = LabelsWithLobes({0.02, 0.2, 0.0005});
  const at::Tensor w = NormalLobeWeights(channels, labels, 0.1);
  ASSERT_EQ(w.sizes(), labels.sizes());
  const float expected_normal[3] = {25, 1, static_cast<float>(kMaxNormalLobeWeight)};  // (0.1/0.02)², wide, capped
  for (int x = 0; x < 3; ++x) {
    for (int c = 0; c < kLabelSize; ++c) {
      const bool normal = c >= 6 && c <= 8;
      const float expected = normal ? expected_normal[x] : channels[0][c][0][0].item<float>();
      EXPECT_NEAR(w[0][c][0][x].item<float>(), expected, 1e-3 * expected) << "pixel " << x << " channel " << c;
    }
  }
}

TEST(LabelLossTest, ZeroReferenceLeavesThePapersWeights) {
  const at::Tensor channels = LabelChannelWeights(2);
  EXPECT_TRUE(at::equal(NormalLobeWeights(channels, LabelsWithLobes({0.01, 0.01, 0.01}), 0), channels));
}

TEST(LabelLossTest, HuberSumWeighsEachChannelAndSkipsInvalidPixels) {
  at::Tensor target = at::zeros({1, kLabelSize, 1, 2}, at::kFloat);
  at::Tensor predicted = target.clone();
  predicted[0][0][0][0] = 0.5;   // quadratic: 0.5 · 0.5² = 0.125, a_d's weight 20
  predicted[0][13][0][0] = 3;    // linear: 3 − 0.5 = 2.5, F0's weight 1
  predicted[0][13][0][1] = 100;  // an invalid pixel: not counted
  const at::Tensor valid = at::tensor({1.0f, 0.0f}).reshape({1, 1, 1, 2});
  EXPECT_NEAR(HuberSum(predicted, target, valid, LabelChannelWeights()).item<double>(), 20 * 0.125 + 2.5, 1e-6);
}

}  // namespace
}  // namespace loom::fitting::internal
