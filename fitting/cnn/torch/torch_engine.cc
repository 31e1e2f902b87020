// The CNN engine (fitting/cnn/internal/cnn_engine.h) of the module libloom_cnn_torch.so: LibTorch's side of
// fitting/cnn/cnn.h and fitting/cnn/cnn_training.h, exported as the module's one symbol.

#include "fitting/cnn/internal/cnn_engine.h"
#include "fitting/cnn/torch/torch_cnn.h"

#include <torch/cuda.h>

namespace loom::fitting::internal {
namespace {

class TorchCnnEngine final : public CnnEngine {
 public:
  Result<Cnn> Create(const CnnModelInfo& info, uint64_t seed) const override { return CreateCnn(info, seed); }
  Result<Cnn> Load(const std::filesystem::path& directory) const override { return LoadCnn(directory); }
  Status Save(const Cnn& cnn, const std::filesystem::path& directory) const override { return SaveCnn(cnn, directory); }
  Result<Cnn> Grown(const Cnn& cnn, const CnnArchitecture& to, uint64_t seed) const override { return GrowCnn(cnn, to, seed); }
  Result<Cnn> Averaged(const std::vector<Cnn>& models) const override { return AverageCnns(models); }
  Result<CnnTensor> PredictDense(const Cnn& cnn, const CnnTensor& input, int max_tile, int threads,
                                 CnnDevice device) const override {
    return PredictDenseLabels(cnn, input, max_tile, threads, device);
  }
  Result<CnnTensor> PredictSliding(const Cnn& cnn, const CnnTensor& input, int first, int count, int batch,
                                   int threads) const override {
    return PredictSlidingLabels(cnn, input, first, count, batch, threads);
  }
  Status CheckTrainingDevice(CnnTrainingOptions::Device device) const override { return CheckTorchDevice(device); }
  int CudaDevices() const override { return static_cast<int>(torch::cuda::device_count()); }
  CnnTensor WithRadianceNoise(const CnnTensor& input, double relative_sigma, uint64_t seed) const override {
    return NoisyInput(input, relative_sigma, seed);
  }
  Result<CnnScore> Score(const Cnn& cnn, const std::vector<CnnExample>& examples, int threads) const override {
    return ScoreCnnLabels(cnn, examples, threads);
  }
  Result<std::vector<CnnEpoch>> Train(Cnn& cnn, const CnnExampleSource& train, const std::vector<CnnExample>& validation,
                                      const CnnTrainingOptions& options) const override {
    return TrainCnnNet(cnn, train, validation, options);
  }
};

}  // namespace
}  // namespace loom::fitting::internal

// The entry point internal::kCnnEngineEntry names.
extern "C" __attribute__((visibility("default"))) const loom::fitting::internal::CnnEngine* loom_cnn_engine_v5() {
  static const loom::fitting::internal::TorchCnnEngine engine;
  return &engine;
}
