#include "fitting/cnn/torch/cnn_net.h"

#include <malloc.h>
#include <sys/mman.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <mutex>
#include <random>
#include <sstream>

#include <c10/core/CPUAllocator.h>
#include <nlohmann/json.hpp>

#include "core/file_io.h"
#include "core/log.h"
#include "core/parallel.h"
#include "fitting/cnn/torch/patch_windows.h"
#include "fitting/cnn/torch/torch_api.h"
#include "fitting/cnn/torch/torch_cnn.h"
#include "fitting/model/label.h"

namespace loom::fitting {

std::string internal::TorchErrorMessage(const std::exception& error) {
  const auto* torch_error = dynamic_cast<const c10::Error*>(&error);
  if (torch_error == nullptr) return error.what();
  LOOM_LOG(Debug) << "LibTorch: " << torch_error->what();
  return torch_error->what_without_backtrace();
}
namespace internal {

CnnNetImpl::CnnNetImpl(const CnnArchitecture& architecture) {
  namespace nn = torch::nn;
  const std::array<int, 4> w = architecture.HiddenWidths();
  conv1_ = register_module("conv1", nn::Conv2d(nn::Conv2dOptions(architecture.input_channels, w[0], 1)));
  conv2_ = register_module("conv2", nn::Conv2d(nn::Conv2dOptions(w[0], w[1], 1)));
  conv3_ = register_module("conv3", nn::Conv2d(nn::Conv2dOptions(w[1], w[2], 3).stride(2)));
  conv4_ = register_module("conv4", nn::Conv2d(nn::Conv2dOptions(w[2], w[3], 3).stride(2)));
  fc_ = register_module("fc", nn::Linear(9 * w[3], kLabelSize));
  dropout_ = register_module("dropout", nn::Dropout(architecture.dropout));
  if (architecture.centre_skip) skip_ = register_module("skip", nn::Linear(w[1], kLabelSize));
  width4_ = w[3];
}

torch::Tensor CnnNetImpl::Leaky(const torch::Tensor& x) const { return torch::leaky_relu(x, kLeakySlope); }

torch::Tensor CnnNetImpl::ForwardPatches(const torch::Tensor& patches) {
  torch::Tensor x = Leaky(conv1_->forward(patches.contiguous(at::MemoryFormat::ChannelsLast)));
  const torch::Tensor features = Leaky(conv2_->forward(x));
  x = Leaky(conv3_->forward(features));
  x = Leaky(conv4_->forward(x));
  const torch::Tensor out = fc_->forward(dropout_->forward(x.flatten(1)));
  if (!skip_) return out;
  return out + skip_->forward(features.select(2, kPatchHalo).select(2, kPatchHalo));
}

torch::Tensor CnnNetImpl::ForwardDense(const torch::Tensor& input) {
  namespace F = torch::nn::functional;
  // Channels-last lets oneDNN run the 1 × 1 layers and fc 2-3× faster here (bench/cnn_bench.cc).
  torch::Tensor x = Leaky(conv1_->forward(input.contiguous(at::MemoryFormat::ChannelsLast)));
  const torch::Tensor features = Leaky(conv2_->forward(x));
  // A stride-2 layer's outputs for every pixel: stride 1, and each later layer's taps spread by
  // the strides before it (dilation 2 for conv4, 4 for fc).
  x = Leaky(F::conv2d(features, conv3_->weight, F::Conv2dFuncOptions().bias(conv3_->bias)));
  x = Leaky(F::conv2d(x, conv4_->weight, F::Conv2dFuncOptions().bias(conv4_->bias).dilation(2)));
  // fc's inputs are conv4's 3 × 3 × w4 outputs flattened channel-major: the same weights
  // as a 14 × w4 × 3 × 3 kernel.
  const torch::Tensor kernel = fc_->weight.view({kLabelSize, width4_, 3, 3});
  const torch::Tensor out = F::conv2d(dropout_->forward(x), kernel, F::Conv2dFuncOptions().bias(fc_->bias).dilation(4));
  if (!skip_) return out;
  // Each output pixel's own features sit kPatchHalo in from its window's corner.
  const torch::Tensor centres = features.narrow(2, kPatchHalo, out.size(2)).narrow(3, kPatchHalo, out.size(3));
  const torch::Tensor readout = skip_->weight.view({kLabelSize, skip_->weight.size(1), 1, 1});
  return out + F::conv2d(centres, readout, F::Conv2dFuncOptions().bias(skip_->bias));
}

namespace {

constexpr size_t kHugePage = size_t{2} << 20;
constexpr size_t kTorchAlignment = 64;  // c10's own CPU allocator's

void FreeTensorMemory(void* data) { std::free(data); }

// torch's CPU allocator, but blocks of a huge page or more aligned to huge pages and advised to
// the kernel as such (transparent huge pages, which Debian's kernel gives on madvise).
class HugePageTensorAllocator final : public TensorAllocator {
 public:
  c10::DeleterFnPtr raw_deleter() const override { return &FreeTensorMemory; }

