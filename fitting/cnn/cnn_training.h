#pragma once
// Training the CNN (fitting/cnn/cnn.h) on materials with known parameters — simulated stacks with
// their ground truth, or reconstructed stacks with a reference fit.
//
// Training is on dense tiles: the dense form computes each output pixel from its own 15 × 15
// neighbourhood only, so a tile of T × T outputs is T² patch samples for the price of one
// forward pass over (T + 14)². Loss: the paper's Huber (δ = 1) on the 14-d label with weights
// 20 on a_d and 10 on a_s, averaged over the valid pixels (those on the material), plus
// optionally a re-rendering loss (rerender_weight, below). Adam with
// weight decay; the learning rate decays exponentially from `learning_rate_start` at the first
// epoch to `learning_rate_end` at the last (the paper: 1e-5 → 1e-6). Dropout acts on the dense
// feature maps, so one dropped activation reaches the neighbouring outputs of its tile too.
//
// Determinism: an epoch's tiles and dropout masks come from (seed, epoch), so training that is
// interrupted and resumed from its checkpoint takes the same steps as one that is not (with
// the same thread count).

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/observation_stack.h"
#include "fitting/cnn/cnn.h"

namespace loom::fitting {

struct CnnExample {
  std::string name;  // for messages: the stack it came from
  CnnTensor input;   // CnnInputFromStack
  CnnLabels labels;  // CnnLabelsFromMaps of its reference maps, same height and width
  // The stack itself, for the re-rendering loss (CnnTrainingOptions::rerender_weight); may be
  // null otherwise.
  std::shared_ptr<const ObservationStack> stack;
};

// Training examples read on demand, for datasets larger than memory: `count` of them,
// `load(i)` reads example i (0 ≤ i < count; called again for the same i in later epochs).
struct CnnExampleSource {
  int count = 0;
  std::function<Result<CnnExample>(int index)> load;
};

struct CnnTrainingProgress {
  int epoch = 0;  // 1-based
  int epochs = 0;
  int step = 0;  // within the epoch, 1-based
  int steps = 0;
  double loss = 0;  // the epoch's running mean
};

struct CnnTrainingOptions {
  int epochs = 30;
  int tile = 32;            // output pixels per tile side (T² patch samples)
  int tiles_per_step = 4;   // tiles in one Adam step
  int steps_per_epoch = 0;  // 0: one tile's worth of steps per T² valid pixels of training data
  // The paper's 1e-5 → 1e-6 is for 768,000 steps of batch 64; loom's datasets train in thousands.
  double learning_rate_start = 1e-3;  // at the first epoch
  double learning_rate_end = 1e-4;    // at the last
  double weight_decay = 5e-4;
  // Training tiles' observations are multiplied by 1 + radiance_noise · N(0, 1), drawn anew
  // each step, so that the network sees inputs as noisy as reconstructed stacks and not only
  // the simulator's exact ones. 0: none. (For tac7-mini, 0.07 made no better model:
  // configs/models/tac7-mini/HISTORY.md.)
  double radiance_noise = 0;
  // The re-rendering loss (fitting/cnn/torch/rerender_loss.h), added to the label loss with this weight
  // (0: off; every training example then needs its stack). Per tile, `rerender_pixels` random
  // valid pixels are rendered from the predicted labels under their own observations (cast
  // shadows left out, a strip's emitters merged into `rerender_strip_samples`) and compared
  // with the stack's radiance: Huber with δ = `rerender_huber` on the residual relative to the
  // pixel's mean, the fitters' residual.
  double rerender_weight = 0;
  // Weight of the (cos 2α, sin 2α) channels in the training's label loss: the paper's is 1, as
  // for every channel but the albedos (a_d 20, a_s 10). The validation and test losses keep the
  // paper's weights, so that runs with different weights compare.
  double alpha_weight = 1;
  // > 0: the shading normal's channels in the training's label loss weighted by
  // (normal_lobe_reference / σ_min)², between 1 and 100, σ_min the narrower of the pixel's true
  // lobe widths (fitting/cnn/torch/label_loss.h): an error in n_s costs as much as it is wide against
  // the lobe. 0: the paper's weight. The validation and test losses keep the paper's weights.
  double normal_lobe_reference = 0;
  int rerender_pixels = 16;
  // > 0: the re-rendering loss's pixels drawn with probability ∝ (rerender_lobe_reference /
  // σ_min)², between 1 and 100 (the normal's lobe weight above), instead of uniformly among a
  // tile's valid pixels: the glossy pixels, whose normals the CNN misses by a lobe width, are
  // rendered more often. 0: uniformly.
  double rerender_lobe_reference = 0;
  int rerender_strip_samples = 8;
  double rerender_huber = 0.1;
  // Training materials in memory at once (0: all, loaded once). Fewer: each epoch goes through
  // the training set in a random order (from seed and epoch) that many at a time, its steps
  // shared out among those windows by size, tiles drawn from the window's materials; needs
  // steps_per_epoch.
  int resident_materials = 0;
  int threads = 0;  // torch threads; 0: one per core
  // Where the network trains: the CPU, or the first CUDA GPU (a LibTorch built with CUDA and a
  // GPU needed; TrainCnn says so otherwise). The materials live on that device for the whole
  // run; validation and the saved weights are on the CPU, so that any build reads them.
  using Device = CnnDevice;
  Device device = Device::kCpu;
  uint64_t seed = 1;
  // Empty: no checkpoints. Else after every epoch DIR/last/: model/ (the weights so far,
  // loadable by Cnn::Load), optimizer.pt and history.json, replaced whole; and DIR/best/, the
  // model of the epoch with the lowest validation objective so far (CnnEpoch).
  std::filesystem::path checkpoint_dir;
  bool resume = false;                                       // continue after the last epoch in checkpoint_dir
  std::function<void(const CnnTrainingProgress&)> progress;  // after every step
  Status Check() const;                                      // every problem, naming the field
  nlohmann::json ToJson() const;                             // the settings (not the callbacks or paths)
};

// Whether `device` can train here: an error saying why not (no GPU, or a CPU-only LibTorch).
Status CheckTrainingDevice(CnnTrainingOptions::Device device);
// The CUDA GPUs the CNN's LibTorch sees (0 with Debian's CPU-only one).
Result<int> CudaDevices();

// The label's 14 channels in order, for reports: a_d.R … F0.
extern const std::array<const char*, 14> kLabelChannelNames;

struct CnnEpoch {
  int epoch = 0;
  double learning_rate = 0;
  double train_loss = 0;           // mean over the epoch's steps (label + weighted re-rendering loss)
  double train_rerender_loss = 0;  // the re-rendering loss alone, unweighted (0 when off)
  double validation_loss = 0;      // label loss over every valid pixel of the validation materials
  // With the re-rendering loss: its value (unweighted) on 512 valid pixels of each validation
  // material, drawn once for the run (uniformly, not by lobe width; CnnScore::rerender_loss); 0 when off.
  double validation_rerender_loss = 0;
  // What the run keeps the epoch with the lowest of: validation_loss + rerender_weight ·
  // validation_rerender_loss, the training's objective on the validation materials (the label
  // loss alone when the re-rendering loss is off). With that loss on, the label loss alone had
  // stopped tracking the re-rendering (configs/models/tac7/HISTORY.md). A checkpoint written
  // before this field existed reads it as its label loss, and resuming it with the re-rendering
  // loss on is refused (its epochs were scored by another measure).
  double validation_objective = 0;
  std::array<double, 14> validation_rmse{};  // per label channel
  double seconds = 0;                        // training and validation
  double samples_per_second = 0;             // patch samples (valid tile outputs) trained per second
};

// The epoch a run keeps: the first with the lowest validation objective. `history` not empty.
const CnnEpoch& KeptEpoch(const std::vector<CnnEpoch>& history);

// Trains `cnn` in place and returns every epoch's record (with resume: from the first epoch,
// the earlier ones read from the checkpoint). Every example must have the model's input
// channels and be at least `tile` pixels on each side.
Result<std::vector<CnnEpoch>> TrainCnn(Cnn& cnn, const std::vector<CnnExample>& train, const std::vector<CnnExample>& validation,
                                       const CnnTrainingOptions& options);
// The same with the training examples read as needed (options.resident_materials at a time).
Result<std::vector<CnnEpoch>> TrainCnn(Cnn& cnn, const CnnExampleSource& train, const std::vector<CnnExample>& validation,
                                       const CnnTrainingOptions& options);

// The epochs as a JSON array (what checkpoints keep in history.json).
std::string CnnHistoryJson(const std::vector<CnnEpoch>& history);
// The epochs of such an array; DataLoss naming `file` when `text` is not one.
Result<std::vector<CnnEpoch>> ParseCnnHistory(const std::string& text, const std::string& file);

// The augmentation of CnnTrainingOptions::radiance_noise on one input (CnnInputFromStack's
// features): every observation's radiance multiplied by its own 1 + relative_sigma · N(0, 1)
// (clamped at 0); the geometry channels and unseen observations (0) as they were.
Result<CnnTensor> WithRadianceNoise(const CnnTensor& input, double relative_sigma, uint64_t seed);

// Loss and per-channel RMSE of `cnn` on `examples` (dense, whole materials, no dropout).
struct CnnScore {
  double loss = 0;
  std::array<double, 14> rmse{};
  int64_t pixels = 0;
  // When every example has its stack: the re-rendering loss (CnnTrainingOptions' default δ and
  // strip samples) on 512 valid pixels of each, drawn from the example's index: what training's
  // validation_rerender_loss measures on the same set. 0 otherwise.
  double rerender_loss = 0;
  // The (cos 2α, sin 2α) RMSE (rmse[11], rmse[12]) over the pixels whose true lobe is anisotropic
  // (the wider width ≥ kAnisotropicSigmaRatio × the narrower, as `loom eval` counts
  // them), and how many. A round lobe has no angle to find: the simulator writes α = 0 there, so
  // over every pixel even an exact fit keeps an error there (configs/models/tac7/HISTORY.md).
  std::array<double, 2> angle_rmse_where_anisotropic{};
  int64_t anisotropic_pixels = 0;
};
Result<CnnScore> ScoreCnn(const Cnn& cnn, const std::vector<CnnExample>& examples, int threads = 0);

}  // namespace loom::fitting
