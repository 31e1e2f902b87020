#include "fitting/cnn/torch/torch_cnn.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <optional>
#include <random>
#include <sstream>

#include "core/file_io.h"
#include "core/parallel.h"
#include "fitting/cnn/torch/cnn_net.h"
#include "fitting/cnn/torch/label_loss.h"
#include "fitting/cnn/torch/patch_windows.h"
#include "fitting/cnn/torch/rerender_loss.h"
#include "fitting/model/label.h"
#include "fitting/model/stack_pixels.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// The checkpoint is written to next/ and then renamed to last/: a crash leaves one complete.
constexpr const char* kLastCheckpoint = "last";
constexpr const char* kNextCheckpoint = "next";
constexpr const char* kBestModel = "best";
// Steps between progress reports, each of which waits for the device to read the running loss.
constexpr int kProgressSteps = 16;

// A copy of `cnn` with its weights on the CPU.
Result<Cnn> CpuCopy(const Cnn& cnn) {
  LOOM_ASSIGN_OR_RETURN(Cnn copy, internal::CreateCnn(cnn.info(), 0));
  torch::NoGradGuard no_grad;
  const auto from = cnn.net().net->named_parameters(), to = copy.net().net->named_parameters();
  for (const auto& parameter : from) to[parameter.key()].copy_(parameter.value());
  return copy;
}

Result<torch::Device> TrainingDevice(CnnTrainingOptions::Device device) {
  LOOM_RETURN_IF_ERROR(internal::CheckTorchDevice(device));
  return device == CnnTrainingOptions::Device::kCuda ? torch::Device(torch::kCUDA, 0) : torch::Device(torch::kCPU);
}

torch::Tensor AsTensor(const CnnTensor& t) {
  return torch::from_blob(const_cast<float*>(t.values.data()), {1, t.channels, t.height, t.width}, torch::kFloat32);
}

torch::Tensor ValidTensor(const CnnLabels& labels) {
  return torch::from_blob(const_cast<uint8_t*>(labels.valid.data()), {1, 1, labels.labels.height, labels.labels.width},
                          torch::kUInt8)
      .to(torch::kFloat32);
}

// A generator of `device`'s kind seeded with `seed`: the radiance noise is drawn where the
// network trains, with nothing drawn or copied on the host (on the CPU the same numbers as a
// CPU generator made with that seed).
at::Generator SeededGenerator(const torch::Device& device, uint64_t seed) {
  at::Generator generator = at::globalContext().defaultGenerator(device).clone();
  generator.set_current_seed(seed);
  return generator;
}

// N × C × H × W features with radiance noise (WithRadianceNoise), drawn by `generator` on the
// features' device.
torch::Tensor NoisyRadiance(const torch::Tensor& input, double relative_sigma, at::Generator& generator) {
  const torch::Tensor geometry = input.narrow(1, 0, kCnnGeometryChannels);
  const torch::Tensor features = input.narrow(1, kCnnGeometryChannels, input.size(1) - kCnnGeometryChannels);
  // The features are log(1 + L / scale): the noise multiplies L / scale = expm1(feature).
  const torch::Tensor noise = torch::randn(features.sizes(), generator, features.options());
  const torch::Tensor factor = 1 + relative_sigma * noise;
  return torch::cat({geometry, torch::log1p(torch::clamp_min(torch::expm1(features) * factor, 0))}, 1);
}

// A summed-area table of a material's valid pixels, on the host: a tile's count of them without
// reading the device, so that a step queues its work without waiting for the one before.
class ValidCounts {
 public:
  explicit ValidCounts(const CnnLabels& labels) : width_(labels.labels.width), sums_((labels.labels.height + 1) * (width_ + 1)) {
    for (int y = 0; y < labels.labels.height; ++y) {
      for (int x = 0; x < width_; ++x) {
        sums_[At(x + 1, y + 1)] = (labels.valid[static_cast<size_t>(y) * width_ + x] != 0) + sums_[At(x, y + 1)] +
                                  sums_[At(x + 1, y)] - sums_[At(x, y)];
      }
    }
  }
  int64_t Tile(int x, int y, int tile) const {
    return sums_[At(x + tile, y + tile)] - sums_[At(x, y + tile)] - sums_[At(x + tile, y)] + sums_[At(x, y)];
  }