 protected:
  c10::DataPtr Allocate(size_t bytes) const override {
    const c10::Device cpu(c10::DeviceType::CPU);
    if (bytes == 0) return {nullptr, nullptr, &FreeTensorMemory, cpu};
    const bool huge = bytes >= kHugePage;
    const size_t alignment = huge ? kHugePage : kTorchAlignment;
    const size_t size = (bytes + alignment - 1) / alignment * alignment;
    void* data = std::aligned_alloc(alignment, size);
    if (data == nullptr) throw std::bad_alloc();
    if (huge) madvise(data, size, MADV_HUGEPAGE);  // only advice: without it the memory still works
    return {data, data, &FreeTensorMemory, cpu};
  }
};

}  // namespace

void SetUpTensorMemory() {
  static std::once_flag once;
  std::call_once(once, [] {
    mallopt(M_MMAP_MAX, 0);
    mallopt(M_TRIM_THRESHOLD, std::numeric_limits<int>::max());
    static HugePageTensorAllocator allocator;
    c10::SetCPUAllocator(&allocator, /*priority=*/1);  // above c10's default (0)
  });
}

torch::Tensor PaddedInput(const CnnTensor& input) {
  const torch::Tensor t =
      torch::from_blob(const_cast<float*>(input.values.data()), {1, input.channels, input.height, input.width}, torch::kFloat32);
  return EdgePadded(t, kPatchHalo);
}

}  // namespace internal

namespace {

using Json = nlohmann::json;
constexpr const char* kInfoFile = "model.json";
constexpr const char* kWeightsFile = "weights.pt";

torch::ScalarType TorchType(WeightStorage storage) {
  return storage == WeightStorage::kFloat16 ? torch::kFloat16 : torch::kFloat32;
}

CnnTensor FromTorch(const torch::Tensor& t) {
  const torch::Tensor c = t.contiguous();
  CnnTensor out;
  out.channels = static_cast<int>(c.size(0));
  out.height = static_cast<int>(c.size(1));
  out.width = static_cast<int>(c.size(2));
  out.values.assign(c.data_ptr<float>(), c.data_ptr<float>() + c.numel());
  return out;
}

// The side of the fewest equal tiles of at most `max_tile` that cover `extent`: equal tiles
// waste no work on a thin last one.
int EqualTileSide(int extent, int max_tile) {
  const int tiles = (extent + max_tile - 1) / max_tile;
  return (extent + tiles - 1) / tiles;
}

Status CheckInput(const Cnn& cnn, const CnnTensor& input) {
  if (input.channels != cnn.info().architecture.input_channels) {
    return InvalidArgumentError("CNN input", std::to_string(input.channels) + " channels, the model takes " +
                                                 std::to_string(cnn.info().architecture.input_channels));
  }
  if (input.values.size() != static_cast<size_t>(input.channels) * input.height * input.width || input.height < 1 ||
      input.width < 1) {
    return InvalidArgumentError("CNN input", "values do not match its " + std::to_string(input.channels) + " x " +
                                                 std::to_string(input.height) + " x " + std::to_string(input.width) + " shape");
  }
  return {};
}

Json InfoToJson(const CnnModelInfo& info) {
  Json groups = Json::array();
  for (ObservationGroup g : info.observation_groups) groups.push_back(ObservationGroupName(g));
  Json json = {{"format", "loom-cnn-1"},
               {"architecture",
                {{"input_channels", info.architecture.input_channels},
                 {"width_divisor", info.architecture.width_divisor},
                 {"dropout", info.architecture.dropout}}},
               {"radiance_scale", info.radiance_scale},
               {"rig", info.rig},
               {"observation_groups", groups},
               {"training", info.training}};
  // Only when not the default, so that a float32 model's model.json reads as before (and a
  // model without the centre skip's).
  if (info.weights != WeightStorage::kFloat32) json["weights"] = WeightStorageName(info.weights);
  if (info.architecture.centre_skip) json["architecture"]["centre_skip"] = true;
  if (info.paper_layout) json["paper_layout"] = info.paper_layout->ToJson();
  return json;
}

CnnModelInfo InfoFromJson(const Json& j) {
  if (j.value("format", "") != "loom-cnn-1") throw std::invalid_argument("format is not loom-cnn-1");
  CnnModelInfo info;
  const Json& a = j.at("architecture");
  info.architecture.input_channels = a.at("input_channels").get<int>();
  info.architecture.width_divisor = a.at("width_divisor").get<int>();
  info.architecture.dropout = a.at("dropout").get<double>();
  info.architecture.centre_skip = a.value("centre_skip", false);
  info.radiance_scale = j.at("radiance_scale").get<double>();
  info.rig = j.at("rig").get<std::string>();
  for (const Json& g : j.at("observation_groups")) {
    const std::optional<ObservationGroup> group = ObservationGroupFromName(g.get<std::string>());
    if (!group) throw std::invalid_argument("observation group '" + g.get<std::string>() + "' is unknown");
    info.observation_groups.push_back(*group);
  }
  info.training = j.value("training", "");
  const std::string weights = j.value("weights", WeightStorageName(WeightStorage::kFloat32));
  const std::optional<WeightStorage> storage = WeightStorageFromName(weights);
  if (!storage) throw std::invalid_argument("weights '" + weights + "' is neither float32 nor float16");
  info.weights = *storage;
  if (j.contains("paper_layout")) info.paper_layout = PaperInputLayout::FromJson(j.at("paper_layout"));
  return info;
}

}  // namespace
Result<Cnn> internal::CreateCnn(const CnnModelInfo& info, uint64_t seed) {
  LOOM_RETURN_IF_ERROR(info.architecture.Check());
  torch::manual_seed(seed);
  auto holder = std::make_shared<internal::CnnNetHolder>(internal::CnnNetHolder{internal::CnnNet(info.architecture)});
  return Cnn(info, std::move(holder));
}

Result<Cnn> internal::LoadCnn(const std::filesystem::path& directory) {
  const std::filesystem::path info_path = directory / kInfoFile;
  Result<std::string> text = ReadFile(info_path);
  if (!text.ok()) return text.status();
  CnnModelInfo info;
  try {
    info = InfoFromJson(Json::parse(*text));
  } catch (const std::exception& e) {
    return InvalidArgumentError(info_path.string(), e.what());
  }
  Result<Cnn> cnn = CreateCnn(info, 0);
  if (!cnn.ok()) return InvalidArgumentError(info_path.string(), cnn.status().ToString());
  const std::filesystem::path weights = directory / kWeightsFile;
  // torch::load takes whatever shapes the file has: compare them with model.json's architecture.
  std::vector<std::vector<int64_t>> expected;
  for (const torch::Tensor& p : cnn->net().net->parameters()) expected.push_back(p.sizes().vec());
  // torch::load keeps each parameter's type and takes the file's bytes as that type: load into
  // parameters of the type model.json names, and check the bytes' count below.
  cnn->net().net->to(TorchType(info.weights));
  try {
    torch::load(cnn->net().net, weights.string());
  } catch (const std::exception& e) {
    return InvalidArgumentError(weights.string(), std::string("not weights of this architecture stored as ") +
                                                      WeightStorageName(info.weights) + ": " + TorchErrorMessage(e));
  }
  const std::vector<torch::Tensor> loaded = cnn->net().net->parameters();
  for (size_t i = 0; i < loaded.size(); ++i) {
    if (loaded[i].sizes().vec() != expected[i]) {
      return InvalidArgumentError(weights.string(), "its weights do not have the shapes of " + info_path.string() +
                                                        "'s architecture (" + std::to_string(info.architecture.input_channels) +
                                                        " input channels, width divisor " +
                                                        std::to_string(info.architecture.width_divisor) + ")");
    }
    const torch::Tensor& p = loaded[i];
    if (p.storage().nbytes() != static_cast<size_t>(p.numel()) * p.element_size()) {
      return InvalidArgumentError(weights.string(), std::string("its weights are not stored as ") +
                                                        WeightStorageName(info.weights) + ", as " + info_path.string() +
                                                        " says they are");
    }
  }
  cnn->net().net->to(torch::kFloat32);  // float16 weights compute in float32
  cnn->net().net->eval();
  return cnn;
}

namespace {

// Each of `wide` units as the narrow unit it copies (k mod narrow), and the share of that unit's
// outgoing weights it takes: positive, drawn from U(0.5, 1.5) and normalised over the copies.
struct Widening {
  torch::Tensor source;  // wide, int64
  torch::Tensor share;   // wide, float
};

Widening WidenUnits(int64_t narrow, int64_t wide, std::mt19937_64& rng) {
  const torch::Tensor source = torch::arange(wide, torch::kLong).remainder(narrow);
  std::uniform_real_distribution<float> draw(0.5f, 1.5f);
  std::vector<float> share(static_cast<size_t>(wide)), total(static_cast<size_t>(narrow), 0.0f);
  for (int64_t k = 0; k < wide; ++k) total[static_cast<size_t>(k % narrow)] += share[static_cast<size_t>(k)] = draw(rng);
  for (int64_t k = 0; k < wide; ++k) share[static_cast<size_t>(k)] /= total[static_cast<size_t>(k % narrow)];
  return {source, torch::from_blob(share.data(), {wide}, torch::kFloat32).clone()};
}

// A layer's weight (out × in × …) with its outputs and inputs widened: rows copied from their
// source units, input columns from theirs and scaled by their share.
torch::Tensor WidenWeight(const torch::Tensor& weight, const Widening* out, const Widening* in) {
  torch::Tensor w = out ? weight.index_select(0, out->source) : weight;
  if (!in) return w;
  std::vector<int64_t> shape(static_cast<size_t>(w.dim()), 1);
  shape[1] = in->share.size(0);
  return w.index_select(1, in->source) * in->share.view(shape);
}

}  // namespace

Result<Cnn> internal::GrowCnn(const Cnn& narrow, const CnnArchitecture& to, uint64_t seed) {
  const CnnArchitecture& from = narrow.info().architecture;
  LOOM_RETURN_IF_ERROR(CheckGrowable(from, to));
  if (to.input_channels != from.input_channels || to.dropout != from.dropout) {
    return InvalidArgumentError("architecture", "only the width and the centre skip grow: the input and dropout stay");
  }
  CnnModelInfo info = narrow.info();
  info.architecture = to;
  LOOM_ASSIGN_OR_RETURN(Cnn wide, CreateCnn(info, seed));
  const std::array<int, 4> narrow_widths = from.HiddenWidths(), wide_widths = to.HiddenWidths();
  std::mt19937_64 rng(seed);
  std::array<Widening, 4> units;
  for (size_t l = 0; l < units.size(); ++l) units[l] = WidenUnits(narrow_widths[l], wide_widths[l], rng);
  const CnnNet& a = narrow.net().net;
  CnnNet& b = wide.net().net;
  torch::NoGradGuard no_grad;
  const std::array<std::pair<torch::nn::Conv2d, torch::nn::Conv2d>, 4> convs = {
      {{a->conv1(), b->conv1()}, {a->conv2(), b->conv2()}, {a->conv3(), b->conv3()}, {a->conv4(), b->conv4()}}};
  for (size_t l = 0; l < convs.size(); ++l) {
    convs[l].second->weight.copy_(WidenWeight(convs[l].first->weight, &units[l], l > 0 ? &units[l - 1] : nullptr));
    convs[l].second->bias.copy_(convs[l].first->bias.index_select(0, units[l].source));
  }
  // fc reads conv4's outputs flattened channel-major, 9 taps each: the taps of unit k are
  // columns 9k … 9k + 8.
  const torch::Tensor taps = torch::arange(9, torch::kLong);
  const Widening columns{(units[3].source.unsqueeze(1) * 9 + taps).flatten(), units[3].share.repeat_interleave(9)};
  b->fc()->weight.copy_(WidenWeight(a->fc()->weight, nullptr, &columns));
  b->fc()->bias.copy_(a->fc()->bias);
  if (a->skip()) {  // reads conv2's units, widened as conv3 reads them
    b->skip()->weight.copy_(WidenWeight(a->skip()->weight, nullptr, &units[1]));
    b->skip()->bias.copy_(a->skip()->bias);
  } else if (b->skip()) {  // added: zero until training moves it
    b->skip()->weight.zero_();
    b->skip()->bias.zero_();
  }
  return wide;
}

Result<Cnn> internal::AverageCnns(const std::vector<Cnn>& models) {
  LOOM_ASSIGN_OR_RETURN(Cnn mean, CreateCnn(models.front().info(), 0));
  torch::NoGradGuard no_grad;
  const std::vector<torch::Tensor> sum = mean.net().net->parameters();
  for (const torch::Tensor& weight : sum) weight.zero_();
  const double share = 1.0 / static_cast<double>(models.size());
  for (const Cnn& model : models) {
    const std::vector<torch::Tensor> weights = model.net().net->parameters();
    for (size_t i = 0; i < sum.size(); ++i) sum[i].add_(weights[i], share);
  }
  return mean;
}

namespace {

// The network to write to weights.pt: `cnn`'s own in float32, else a copy in its info's storage
// (rounding a copy, never the weights being used).
internal::CnnNet StoredNet(const Cnn& cnn) {
  const internal::CnnNet& net = cnn.net().net;
  if (cnn.info().weights == WeightStorage::kFloat32) return net;
  internal::CnnNet stored(cnn.info().architecture);
  stored->to(TorchType(cnn.info().weights));
  torch::NoGradGuard no_grad;
  const std::vector<torch::Tensor> from = net->parameters(), to = stored->parameters();
  for (size_t i = 0; i < from.size(); ++i) to[i].copy_(from[i]);
  return stored;
}

}  // namespace

Status internal::SaveCnn(const Cnn& cnn, const std::filesystem::path& directory) {
  LOOM_RETURN_IF_ERROR(CreateDirectories(directory));
  // Weights first: model.json names a complete model or none. LibTorch serialises to memory, as
  // its file writer throws from a destructor (and so aborts) when the disk fills.
  std::ostringstream weights;
  try {
    torch::save(StoredNet(cnn), weights);
  } catch (const std::exception& e) {
    return InternalError((directory / kWeightsFile).string(), "cannot serialise the weights: " + TorchErrorMessage(e));
  }
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(directory / kWeightsFile, weights.view()));
  return WriteFileAtomically(directory / kInfoFile, InfoToJson(cnn.info()).dump(2) + "\n");
}

