#pragma once
// The paper's CNN (Merzbach et al. 2019): a 15 × 15 patch of a stack around a pixel → the
// pixel's 14-d label (fitting/model/label.h). LibTorch behind this torch-free interface, loaded
// by the first call that needs it (internal/cnn_engine.h), so that no other code pays for it.
//
// | layer | kind                          | output (patch form)   | paper widths | width_divisor 8 |
// |-------|-------------------------------|-----------------------|--------------|-----------------|
// | conv1 | 1 × 1                         | 15 × 15 × w1          | 512          | 64              |
// | conv2 | 1 × 1                         | 15 × 15 × w2          | 256          | 32              |
// | conv3 | 3 × 3, stride 2               | 7 × 7 × w3            | 512          | 64              |
// | conv4 | 3 × 3, stride 2               | 3 × 3 × w4            | 1024         | 128             |
// | fc    | fully connected 9·w4 → 14     | 14                    |              |                 |
// LeakyReLU (0.01) after every convolution, no batch normalisation (it would lose the input's
// absolute intensity, which the albedos need), dropout before fc (training only). Optionally
// (CnnArchitecture::centre_skip, not the paper's) a 1 × 1 readout w2 → 14 of conv2's features
// at the patch's centre pixel, added to fc's output.
//
// Two evaluations of the same weights:
//  - sliding window: one patch per output pixel, as the paper infers (475 MFLOP per pixel at
//    the paper's size; kept for the equivalence test and the benchmark);
//  - dense: fully convolutional over a whole tile — conv3 and conv4 at stride 1 with dilation
//    1 and 2, fc as a 3 × 3 convolution with dilation 4 — which computes every pixel's patch
//    output while sharing the 1 × 1 layers between overlapping patches (~36× less work).
// Both see the input padded by kPatchHalo pixels of edge replication, so every pixel has an
// output; pixels within the halo of the edge see replicated neighbours.
//
// Input features (CnnInputFromStack): height above the stack's median (mm), the geometric
// normal (3), then log(1 + L / radiance_scale) of every observation (unseen = 0). The stack's
// x and y positions are left out: they say where on the holder a pixel is, which a stationary
// material's reflectance does not depend on. So a stack of N observations needs
// input_channels = 4 + N (the paper's 934-channel input had x, y, z). A model may instead take
// the paper's layout (cnn_input.h): the same channels for every gloss preset of its rig.
// Thread safety: a Cnn is not shared between threads (torch's own pool parallelises each call).

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/observation_stack.h"
#include "core/status.h"
#include "fitting/cnn/cnn_input.h"

namespace loom::fitting {

inline constexpr int kPatchSize = 15;
inline constexpr int kPatchHalo = 7;    // (kPatchSize − 1) / 2
inline constexpr int kDenseTile = 256;  // Cnn::PredictDense's largest tile side

// Where the network runs: the CPU, or the first CUDA GPU (a build against a CUDA LibTorch:
// docs/gpu-training.md; Debian's is CPU-only, and asking for cuda there is an error saying so).
enum class CnnDevice { kCpu, kCuda };
// Whether the network can run on `device` here: an error saying why not (no GPU, or a CPU-only LibTorch).
Status CheckCnnDevice(CnnDevice device);

struct CnnArchitecture {
  int input_channels = 934;  // the paper's; 4 + observations for a loom stack
  int width_divisor = 1;     // divides the hidden widths 512, 256, 512, 1024 (1: the paper's)
  double dropout = 0.02;     // before fc, training only (the paper's text; its figure says 0.1)
  // loom's, not the paper's: a linear readout of conv2's features at the patch's centre pixel
  // added to fc's output, a short path from the pixel's own observations to its label (the
  // paper's path to them runs through two 3 × 3 stride-2 layers shared with its neighbours).
  bool centre_skip = false;