 private:
  size_t At(int x, int y) const { return static_cast<size_t>(y) * (width_ + 1) + x; }
  int width_;
  std::vector<int64_t> sums_;
};

// One training material as tensors where the network trains: the input, labels and validity.
// The input is kept unpadded (a tile's halo is cut with its window, patch_windows.h): padded, a
// 32² material's 932 channels took twice the memory, and a 1,656-fabric tac7 set did not fit in
// 24 GB.
struct Material {
  torch::Tensor input;   // 1 × C × H × W
  torch::Tensor labels;  // 1 × 14 × H × W
  torch::Tensor valid;   // 1 × 1 × H × W
  int height, width;
  std::shared_ptr<const ValidCounts> valid_counts;
  // With the re-rendering loss: every pixel's observations (pixel (x, y) row y · width + x), on
  // the host until the window's materials share one table where the network trains.
  internal::RerenderTable rerender;
  int64_t first_row = 0;  // the material's first row in that table
};

// The re-rendering table of every pixel of `stack` (on the calling thread: materials load on the
// training's threads). Cast shadows are left out: the test costs a ray march per emitter, and the
// robust loss takes the few shadowed observations as outliers.
internal::RerenderTable RerenderTableOf(const ObservationStack& stack, int strip_samples) {
  const StackPixels pixels(stack, {.cast_shadows = false, .strip_quadrature = std::nullopt});
  // A row of pixels at a time: every pixel's observations at once, each emitter of a strip a
  // light sample, take many times the memory of the table they make.
  std::vector<internal::RerenderTable> rows;
  for (int y = 0; y < pixels.height(); ++y) {
    std::vector<std::vector<PixelObservation>> observations;
    for (int x = 0; x < pixels.width(); ++x) observations.push_back(pixels.Observations(x, y));
    rows.push_back(internal::MakeRerenderTable(observations, strip_samples));
  }
  return internal::ConcatRerenderTables(rows);
}

// A training example as tensors on `device` (copies: the example may go); its re-rendering table
// on the host.
Result<Material> PrepareMaterial(const CnnExample& e, const CnnTrainingOptions& options, const torch::Device& device) {
  const torch::Tensor input = torch::from_blob(const_cast<float*>(e.input.values.data()),
                                               {1, e.input.channels, e.input.height, e.input.width}, torch::kFloat32);
  Material material{input.to(device, /*non_blocking=*/false, /*copy=*/true),
                    AsTensor(e.labels.labels).to(device, /*non_blocking=*/false, /*copy=*/true),
                    ValidTensor(e.labels).to(device),
                    e.input.height,
                    e.input.width,
                    std::make_shared<const ValidCounts>(e.labels),
                    {}};
  if (options.rerender_weight > 0) {
    if (!e.stack) return InvalidArgumentError(e.name, "training example without its stack: the re-rendering loss needs it");
    if (e.stack->image.width() != e.input.width || e.stack->image.height() != e.input.height) {
      return InvalidArgumentError(e.name, "training example whose stack is not the input's size");
    }
    material.rerender = RerenderTableOf(*e.stack, options.rerender_strip_samples);
  }
  return material;
}

// A window's materials and, with the re-rendering loss, their pixels' observations in one table,
// both where the network trains.
struct Resident {
  std::vector<Material> materials;
  internal::RerenderTable rerender;
};

Resident MakeResident(std::vector<Material> materials, const torch::Device& device) {
  Resident resident;
  std::vector<internal::RerenderTable> tables;
  int64_t rows = 0;
  for (Material& m : materials) {
    if (m.rerender.rows() == 0) continue;  // trained without the re-rendering loss
    m.first_row = rows;
    rows += m.rerender.rows();
    tables.push_back(m.rerender.To(device));  // one at a time: the host never holds two copies of them all
    m.rerender = {};
  }
  if (!tables.empty()) resident.rerender = internal::ConcatRerenderTables(tables);
  resident.materials = std::move(materials);
  return resident;
}

struct Batch {
  torch::Tensor input, labels, valid;  // where the network trains
  // Per tile, on the host until the re-rendering loss takes them there: the table row of its
  // first pixel and its material's width (a row down the tile is that many table rows on).
  std::vector<int64_t> first_row, row_stride;
  int64_t valid_pixels = 0;  // counted on the host
};

