#pragma once
// The CNN's training and scoring with LibTorch, as fitting/cnn_training.h describes them: the
// CNN engine's side of it (internal/cnn_engine.h). Torch-free itself; its .cc includes torch.

#include <cstdint>
#include <vector>

#include "core/status.h"
#include "fitting/cnn.h"
#include "fitting/cnn_training.h"

namespace loom::fitting::internal {

Status CheckTorchDevice(CnnTrainingOptions::Device device);
CnnTensor NoisyInput(const CnnTensor& input, double relative_sigma, uint64_t seed);
Result<CnnScore> ScoreCnnLabels(const Cnn& cnn, const std::vector<CnnExample>& examples, int threads);
Result<std::vector<CnnEpoch>> TrainCnnNet(Cnn& cnn, const CnnExampleSource& train, const std::vector<CnnExample>& validation,
                                          const CnnTrainingOptions& options);

}  // namespace loom::fitting::internal