namespace {

// The tiles one after another on the first CUDA GPU, on a copy of the weights there.
torch::Tensor PredictOnGpu(const Cnn& cnn, const torch::Tensor& padded, int height, int width, int max_tile) {
  const torch::Device gpu(torch::kCUDA, 0);
  internal::CnnNet net(cnn.info().architecture);
  {
    torch::NoGradGuard no_grad;
    const std::vector<torch::Tensor> from = cnn.net().net->parameters(), to = net->parameters();
    for (size_t i = 0; i < from.size(); ++i) to[i].copy_(from[i]);
  }
  net->to(gpu);
  net->eval();
  c10::InferenceMode inference;
  torch::Tensor out = torch::empty({kLabelSize, height, width});
  for (int y = 0; y < height; y += max_tile) {
    for (int x = 0; x < width; x += max_tile) {
      const int h = std::min(max_tile, height - y), w = std::min(max_tile, width - x);
      const torch::Tensor window = padded.narrow(2, y, h + 2 * kPatchHalo).narrow(3, x, w + 2 * kPatchHalo).to(gpu);
      out.narrow(1, y, h).narrow(2, x, w).copy_(net->ForwardDense(window)[0].to(torch::kCPU));
    }
  }
  return out;
}

}  // namespace

Result<CnnTensor> internal::PredictDenseLabels(const Cnn& cnn, const CnnTensor& input, int max_tile, int threads,
                                               CnnDevice device) {
  LOOM_RETURN_IF_ERROR(CheckInput(cnn, input));
  if (max_tile < 1) return InvalidArgumentError("CNN tile", "must be ≥ 1");
  if (device == CnnDevice::kCuda) {
    LOOM_RETURN_IF_ERROR(internal::CheckTorchDevice(device));
    return FromTorch(PredictOnGpu(cnn, internal::PaddedInput(input), input.height, input.width, max_tile));
  }
  // The tiles go to loom's threads, each tile's ops single-threaded: torch's own intra-op
  // threads split a convolution's sums by their count, so that the maps (and every fit started
  // from them) would change with --threads.
  torch::set_num_threads(1);
  internal::SetUpTensorMemory();
  cnn.net().net->eval();
  const torch::Tensor padded = internal::PaddedInput(input);
  torch::Tensor out = torch::empty({kLabelSize, input.height, input.width});
  const int tile_height = EqualTileSide(input.height, max_tile), tile_width = EqualTileSide(input.width, max_tile);
  const int tiles_x = (input.width + tile_width - 1) / tile_width;
  const int tiles = tiles_x * ((input.height + tile_height - 1) / tile_height);
  ParallelFor(tiles, threads, [&](int tile) {
    torch::set_num_threads(1);  // this thread's OpenMP team too
    c10::InferenceMode inference;
    const int y = tile / tiles_x * tile_height, x = tile % tiles_x * tile_width;
    const int h = std::min(tile_height, input.height - y), w = std::min(tile_width, input.width - x);
    const torch::Tensor window = padded.narrow(2, y, h + 2 * kPatchHalo).narrow(3, x, w + 2 * kPatchHalo);
    out.narrow(1, y, h).narrow(2, x, w).copy_(cnn.net().net->ForwardDense(window.contiguous())[0]);
  });
  return FromTorch(out);
}