Batch SampleTiles(const std::vector<Material>& materials, int tile, int count, std::mt19937_64& rng) {
  std::vector<torch::Tensor> inputs, labels, valid;
  Batch batch;
  for (int i = 0; i < count; ++i) {
    const Material& m = materials[std::uniform_int_distribution<size_t>(0, materials.size() - 1)(rng)];
    const int y = std::uniform_int_distribution<int>(0, m.height - tile)(rng);
    const int x = std::uniform_int_distribution<int>(0, m.width - tile)(rng);
    inputs.push_back(internal::TileWindow(m.input, x, y, tile, kPatchHalo));
    labels.push_back(m.labels.narrow(2, y, tile).narrow(3, x, tile));
    valid.push_back(m.valid.narrow(2, y, tile).narrow(3, x, tile));
    batch.first_row.push_back(m.first_row + static_cast<int64_t>(y) * m.width + x);
    batch.row_stride.push_back(m.width);
    batch.valid_pixels += m.valid_counts->Tile(x, y, tile);
  }
  batch.input = torch::cat(inputs);
  batch.labels = torch::cat(labels);
  batch.valid = torch::cat(valid);
  return batch;
}

// The re-rendering loss of a batch's predictions (N × 14 × T × T) at `rerender_pixels` pixels of
// each tile, drawn among its valid ones uniformly or as narrow as their true lobes are
// (rerender_lobe_reference). Where the network trains, from `table`: the draws, and the drawn
// pixels' observations gathered by row; a tile without a valid pixel draws pixels that weigh
// nothing, so that nothing is read back to test for it.
torch::Tensor BatchRerenderLoss(const Batch& batch, const torch::Tensor& predicted, const internal::RerenderTable& table,
                                const CnnTrainingOptions& options, std::mt19937_64& rng) {
  const int64_t tiles = predicted.size(0), tile = predicted.size(2);
  const torch::Tensor valid = batch.valid.reshape({tiles, tile * tile});
  torch::Tensor weights = valid;
  if (options.rerender_lobe_reference > 0) {
    const torch::Tensor narrowness = internal::LobeNarrowness(batch.labels, options.rerender_lobe_reference);
    weights = torch::where(valid > 0, narrowness.reshape({tiles, tile * tile}), torch::zeros_like(valid));
  }
  const torch::Tensor drawn = internal::DrawRows(weights, options.rerender_pixels, rng);
  const auto per_tile = [&](const std::vector<int64_t>& values) {
    return internal::ToDevice(torch::tensor(values, torch::kLong), predicted.device()).unsqueeze(1);
  };
  const torch::Tensor rows =
      per_tile(batch.first_row) + torch::div(drawn, tile, "floor") * per_tile(batch.row_stride) + torch::remainder(drawn, tile);
  const internal::RerenderBatch rerender = internal::GatherRerenderBatch(table, rows.flatten(), valid.gather(1, drawn).flatten());
  // The pixels' labels in one gather (a view per pixel cost a full-size gradient each in the
  // backward pass).
  const torch::Tensor index = (torch::arange(tiles, drawn.options()).unsqueeze(1) * (tile * tile) + drawn).flatten();
  const torch::Tensor labels = predicted.permute({0, 2, 3, 1}).reshape({-1, kLabelSize}).index_select(0, index);
  return internal::RerenderLoss(labels, rerender, options.rerender_huber);
}

double LearningRate(const CnnTrainingOptions& options, int epoch) {  // epoch 0-based
  if (options.epochs <= 1) return options.learning_rate_start;
  const double t = static_cast<double>(epoch) / (options.epochs - 1);
  return options.learning_rate_start * std::pow(options.learning_rate_end / options.learning_rate_start, t);
}

Status CheckExamples(const Cnn& cnn, const std::vector<CnnExample>& examples, int min_size, const char* set) {
  for (const CnnExample& e : examples) {
    if (e.input.channels != cnn.info().architecture.input_channels) {
      return InvalidArgumentError(e.name, std::string(set) + " example with " + std::to_string(e.input.channels) +
                                              " input channels, the model takes " +
                                              std::to_string(cnn.info().architecture.input_channels));
    }
    if (e.labels.labels.height != e.input.height || e.labels.labels.width != e.input.width) {
      return InvalidArgumentError(e.name, std::string(set) + " example whose labels are not the input's size");
    }
    if (e.input.height < min_size || e.input.width < min_size) {
      return InvalidArgumentError(e.name, std::string(set) + " example of " + std::to_string(e.input.width) + "x" +
                                              std::to_string(e.input.height) + " px, smaller than a tile of " +
                                              std::to_string(min_size));
    }
  }
  return {};
}

}  // namespace

