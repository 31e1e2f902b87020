#pragma once
// The torch module behind fitting/cnn.h (layer table there). Included by cnn_net.cc and
// cnn_trainer.cc only: <torch/torch.h> costs ~16 s and ~1 GB per translation unit.
#include <torch/torch.h>

#include "fitting/cnn.h"

namespace loom::fitting::internal {

inline constexpr double kLeakySlope = 0.01;

class CnnNetImpl : public torch::nn::Module {
 public:
  explicit CnnNetImpl(const CnnArchitecture& architecture);

  // N × C × 15 × 15 patches → N × 14.
  torch::Tensor ForwardPatches(const torch::Tensor& patches);
  // N × C × (H + 14) × (W + 14) → N × 14 × H × W: the same weights, fully convolutional.
  torch::Tensor ForwardDense(const torch::Tensor& input);

  // The layers, for Cnn::Widened.
  const torch::nn::Conv2d& conv1() const { return conv1_; }
  const torch::nn::Conv2d& conv2() const { return conv2_; }
  const torch::nn::Conv2d& conv3() const { return conv3_; }
  const torch::nn::Conv2d& conv4() const { return conv4_; }
  const torch::nn::Linear& fc() const { return fc_; }

 private:
  torch::Tensor Leaky(const torch::Tensor& x) const;

  torch::nn::Conv2d conv1_{nullptr}, conv2_{nullptr}, conv3_{nullptr}, conv4_{nullptr};
  torch::nn::Linear fc_{nullptr};
  torch::nn::Dropout dropout_{nullptr};
  int width4_ = 0;
};
TORCH_MODULE(CnnNet);

struct CnnNetHolder {
  CnnNet net;
};

// Sets glibc's malloc, once per process, to keep freed memory for reuse instead of returning it
// to the system. torch frees and re-allocates its activations (~100 MB each at the paper's
// widths) at every layer; glibc serves blocks that large from fresh mmaps, and their first-touch
// page faults cost this machine more than the convolutions (a 630² paper-size inference: 50 s →
// 23 s, bench/cnn_bench.cc, 2026-11-22, in the main thread's CPU time). The price: the process
// keeps its peak heap until it exits. In wall time (2026-11-28, three runs each) the 630²
// inference took 55.7–63.0 s with it and 55.6–57.5 s without, ~36–42 s of system time either
// way: no gain measurable now (docs/benchmarks.md, "The paper's CNN").
void KeepFreedMemoryForReuse();

// Input C × H × W (the CnnTensor) as a 1 × C × (H + 14) × (W + 14) tensor, edge-replicated.
torch::Tensor PaddedInput(const CnnTensor& input);

}  // namespace loom::fitting::internal