  std::array<int, 4> HiddenWidths() const;
  // Multiply-adds per output pixel, ×2 = FLOPs: sliding window (each patch on its own) and dense.
  double SlidingFlopsPerPixel() const;
  double DenseFlopsPerPixel() const;
  int64_t WeightCount() const;  // weights and biases
  Status Check() const;         // every problem, naming the field
};

// How weights.pt stores a model's weights. float16 halves the file, for a model that lives in
// git; the network computes in float32 either way.
enum class WeightStorage { kFloat32, kFloat16 };
const char* WeightStorageName(WeightStorage storage);  // "float32", "float16"
std::optional<WeightStorage> WeightStorageFromName(const std::string& name);

// What a trained model expects of its input and how it was made: written next to its weights.
struct CnnModelInfo {
  CnnArchitecture architecture;
  double radiance_scale = 1;                         // L ↦ log(1 + L / radiance_scale)
  std::string rig;                                   // the stacks' rig, e.g. "tac7-mini"
  std::vector<ObservationGroup> observation_groups;  // the stack layout it was trained on
  // With a paper layout (cnn_input.h) the model takes every preset's stacks of its rig through
  // it; without, exactly the stacks of `observation_groups`.
  std::optional<PaperInputLayout> paper_layout;
  std::string training;  // free text: data, epochs, validation errors
  // Save writes the weights so; Load checks weights.pt against it. Training keeps float32.
  WeightStorage weights = WeightStorage::kFloat32;
};

// The network input of a stack under `info`'s layout (its paper layout, or else the stack's own
// observations); an error naming the stack's source when its observations are not the ones the
// model was trained on. Defined in cnn_input.cc.
Result<CnnTensor> CnnInputFromStack(const ObservationStack& stack, const CnnModelInfo& info);

// Whether models `a` and `b` read the same stacks the same way: rig, input channels, observation
// groups and paper layout (a fine-tune's start and its dataset must agree on these).
bool SameInputLayout(const CnnModelInfo& a, const CnnModelInfo& b);

// OK when `a` and `b` describe one network on one input (architecture, rig, input layout and
// radiance scale), so that their weights can be averaged; else an error saying what differs.
Status CheckSameNetwork(const CnnModelInfo& a, const CnnModelInfo& b);

// Whether a model of architecture `from` can be grown into `to` (training's --init): only wider
// (a width divisor that divides `from`'s) and a centre skip added; the input and dropout stay.
Status CheckGrowable(const CnnArchitecture& from, const CnnArchitecture& to);

// The 14 label channels of SVBRDF maps (fitting/model/svbrdf_maps.h layout) and, per pixel,
// whether it holds a material (a zero normal marks a pixel off the sample).
struct CnnLabels {
  CnnTensor labels;
  std::vector<uint8_t> valid;
};
CnnLabels CnnLabelsFromMaps(const Image& maps);

// SVBRDF maps (13 channels, no height) from a 14 × H × W label tensor, decoded by DecodeLabel.
Image MapsFromLabels(const CnnTensor& labels);

namespace internal {
struct CnnNetHolder;  // the torch module (fitting/cnn/torch/cnn_net.h)
}

class Cnn {
 public:
  // Random weights (torch's default initialisation, seeded).
  static Result<Cnn> Create(const CnnModelInfo& info, uint64_t seed);
  // A model directory: model.json (CnnModelInfo) + weights.pt. Errors name the file.
  static Result<Cnn> Load(const std::filesystem::path& directory);
  Status Save(const std::filesystem::path& directory) const;

  // This model at a wider `width_divisor` (one that divides its own) computing the same function:
  // each hidden unit copied into the new ones, and each copy's share of its outgoing weights
  // drawn at random (seeded) so that training tells the copies apart (Net2WiderNet, Chen et
  // al. 2016). For fine-tuning a wider network from a trained narrow one.
  Result<Cnn> Widened(int width_divisor, uint64_t seed) const;
  // This model with CnnArchitecture::centre_skip added, its weights zero: the same function,
  // for fine-tuning with the skip from a model trained without it.
  Result<Cnn> WithCentreSkip() const;
  // The uniform average of `models`' weights: models of one network and input (CheckSameNetwork),
  // e.g. the last epochs of one run or fine-tunes of one start, whose average often predicts
  // better than each (Izmailov et al. 2018, Wortsman et al. 2022). The first's info describes it.
  static Result<Cnn> Average(const std::vector<Cnn>& models);

  const CnnModelInfo& info() const { return info_; }
  CnnModelInfo& mutable_info() { return info_; }

  // Labels (14 × H × W) of every pixel of `input` (C × H × W), dense, in equal tiles of at most
  // `max_tile` × `max_tile` output pixels (+ halo), `threads` torch threads (0: one per core).
  // Larger tiles recompute less halo (630² in 3 × 3 tiles of 210: 6 % more work than one tile;
  // in 5 × 5 of 126: 12 %); a 630² paper-size input peaks at about 5 GB (bench/cnn_bench.cc).
  // Prediction and training put torch's large tensors on huge pages and set the process's
  // malloc to keep freed memory for reuse (fitting/cnn/torch/cnn_net.h: SetUpTensorMemory says why).
  // On `device` cuda the tiles run one after another on the GPU, on a copy of the weights there.
  Result<CnnTensor> PredictDense(const CnnTensor& input, int max_tile = kDenseTile, int threads = 0,
                                 CnnDevice device = CnnDevice::kCpu) const;
  // The same outputs the sliding-window way, for pixels [first, first + count) in row-major
  // order (14 × count, as a 14 × 1 × count tensor), `batch` patches per forward pass.
  Result<CnnTensor> PredictSliding(const CnnTensor& input, int first, int count, int batch = 256, int threads = 0) const;

  // SVBRDF maps of a whole stack (fitting/model/svbrdf_maps.h layout with the stack's height): input, dense
  // prediction, decoded labels.
  Result<Image> PredictMaps(const ObservationStack& stack, int threads = 0, CnnDevice device = CnnDevice::kCpu) const;

  // The torch module, for the CNN engine's code (internal/cnn_engine.h), which makes every Cnn.
  Cnn(CnnModelInfo info, std::shared_ptr<internal::CnnNetHolder> net);
  internal::CnnNetHolder& net() const { return *net_; }

 private:
  CnnModelInfo info_;
  std::shared_ptr<internal::CnnNetHolder> net_;
};

}  // namespace loom::fitting