Status internal::CheckTorchDevice(CnnTrainingOptions::Device device) {
  if (device == CnnTrainingOptions::Device::kCuda && !torch::cuda::is_available()) {
    return FailedPreconditionError("the CNN on cuda",
                                   "no CUDA GPU is available to this build of LibTorch (Debian's libtorch is CPU-only): "
                                   "run it on the cpu, or build loom against a CUDA LibTorch (docs/gpu-training.md)");
  }
  return {};
}

namespace {

Status SaveCheckpoint(const Cnn& cnn, torch::optim::Adam& optimizer, const std::vector<CnnEpoch>& history, const fs::path& dir) {
  const fs::path next = dir / kNextCheckpoint, last = dir / kLastCheckpoint;
  std::error_code error;
  fs::remove_all(next, error);
  LOOM_RETURN_IF_ERROR(internal::SaveCnn(cnn, next / "model"));
  std::ostringstream optimizer_state;  // in memory: LibTorch's file writer aborts on a full disk
  try {
    torch::save(optimizer, optimizer_state);
  } catch (const std::exception& e) {
    return InternalError((next / "optimizer.pt").string(), internal::TorchErrorMessage(e));
  }
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(next / "optimizer.pt", optimizer_state.view()));
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(next / "history.json", CnnHistoryJson(history) + "\n"));
  fs::remove_all(last, error);
  fs::rename(next, last, error);
  if (error) return IoError(last.string(), "cannot move the checkpoint into place: " + error.message());
  return {};
}

// The checkpoint to resume from: last/, or next/ when a crash came between removing last/ and
// renaming next/ (next/ is complete once its history.json exists).
Result<fs::path> CheckpointToResume(const fs::path& dir) {
  for (const char* name : {kLastCheckpoint, kNextCheckpoint}) {
    if (fs::exists(dir / name / "history.json")) return dir / name;
  }
  return NotFoundError(dir.string(), "no checkpoint to resume from (no last/history.json)");
}

std::string ObjectiveText(double rerender_weight) {
  if (rerender_weight == 0) return "the validation label loss alone";
  std::ostringstream text;
  text << "the validation label loss + " << rerender_weight << " x re-rendering loss";
  return text.str();
}

// The run keeps the epoch with the lowest objective over the resumed epochs and its own, so
// every epoch must have been scored by this run's objective. A checkpoint written without the
// re-rendering loss, or before loom kept epochs by it, states its label loss alone: resumed with
// the loss on, its epochs would look ~10x better than the new ones and stay kept.
Status CheckResumedObjective(const std::vector<CnnEpoch>& history, double rerender_weight, const fs::path& file) {
  for (const CnnEpoch& e : history) {
    const double scored_weight =
        e.validation_rerender_loss > 0 ? (e.validation_objective - e.validation_loss) / e.validation_rerender_loss : 0;
    if (std::abs(scored_weight - rerender_weight) <= 1e-6 * std::max(1.0, rerender_weight)) continue;
    return FailedPreconditionError(
        file.string(), "epoch " + std::to_string(e.epoch) + " was scored by " + ObjectiveText(scored_weight) + ", this run by " +
                           ObjectiveText(rerender_weight) +
                           ": the two do not compare. Resume with the options the run had, or start a new run from "
                           "its model (--init " +
                           (file.parent_path() / "model").string() + ")");
  }
  return {};
}

