#pragma once
// What the CNN engine (fitting/cnn/internal/cnn_engine.h) does, implemented with LibTorch: Cnn's members that
// need it (cnn_net.cc) and the training and scoring (cnn_trainer.cc), as fitting/cnn/cnn.h and
// fitting/cnn/cnn_training.h describe them. Torch-free itself, so that the engine's own file is cheap.

#include <cstdint>
#include <filesystem>
#include <vector>

#include "core/status.h"
#include "fitting/cnn/cnn.h"
#include "fitting/cnn/cnn_training.h"

namespace loom::fitting::internal {

Result<Cnn> CreateCnn(const CnnModelInfo& info, uint64_t seed);
Result<Cnn> LoadCnn(const std::filesystem::path& directory);
Status SaveCnn(const Cnn& cnn, const std::filesystem::path& directory);
// `from` as architecture `to`, computing the same function: wider (Net2WiderNet, Cnn::Widened)
// and with the centre skip added as zeros; an error for any other change.
Result<Cnn> GrowCnn(const Cnn& from, const CnnArchitecture& to, uint64_t seed);
// The uniform average of the models' weights (Cnn::Average; one network, checked by the caller).
Result<Cnn> AverageCnns(const std::vector<Cnn>& models);
Result<CnnTensor> PredictDenseLabels(const Cnn& cnn, const CnnTensor& input, int max_tile, int threads,
                                     CnnDevice device = CnnDevice::kCpu);
Result<CnnTensor> PredictSlidingLabels(const Cnn& cnn, const CnnTensor& input, int first, int count, int batch, int threads);

Status CheckTorchDevice(CnnTrainingOptions::Device device);
CnnTensor NoisyInput(const CnnTensor& input, double relative_sigma, uint64_t seed);
Result<CnnScore> ScoreCnnLabels(const Cnn& cnn, const std::vector<CnnExample>& examples, int threads);
Result<std::vector<CnnEpoch>> TrainCnnNet(Cnn& cnn, const CnnExampleSource& train, const std::vector<CnnExample>& validation,
                                          const CnnTrainingOptions& options);

}  // namespace loom::fitting::internal
