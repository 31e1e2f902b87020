#pragma once
// The CNN's LibTorch side behind a torch-free interface, loaded on first use from a module that
// the build puts beside loom (libloom_cnn_torch.so: fitting/cnn/torch/torch_engine.cc). Loading LibTorch
// costs a process ~0.9 s of CPU and ~150 MB before main() runs (its operators register
// themselves), which every `loom` command paid while loom linked it: `loom --help`, a scan, a
// calibration. Now only the CNN's callers do (fitting/cnn/cnn.h and cnn_training.h forward here).
//
// The module holds its own copy of the loom code it uses (core, the model, stack pixels), its
// symbols hidden: only the entry point below is exported, so nothing in it interposes on loom's.

#include <cstdint>
#include <filesystem>
#include <vector>

#include "core/status.h"
#include "fitting/cnn/cnn.h"
#include "fitting/cnn/cnn_training.h"

namespace loom::fitting::internal {

class CnnEngine {
 public:
  virtual ~CnnEngine() = default;

  // Cnn's construction, storage and inference (fitting/cnn/cnn.h).
  virtual Result<Cnn> Create(const CnnModelInfo& info, uint64_t seed) const = 0;
  virtual Result<Cnn> Load(const std::filesystem::path& directory) const = 0;
  virtual Status Save(const Cnn& cnn, const std::filesystem::path& directory) const = 0;
  // Cnn::Widened and WithCentreSkip: `cnn` as architecture `to`, the same function.
  virtual Result<Cnn> Grown(const Cnn& cnn, const CnnArchitecture& to, uint64_t seed) const = 0;
  // Cnn::Average, the models already checked to be one network.
  virtual Result<Cnn> Averaged(const std::vector<Cnn>& models) const = 0;
  virtual Result<CnnTensor> PredictDense(const Cnn& cnn, const CnnTensor& input, int max_tile, int threads,
                                         CnnDevice device) const = 0;
  virtual Result<CnnTensor> PredictSliding(const Cnn& cnn, const CnnTensor& input, int first, int count, int batch,
                                           int threads) const = 0;

  // Training and scoring (fitting/cnn/cnn_training.h).
  virtual Status CheckTrainingDevice(CnnTrainingOptions::Device device) const = 0;
  virtual int CudaDevices() const = 0;  // the CUDA GPUs this LibTorch sees
  virtual CnnTensor WithRadianceNoise(const CnnTensor& input, double relative_sigma, uint64_t seed) const = 0;
  virtual Result<CnnScore> Score(const Cnn& cnn, const std::vector<CnnExample>& examples, int threads) const = 0;
  virtual Result<std::vector<CnnEpoch>> Train(Cnn& cnn, const CnnExampleSource& train, const std::vector<CnnExample>& validation,
                                              const CnnTrainingOptions& options) const = 0;
};

// The module's one exported symbol: a C function returning its engine, which lives as long as
// the process (the module is never unloaded). The suffix changes whenever CnnEngine does, so
// that a module built from other sources is refused rather than called.
inline constexpr const char* kCnnEngineEntry = "loom_cnn_engine_v5";
using CnnEngineEntry = const CnnEngine* (*)();

// Loads `module` and returns its engine; an error names the module and says what went wrong.
Result<const CnnEngine*> LoadCnnEngine(const std::filesystem::path& module);

// The module built with this loom (its path is fixed when loom is built), loaded by the first
// call in a process; later calls return the same engine, or the same error.
Result<const CnnEngine*> BuiltCnnEngine();

}  // namespace loom::fitting::internal