// Replaces `cnn` and `optimizer` by the checkpoint's; returns the epochs it has done.
Result<std::vector<CnnEpoch>> Resume(const fs::path& dir, double rerender_weight, const torch::optim::AdamOptions& adam,
                                     const torch::Device& device, Cnn& cnn, std::unique_ptr<torch::optim::Adam>& optimizer) {
  Result<fs::path> checkpoint = CheckpointToResume(dir);
  if (!checkpoint.ok()) return checkpoint.status();
  // The history first: a run that cannot go on is refused before the model and optimizer load.
  const fs::path optimizer_path = *checkpoint / "optimizer.pt", history_path = *checkpoint / "history.json";
  LOOM_ASSIGN_OR_RETURN(const std::string text, ReadFile(history_path));
  LOOM_ASSIGN_OR_RETURN(std::vector<CnnEpoch> history, ParseCnnHistory(text, history_path.string()));
  LOOM_RETURN_IF_ERROR(CheckResumedObjective(history, rerender_weight, history_path));
  Result<Cnn> loaded = internal::LoadCnn(*checkpoint / "model");
  if (!loaded.ok()) return loaded.status();
  if (loaded->info().architecture.input_channels != cnn.info().architecture.input_channels ||
      loaded->info().architecture.width_divisor != cnn.info().architecture.width_divisor) {
    return FailedPreconditionError((*checkpoint / "model").string(), "a checkpoint of another architecture");
  }
  cnn = std::move(*loaded);
  cnn.net().net->to(device);
  optimizer = std::make_unique<torch::optim::Adam>(cnn.net().net->parameters(), adam);
  try {
    torch::load(*optimizer, optimizer_path.string(), device);
  } catch (const std::exception& e) {
    return DataLossError(optimizer_path.string(), "unreadable checkpoint: " + internal::TorchErrorMessage(e));
  }
  return history;
}

}  // namespace

CnnTensor internal::NoisyInput(const CnnTensor& input, double relative_sigma, uint64_t seed) {
  at::Generator generator = at::make_generator<at::CPUGeneratorImpl>(seed);
  const torch::Tensor noisy = NoisyRadiance(AsTensor(input), relative_sigma, generator).contiguous();
  return {input.channels, input.height, input.width,
          std::vector<float>(noisy.data_ptr<float>(), noisy.data_ptr<float>() + noisy.numel())};
}

namespace {

// A scored material's re-rendering probe: valid pixels drawn once, uniformly, with their
// observations. Every epoch renders the same pixels from its predictions, so that epochs compare
// on the re-rendering as they do on the labels.
struct RerenderProbe {
  torch::Tensor pixels;  // flat indices into the material's H × W
  internal::RerenderBatch batch;
};

// Pixels a probe renders: enough that epochs a few per cent apart in the loss are told apart, few
// enough that a tac7 material's observations stay in tens of MB.
constexpr int kProbePixels = 512;
constexpr int kAngleChannel = 11;                    // cos 2α, sin 2α: 11, 12
constexpr uint64_t kProbeSeed = 0x9e3779b97f4a7c15;  // not the run's seed: probes compare across runs too

// The examples' probes, each drawn from its index, so that a set scored again (loom model
// --score) renders the pixels its training validated on.
Result<std::vector<RerenderProbe>> MakeRerenderProbes(const std::vector<CnnExample>& examples, int strip_samples) {
  std::vector<RerenderProbe> probes;
  for (size_t i = 0; i < examples.size(); ++i) {
    const CnnExample& e = examples[i];
    if (!e.stack) return InvalidArgumentError(e.name, "example without its stack: the re-rendering loss needs it");
    if (e.stack->image.width() != e.input.width || e.stack->image.height() != e.input.height) {
      return InvalidArgumentError(e.name, "example whose stack is not the input's size");
    }
    const StackPixels stack_pixels(*e.stack, StackPixelOptions{.cast_shadows = false, .strip_quadrature = std::nullopt});
    std::mt19937_64 rng(kProbeSeed + i);
    const std::vector<int64_t> drawn = internal::DrawPixels(ValidTensor(e.labels)[0][0], kProbePixels, rng);
    std::vector<std::vector<PixelObservation>> observations;
    for (const int64_t at : drawn) {
      observations.push_back(
          stack_pixels.Observations(static_cast<int>(at % e.input.width), static_cast<int>(at / e.input.width)));
    }
    probes.push_back({torch::tensor(drawn, torch::kLong), internal::MakeRerenderBatch(observations, strip_samples)});
  }
  return probes;
}

// The re-rendering loss of a material's predicted labels (1 × 14 × H × W) at its probe's pixels;
// 0 where the probe has no usable observation.
double ProbeRerenderLoss(const RerenderProbe& probe, const torch::Tensor& predicted, double huber_delta) {
  if (probe.batch.radiance.numel() == 0) return 0;
  const torch::Tensor labels = predicted[0].reshape({kLabelSize, -1}).t().index_select(0, probe.pixels);
  return internal::RerenderLoss(labels, probe.batch, huber_delta).item<double>();
}

// ScoreCnnLabels, with the re-rendering loss at `probes` (one per example; none: not scored).
Result<CnnScore> ScoreLabels(const Cnn& cnn, const std::vector<CnnExample>& examples, int threads,
                             const std::vector<RerenderProbe>& probes, double huber_delta) {
  LOOM_RETURN_IF_ERROR(CheckExamples(cnn, examples, 1, "scored"));
  CnnScore score;
  double loss_sum = 0, rerender_sum = 0;
  std::array<double, 14> squares{};
  std::array<double, 2> angle_squares{};
  const torch::Tensor paper_weights = internal::LabelChannelWeights();
  for (size_t i = 0; i < examples.size(); ++i) {
    const CnnExample& e = examples[i];
    Result<CnnTensor> predicted = internal::PredictDenseLabels(cnn, e.input, kDenseTile, threads);
    if (!predicted.ok()) return predicted.status();
    c10::InferenceMode inference;
    const torch::Tensor p = AsTensor(*predicted), t = AsTensor(e.labels.labels), valid = ValidTensor(e.labels);
    if (!probes.empty()) rerender_sum += ProbeRerenderLoss(probes[i], p, huber_delta);
    loss_sum += internal::HuberSum(p, t, valid, paper_weights).item<double>();
    const torch::Tensor squared_error = (p - t).square();
    const torch::Tensor channel_squares = (squared_error * valid).sum({0, 2, 3});
    for (int c = 0; c < kLabelSize; ++c) squares[c] += channel_squares[c].item<double>();
    score.pixels += static_cast<int64_t>(valid.sum().item<double>());
    const torch::Tensor anisotropic = internal::AnisotropicPixels(t, valid, kAnisotropicSigmaRatio);
    const torch::Tensor angle_squares_here = (squared_error.narrow(1, kAngleChannel, 2) * anisotropic).sum({0, 2, 3});
    for (int c = 0; c < 2; ++c) angle_squares[c] += angle_squares_here[c].item<double>();
    score.anisotropic_pixels += static_cast<int64_t>(anisotropic.sum().item<double>());
  }
  if (score.pixels == 0) return InvalidArgumentError("CNN score", "no valid pixels in the examples");
  score.loss = loss_sum / (static_cast<double>(score.pixels) * kLabelSize);
  for (int c = 0; c < kLabelSize; ++c) score.rmse[c] = std::sqrt(squares[c] / score.pixels);
  for (int c = 0; c < 2 && score.anisotropic_pixels > 0; ++c) {
    score.angle_rmse_where_anisotropic[c] = std::sqrt(angle_squares[c] / static_cast<double>(score.anisotropic_pixels));
  }
  score.rerender_loss = probes.empty() ? 0 : rerender_sum / static_cast<double>(examples.size());
  return score;
}

}  // namespace

