#include "fitting/cnn/torch/label_loss.h"

#include <array>

#include "fitting/model/label.h"

namespace loom::fitting::internal {

namespace {

constexpr int kNormalChannel = 6;  // n_s: 6..8
constexpr int kSigmaChannel = 9;   // σx', σy': 9, 10

}  // namespace

at::Tensor DecodeSigma(const at::Tensor& encoded) {
  return at::clamp_min(0.01 * (at::pow(101.0, at::clamp_min(encoded, 0.0)) - 1.0), kSigmaFloor);
}

at::Tensor LabelChannelWeights(double alpha_weight) {
  std::array<float, kLabelSize> w;
  w.fill(1);
  for (int c = 0; c < 3; ++c) w[c] = 20, w[3 + c] = 10;  // the paper's w(a_d), w(a_s)
  w[11] = w[12] = static_cast<float>(alpha_weight);      // cos 2α, sin 2α
  return at::from_blob(w.data(), {1, kLabelSize, 1, 1}, at::kFloat).clone();
}

at::Tensor LobeNarrowness(const at::Tensor& labels, double reference) {
  // The narrower of the two widths (σ' grows with σ).
  const at::Tensor sigma = DecodeSigma(std::get<0>(labels.narrow(1, kSigmaChannel, 2).min(1, /*keepdim=*/true)));
  return at::clamp(at::pow(reference / sigma, 2), 1.0, kMaxNormalLobeWeight);
}

at::Tensor NormalLobeWeights(const at::Tensor& channel_weights, const at::Tensor& labels, double reference) {
  if (reference <= 0) return channel_weights;
  const at::Tensor normal_weight = LobeNarrowness(labels, reference);  // N × 1 × H × W
  at::Tensor is_normal = at::zeros({1, kLabelSize, 1, 1}, labels.options());
  is_normal.narrow(1, kNormalChannel, 3).fill_(1);
  return channel_weights.to(labels.device()) * (1 + is_normal * (normal_weight - 1));
}

at::Tensor AnisotropicPixels(const at::Tensor& labels, const at::Tensor& valid, double min_ratio) {
  const at::Tensor sigma = DecodeSigma(labels.narrow(1, kSigmaChannel, 2));
  const at::Tensor wider = std::get<0>(sigma.max(1, /*keepdim=*/true)), narrower = std::get<0>(sigma.min(1, /*keepdim=*/true));
  return valid * (wider >= min_ratio * narrower).to(valid.scalar_type());
}

at::Tensor HuberSum(const at::Tensor& predicted, const at::Tensor& target, const at::Tensor& valid, const at::Tensor& weights) {
  const at::Tensor loss = at::huber_loss(predicted, target, at::Reduction::None, /*delta=*/1.0);
  return (loss * weights.to(predicted.device()) * valid).sum();
}

}  // namespace loom::fitting::internal
