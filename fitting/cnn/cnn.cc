#include "fitting/cnn/cnn.h"

#include <algorithm>

#include "fitting/cnn/internal/cnn_engine.h"
#include "fitting/model/label.h"
#include "fitting/model/svbrdf_maps.h"

namespace loom::fitting {

const char* WeightStorageName(WeightStorage storage) { return storage == WeightStorage::kFloat16 ? "float16" : "float32"; }

std::optional<WeightStorage> WeightStorageFromName(const std::string& name) {
  for (WeightStorage storage : {WeightStorage::kFloat32, WeightStorage::kFloat16}) {
    if (name == WeightStorageName(storage)) return storage;
  }
  return std::nullopt;
}

std::array<int, 4> CnnArchitecture::HiddenWidths() const {
  const int d = std::max(1, width_divisor);
  return {512 / d, 256 / d, 512 / d, 1024 / d};
}

double CnnArchitecture::SlidingFlopsPerPixel() const {
  const std::array<int, 4> w = HiddenWidths();
  const double macs = 225.0 * input_channels * w[0] + 225.0 * w[0] * w[1] + 49.0 * 9 * w[1] * w[2] + 9.0 * 9 * w[2] * w[3] +
                      9.0 * w[3] * kLabelSize + (centre_skip ? 1.0 * w[1] * kLabelSize : 0.0);
  return 2 * macs;
}

double CnnArchitecture::DenseFlopsPerPixel() const {
  const std::array<int, 4> w = HiddenWidths();
  const double macs = 1.0 * input_channels * w[0] + 1.0 * w[0] * w[1] + 9.0 * w[1] * w[2] + 9.0 * w[2] * w[3] +
                      9.0 * w[3] * kLabelSize + (centre_skip ? 1.0 * w[1] * kLabelSize : 0.0);
  return 2 * macs;
}

int64_t CnnArchitecture::WeightCount() const {
  const std::array<int, 4> w = HiddenWidths();
  const auto layer = [](int64_t inputs, int64_t outputs) { return inputs * outputs + outputs; };
  return layer(input_channels, w[0]) + layer(w[0], w[1]) + layer(9 * w[1], w[2]) + layer(9 * w[2], w[3]) +
         layer(9 * w[3], kLabelSize) + (centre_skip ? layer(w[1], kLabelSize) : 0);
}

Status CnnArchitecture::Check() const {
  std::vector<std::string> problems;
  // The first layer's weights grow with the channels: a bound keeps a damaged model.json from
  // asking for terabytes (the paper's rig has a few hundred observations per stack).
  if (input_channels < 1 || input_channels > 65536) problems.push_back("input_channels must be in [1, 65536]");
  if (width_divisor < 1 || 256 % width_divisor != 0) problems.push_back("width_divisor must divide 256");
  if (!(dropout >= 0 && dropout < 1)) problems.push_back("dropout must be in [0, 1)");
  return ProblemsStatus("CnnArchitecture", problems);
}

bool SameInputLayout(const CnnModelInfo& a, const CnnModelInfo& b) {
  const auto layout = [](const CnnModelInfo& i) { return i.paper_layout ? i.paper_layout->ToJson() : nlohmann::json(); };
  return a.rig == b.rig && a.architecture.input_channels == b.architecture.input_channels &&
         a.observation_groups == b.observation_groups && layout(a) == layout(b);
}

Status CheckGrowable(const CnnArchitecture& from, const CnnArchitecture& to) {
  const int width_divisor = to.width_divisor, narrow_divisor = from.width_divisor;
  if (width_divisor < 1 || width_divisor > narrow_divisor || narrow_divisor % width_divisor != 0) {
    return InvalidArgumentError("width divisor " + std::to_string(width_divisor),
                                "a model of width divisor " + std::to_string(narrow_divisor) +
                                    " widens only to a divisor of it (the same width or wider)");
  }
  if (from.centre_skip && !to.centre_skip) {
    return InvalidArgumentError("centre skip", "a model with one keeps it: without it, it would compute another function");
  }
  return Status::Ok();
}

Status CheckSameNetwork(const CnnModelInfo& a, const CnnModelInfo& b) {
  const CnnArchitecture &x = a.architecture, &y = b.architecture;
  std::vector<std::string> problems;
  if (x.width_divisor != y.width_divisor || x.dropout != y.dropout || x.centre_skip != y.centre_skip) {
    problems.push_back("another architecture (width divisor, dropout or centre skip)");
  }
  if (a.rig != b.rig) {
    problems.push_back("rig '" + b.rig + "' against '" + a.rig + "'");
  } else if (!SameInputLayout(a, b)) {
    problems.push_back("another input layout (input channels, observation groups or paper layout)");
  }
  // Each network learnt on inputs log(1 + L / scale): another scale is another input.
  if (a.radiance_scale != b.radiance_scale) {
    problems.push_back("radiance scale " + std::to_string(b.radiance_scale) + " against " + std::to_string(a.radiance_scale));
  }
  if (problems.empty()) return Status::Ok();
  std::string message = "not the same network as the first model:";
  for (const std::string& problem : problems) message += " " + problem + ";";
  message.back() = '.';
  return InvalidArgumentError("model", message);
}

CnnLabels CnnLabelsFromMaps(const Image& maps) {
  const int width = maps.width(), height = maps.height();
  CnnLabels out{{kLabelSize, height, width, std::vector<float>(static_cast<size_t>(kLabelSize) * width * height)},
                std::vector<uint8_t>(static_cast<size_t>(width) * height)};
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const WardParams<double> params = GetParams(maps, x, y);
      const size_t i = static_cast<size_t>(y) * width + x;
      out.valid[i] = params.n_s.squaredNorm() > 0.5;
      if (!out.valid[i]) continue;
      const Label label = EncodeLabel(params);
      for (int c = 0; c < kLabelSize; ++c) out.labels.values[c * width * height + i] = static_cast<float>(label[c]);
    }
  }
  return out;
}