Result<CnnScore> internal::ScoreCnnLabels(const Cnn& cnn, const std::vector<CnnExample>& examples, int threads) {
  const bool with_stacks = std::all_of(examples.begin(), examples.end(), [](const CnnExample& e) { return e.stack != nullptr; });
  if (!with_stacks) return ScoreLabels(cnn, examples, threads, {}, 0);
  const CnnTrainingOptions defaults;
  LOOM_ASSIGN_OR_RETURN(const std::vector<RerenderProbe> probes, MakeRerenderProbes(examples, defaults.rerender_strip_samples));
  return ScoreLabels(cnn, examples, threads, probes, defaults.rerender_huber);
}

namespace {

// The training examples source.load(indices[i]) as materials, each checked, resident where the
// network trains.
Result<Resident> LoadMaterials(const Cnn& cnn, const CnnExampleSource& source, const std::vector<int>& indices,
                               const CnnTrainingOptions& options, const torch::Device& device) {
  // On the training's threads: reading and decoding a material's EXR files takes ~0.25 s.
  std::vector<std::optional<Result<Material>>> prepared(indices.size());
  ParallelFor(static_cast<int>(indices.size()), options.threads, [&](int k) {
    prepared[static_cast<size_t>(k)] = [&]() -> Result<Material> {
      LOOM_ASSIGN_OR_RETURN(const CnnExample example, source.load(indices[static_cast<size_t>(k)]));
      LOOM_RETURN_IF_ERROR(CheckExamples(cnn, {example}, options.tile, "training"));
      return PrepareMaterial(example, options, device);
    }();
  });
  std::vector<Material> materials;
  for (std::optional<Result<Material>>& material : prepared) {  // the first error in the set's order
    if (!material->ok()) return material->status();
    materials.push_back(std::move(**material));
  }
  return MakeResident(std::move(materials), device);
}

// An epoch's windows of the training set: all of it, or with resident_materials a random order
// cut into windows of that many.
std::vector<std::vector<int>> EpochWindows(int count, const CnnTrainingOptions& options, int epoch) {
  std::vector<int> order(count);
  std::iota(order.begin(), order.end(), 0);
  const int window = options.resident_materials > 0 ? std::min(options.resident_materials, count) : count;
  if (window == count) return {order};
  std::mt19937_64 rng(options.seed * 7919 + epoch);  // apart from the tiles' stream
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<std::vector<int>> windows;
  for (int first = 0; first < count; first += window) {
    windows.emplace_back(order.begin() + first, order.begin() + std::min(first + window, count));
  }
  return windows;
}

}  // namespace

