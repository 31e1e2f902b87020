#pragma once
// The CNN's label loss (Merzbach et al. 2019, §"Loss"): a Huber distance per label channel
// (fitting/model/label.h), weighted per channel as the paper weighs them, and optionally per
// pixel for the shading normal by how narrow the true lobe is; and the label's σ decoded in torch
// ops, which the re-rendering loss renders with. Included by fitting/cnn/torch/cnn_trainer.cc, rerender_loss.cc
// and their tests only (ATen, not all of torch).

#include <ATen/ATen.h>

namespace loom::fitting::internal {

// σ from its label encoding (fitting/model/label.h's DecodeSigma): 0.01 (101^σ' − 1), σ' ≥ 0, σ ≥ kSigmaFloor.
at::Tensor DecodeSigma(const at::Tensor& encoded);

// The paper's weights of the 14 label channels (a_d 20, a_s 10, every other 1), the anisotropy
// angle's (cos 2α, sin 2α) times `alpha_weight`: 1 × 14 × 1 × 1.
at::Tensor LabelChannelWeights(double alpha_weight = 1);

// How narrow each pixel's true lobe is against `reference` (rad): (reference / σ_min)², clamped
// to [1, kMaxNormalLobeWeight], σ_min the narrower of the pixel's lobe widths (decoded from
// `labels`' σx', σy'; N × 14 × H × W): N × 1 × H × W. A normal's error moves the highlight by
// that angle, which costs the re-rendering as much as it is wide against the lobe: on the
// glossiest fabrics the CNN's normals err by a lobe width (configs/models/tac7-mini/HISTORY.md).
inline constexpr double kMaxNormalLobeWeight = 100;  // so that the narrowest pixels cannot drown the batch
at::Tensor LobeNarrowness(const at::Tensor& labels, double reference);

// `channel_weights` with the shading normal's channels (n_s, 6..8) of each pixel multiplied by
// its LobeNarrowness: lobes wider than `reference` keep the paper's weight; `reference` 0
// returns `channel_weights` as they are.
at::Tensor NormalLobeWeights(const at::Tensor& channel_weights, const at::Tensor& labels, double reference);

// Where each pixel's true lobe is anisotropic: valid (`valid`: N × 1 × H × W of 0/1) and its wider
// lobe width at least `min_ratio` times its narrower one (decoded from `labels`' σx', σy'). Of a
// round lobe α is arbitrary (the simulator writes 0 there), so no fit can find it in the data.
at::Tensor AnisotropicPixels(const at::Tensor& labels, const at::Tensor& valid, double min_ratio);

// The weighted Huber (δ = 1) of `predicted` against `target` (N × 14 × H × W), summed over the
// valid pixels (`valid`: N × 1 × H × W of 0/1). `weights` broadcast against the labels.
at::Tensor HuberSum(const at::Tensor& predicted, const at::Tensor& target, const at::Tensor& valid, const at::Tensor& weights);

}  // namespace loom::fitting::internal
