#pragma once
// The torch module behind fitting/cnn/cnn.h (layer table there). Included by cnn_net.cc and
// cnn_trainer.cc only: <torch/torch.h> costs ~16 s and ~1 GB per translation unit.
#include <torch/torch.h>

#include "fitting/cnn/cnn.h"

namespace loom::fitting::internal {

// A LibTorch exception's message without the C++ backtrace c10::Error appends to what(): that
// goes to the debug log, the message to the user.
std::string TorchErrorMessage(const std::exception& error);

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
  const torch::nn::Linear& skip() const { return skip_; }  // null without CnnArchitecture::centre_skip

 private:
  torch::Tensor Leaky(const torch::Tensor& x) const;

  torch::nn::Conv2d conv1_{nullptr}, conv2_{nullptr}, conv3_{nullptr}, conv4_{nullptr};
  torch::nn::Linear fc_{nullptr};
  torch::nn::Linear skip_{nullptr};
  torch::nn::Dropout dropout_{nullptr};
  int width4_ = 0;
};
TORCH_MODULE(CnnNet);

struct CnnNetHolder {
  CnnNet net;
};

// Sets, once per process, how torch's CPU tensors get their memory: blocks of 2 MiB or more on
// transparent huge pages (2 MiB-aligned and madvised; Debian's kernel gives them on madvise),
// and glibc's malloc keeping freed memory for reuse instead of returning it to the system.
// torch frees and re-allocates its activations (~100 MB each at the paper's widths) at every
// layer, and on 4 KiB pages their first-touch page faults cost this machine about as much as
// the convolutions: a 630² paper-size dense inference (bench/cnn_bench.cc) took
// 52.5 s with 33 s of system time; with huge pages (glibc's malloc.hugetlb tunable, the same
// advice for all of malloc) 27.6 s. Keeping freed memory alone gained nothing measurable in wall
// time (docs/benchmarks.md, "The paper's CNN"). The price: the process keeps its peak heap.
void SetUpTensorMemory();

// Input C × H × W (the CnnTensor) as a 1 × C × (H + 14) × (W + 14) tensor, edge-replicated
// (patch_windows.h's EdgePadded).
torch::Tensor PaddedInput(const CnnTensor& input);

}  // namespace loom::fitting::internal