Result<std::vector<CnnEpoch>> internal::TrainCnnNet(Cnn& cnn, const CnnExampleSource& train,
                                                    const std::vector<CnnExample>& validation,
                                                    const CnnTrainingOptions& options) {
  LOOM_RETURN_IF_ERROR(options.Check());
  if (train.count == 0 || validation.empty()) {
    return InvalidArgumentError("CNN training", "needs training and validation examples");
  }
  LOOM_RETURN_IF_ERROR(CheckExamples(cnn, validation, 1, "validation"));
  const bool streaming = options.resident_materials > 0 && options.resident_materials < train.count;
  if (streaming && options.steps_per_epoch == 0) {
    return InvalidArgumentError("CnnTrainingOptions", "resident_materials below the training set needs steps_per_epoch");
  }
  std::vector<RerenderProbe> probes;  // the validation's, when the re-rendering loss trains
  if (options.rerender_weight > 0) {
    LOOM_ASSIGN_OR_RETURN(probes, MakeRerenderProbes(validation, options.rerender_strip_samples));
  }
  LOOM_ASSIGN_OR_RETURN(const torch::Device device, TrainingDevice(options.device));
  const int threads = ThreadCount(options.threads);
  torch::set_num_threads(threads);
  internal::SetUpTensorMemory();

  const torch::optim::AdamOptions adam =
      torch::optim::AdamOptions(options.learning_rate_start).betas({0.9, 0.999}).eps(1e-8).weight_decay(options.weight_decay);
  std::unique_ptr<torch::optim::Adam> optimizer;
  std::vector<CnnEpoch> history;
  if (options.resume) {
    Result<std::vector<CnnEpoch>> resumed = Resume(options.checkpoint_dir, options.rerender_weight, adam, device, cnn, optimizer);
    if (!resumed.ok()) return resumed.status();
    history = std::move(*resumed);
  } else {
    cnn.net().net->to(device);
    optimizer = std::make_unique<torch::optim::Adam>(cnn.net().net->parameters(), adam);
  }

  // In memory: every material, loaded once; streaming: one window at a time.
  Resident resident;
  int steps = options.steps_per_epoch;
  if (!streaming) {
    LOOM_ASSIGN_OR_RETURN(resident, LoadMaterials(cnn, train, EpochWindows(train.count, options, 0).front(), options, device));
    double valid_pixels = 0;
    for (const Material& m : resident.materials) valid_pixels += m.valid.sum().item<double>();
    const int tile_samples = options.tile * options.tile * options.tiles_per_step;
    if (steps == 0) steps = std::max(1, static_cast<int>(std::ceil(valid_pixels / tile_samples)));
  }
  internal::CnnNet& net = cnn.net().net;
  const torch::Tensor channel_weights = internal::LabelChannelWeights(options.alpha_weight).to(device);
  for (int epoch = static_cast<int>(history.size()); epoch < options.epochs; ++epoch) {
    const Clock::time_point start = Clock::now();
    CnnEpoch record;
    record.epoch = epoch + 1;
    record.learning_rate = LearningRate(options, epoch);
    for (auto& group : optimizer->param_groups()) {
      static_cast<torch::optim::AdamOptions&>(group.options()).lr(record.learning_rate);
    }
    std::mt19937_64 rng(options.seed * 1000003 + epoch);
    torch::manual_seed(options.seed * 1000003 + epoch);
    at::Generator noise = SeededGenerator(device, options.seed * 1000003 + epoch);
    net->train();
    // Sums kept where the network trains and read once an epoch (and for progress now and then):
    // a step that read its loss would wait for the device before queueing the next.
    torch::Tensor loss_sum = torch::zeros({}, torch::TensorOptions().dtype(torch::kDouble).device(device));
    torch::Tensor rerender_sum = loss_sum.clone();
    double samples = 0;
    const std::vector<std::vector<int>> windows = EpochWindows(train.count, options, epoch);
    int step = 0;
    for (size_t w = 0; w < windows.size(); ++w) {
      if (streaming) {
        resident = {};  // before the next window: at most one window in memory
        LOOM_ASSIGN_OR_RETURN(resident, LoadMaterials(cnn, train, windows[w], options, device));
      }
      // The epoch's steps shared out among the windows by their size.
      const int window_end =
          static_cast<int>(static_cast<int64_t>(steps) * (static_cast<int64_t>(w + 1) * windows.front().size()) / train.count);
      for (; step < std::min(steps, w + 1 == windows.size() ? steps : window_end); ++step) {
        const Batch batch = SampleTiles(resident.materials, options.tile, options.tiles_per_step, rng);
        if (batch.valid_pixels == 0) continue;
        const double count = static_cast<double>(batch.valid_pixels);
        optimizer->zero_grad();
        const torch::Tensor input =
            options.radiance_noise > 0 ? NoisyRadiance(batch.input, options.radiance_noise, noise) : batch.input;
        const torch::Tensor predicted = net->ForwardDense(input);
        const torch::Tensor label_weights =
            internal::NormalLobeWeights(channel_weights, batch.labels, options.normal_lobe_reference);
        torch::Tensor loss = internal::HuberSum(predicted, batch.labels, batch.valid, label_weights) / (count * kLabelSize);
        if (options.rerender_weight > 0) {
          const torch::Tensor rerender = BatchRerenderLoss(batch, predicted, resident.rerender, options, rng);
          loss = loss + options.rerender_weight * rerender;
          rerender_sum += rerender.detach();
        }
        loss.backward();
        optimizer->step();
        loss_sum += loss.detach();
        samples += count;
        if (options.progress && ((step + 1) % kProgressSteps == 0 || step + 1 == steps)) {
          options.progress({epoch + 1, options.epochs, step + 1, steps, loss_sum.item<double>() / (step + 1)});
        }
      }
    }
    record.train_loss = loss_sum.item<double>() / steps;
    record.train_rerender_loss = rerender_sum.item<double>() / steps;
    if (!std::isfinite(record.train_loss) || !std::isfinite(record.train_rerender_loss)) {
      // Diverged: every later epoch would be NaN too, and a NaN model must never be written.
      return FailedPreconditionError("training, epoch " + std::to_string(epoch + 1),
                                     "the loss is not a finite number (a learning rate too high?): stopped; the "
                                     "checkpoints and the model of earlier epochs are kept as they were");
    }
    record.samples_per_second = samples / std::chrono::duration<double>(Clock::now() - start).count();
    // Validation and the checkpoint from a copy of the weights on the CPU: the network being
    // trained stays where it is (moving it to the CPU and back between epochs crashed CUDA
    // training in its next step, LibTorch 2.11).
    LOOM_ASSIGN_OR_RETURN(const Cnn snapshot, CpuCopy(cnn));
    Result<CnnScore> score = ScoreLabels(snapshot, validation, threads, probes, options.rerender_huber);
    torch::set_num_threads(threads);  // ScoreCnn's inference sets one thread
    if (!score.ok()) return score.status();
    record.validation_loss = score->loss;
    record.validation_rmse = score->rmse;
    record.validation_rerender_loss = score->rerender_loss;
    record.validation_objective = record.validation_loss + options.rerender_weight * score->rerender_loss;
    record.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    history.push_back(record);
    const bool best = KeptEpoch(history).epoch == record.epoch;
    if (!options.checkpoint_dir.empty()) {
      if (best) LOOM_RETURN_IF_ERROR(SaveCnn(snapshot, options.checkpoint_dir / kBestModel));
      LOOM_RETURN_IF_ERROR(SaveCheckpoint(snapshot, *optimizer, history, options.checkpoint_dir));
    }
  }
  net->to(torch::kCPU);
  net->eval();
  return history;
}

}  // namespace loom::fitting