Image MapsFromLabels(const CnnTensor& labels) {
  Image maps = MakeSvbrdfImage(labels.width, labels.height, /*with_height=*/false);
  for (int y = 0; y < labels.height; ++y) {
    for (int x = 0; x < labels.width; ++x) {
      Label label;
      for (int c = 0; c < kLabelSize; ++c) label[c] = labels.at(c, y, x);
      SetParams(maps, x, y, DecodeLabel(label));
    }
  }
  return maps;
}

Cnn::Cnn(CnnModelInfo info, std::shared_ptr<internal::CnnNetHolder> net) : info_(std::move(info)), net_(std::move(net)) {}

// What needs LibTorch goes to the CNN engine (internal/cnn_engine.h), loaded by the first call.
Result<Cnn> Cnn::Create(const CnnModelInfo& info, uint64_t seed) {
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  return engine->Create(info, seed);
}

Result<Cnn> Cnn::Load(const std::filesystem::path& directory) {
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  return engine->Load(directory);
}

Status Cnn::Save(const std::filesystem::path& directory) const {
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  return engine->Save(*this, directory);
}

Result<Cnn> Cnn::Widened(int width_divisor, uint64_t seed) const {
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  CnnArchitecture wide = info_.architecture;
  wide.width_divisor = width_divisor;
  return engine->Grown(*this, wide, seed);
}

Result<Cnn> Cnn::WithCentreSkip() const {
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  CnnArchitecture with_skip = info_.architecture;
  with_skip.centre_skip = true;
  return engine->Grown(*this, with_skip, 0);
}

Result<Cnn> Cnn::Average(const std::vector<Cnn>& models) {
  if (models.empty()) return InvalidArgumentError("models", "none to average");
  for (size_t i = 1; i < models.size(); ++i) {
    const Status same = CheckSameNetwork(models.front().info(), models[i].info());
    if (!same.ok()) {
      return Status(same.code(), "model " + std::to_string(i + 1) + " of " + std::to_string(models.size()), same.message());
    }
  }
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  return engine->Averaged(models);
}

Status CheckCnnDevice(CnnDevice device) {
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  return engine->CheckTrainingDevice(device);
}

Result<CnnTensor> Cnn::PredictDense(const CnnTensor& input, int max_tile, int threads, CnnDevice device) const {
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  return engine->PredictDense(*this, input, max_tile, threads, device);
}

Result<CnnTensor> Cnn::PredictSliding(const CnnTensor& input, int first, int count, int batch, int threads) const {
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  return engine->PredictSliding(*this, input, first, count, batch, threads);
}

Result<Image> Cnn::PredictMaps(const ObservationStack& stack, int threads, CnnDevice device) const {
  Result<CnnTensor> input = CnnInputFromStack(stack, info_);
  if (!input.ok()) return input.status();
  Result<CnnTensor> labels = PredictDense(*input, kDenseTile, threads, device);
  if (!labels.ok()) return labels.status();
  const Image decoded = MapsFromLabels(*labels);
  Image maps = MakeSvbrdfImage(decoded.width(), decoded.height(), /*with_height=*/true);
  for (int c = 0; c < decoded.num_channels(); ++c) {
    std::copy(decoded.channel(c).begin(), decoded.channel(c).end(),
              maps.channel(*maps.ChannelIndex(decoded.channel_name(c))).begin());
  }
  const auto height = stack.image.channel(2);  // pos.Z
  std::copy(height.begin(), height.end(), maps.channel(*maps.ChannelIndex(kHeightChannel)).begin());
  return maps;
}

}  // namespace loom::fitting