Result<CnnTensor> internal::PredictSlidingLabels(const Cnn& cnn, const CnnTensor& input, int first, int count, int batch,
                                                 int threads) {
  LOOM_RETURN_IF_ERROR(CheckInput(cnn, input));
  const int pixels = input.height * input.width;
  if (first < 0 || count < 1 || first + count > pixels || batch < 1) {
    return InvalidArgumentError("CNN sliding window", "pixels [" + std::to_string(first) + ", " + std::to_string(first + count) +
                                                          ") of " + std::to_string(pixels) + ", batch " + std::to_string(batch));
  }
  torch::set_num_threads(ThreadCount(threads));
  internal::SetUpTensorMemory();
  c10::InferenceMode inference;
  cnn.net().net->eval();
  const torch::Tensor padded = internal::PaddedInput(input)[0];
  torch::Tensor out = torch::empty({kLabelSize, 1, count});
  for (int begin = 0; begin < count; begin += batch) {
    const int n = std::min(batch, count - begin);
    std::vector<torch::Tensor> patches;
    for (int i = begin; i < begin + n; ++i) {
      const int y = (first + i) / input.width, x = (first + i) % input.width;
      patches.push_back(padded.narrow(1, y, kPatchSize).narrow(2, x, kPatchSize));
    }
    out.narrow(2, begin, n).copy_(cnn.net().net->ForwardPatches(torch::stack(patches)).t().unsqueeze(1));
  }
  return FromTorch(out);
}

}  // namespace loom::fitting