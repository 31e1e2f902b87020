#include "fitting/cnn/cnn_training.h"

#include <algorithm>
#include <cmath>

#include "fitting/cnn/internal/cnn_engine.h"

namespace loom::fitting {

const std::array<const char*, 14> kLabelChannelNames = {"a_d.R",    "a_d.G",     "a_d.B",     "a_s.R", "a_s.G",
                                                        "a_s.B",    "n_s.X",     "n_s.Y",     "n_s.Z", "sigma_x'",
                                                        "sigma_y'", "cos2alpha", "sin2alpha", "F0"};

namespace {

using Json = nlohmann::json;

Json EpochJson(const CnnEpoch& e) {
  return {{"epoch", e.epoch},
          {"learning_rate", e.learning_rate},
          {"train_loss", e.train_loss},
          {"train_rerender_loss", e.train_rerender_loss},
          {"validation_loss", e.validation_loss},
          {"validation_rerender_loss", e.validation_rerender_loss},
          {"validation_objective", e.validation_objective},
          {"validation_rmse", e.validation_rmse},
          {"seconds", e.seconds},
          {"samples_per_second", e.samples_per_second}};
}

CnnEpoch EpochFromJson(const Json& j) {
  CnnEpoch e;
  e.epoch = j.at("epoch").get<int>();
  e.learning_rate = j.at("learning_rate").get<double>();
  e.train_loss = j.at("train_loss").get<double>();
  e.train_rerender_loss = j.value("train_rerender_loss", 0.0);  // absent in histories before the loss existed
  e.validation_loss = j.at("validation_loss").get<double>();
  // Absent in histories before the objective existed: those runs kept the lowest label loss.
  e.validation_rerender_loss = j.value("validation_rerender_loss", 0.0);
  e.validation_objective = j.value("validation_objective", e.validation_loss);
  e.validation_rmse = j.at("validation_rmse").get<std::array<double, 14>>();
  e.seconds = j.at("seconds").get<double>();
  e.samples_per_second = j.at("samples_per_second").get<double>();
  return e;
}

}  // namespace

const CnnEpoch& KeptEpoch(const std::vector<CnnEpoch>& history) {
  return *std::min_element(history.begin(), history.end(),
                           [](const CnnEpoch& a, const CnnEpoch& b) { return a.validation_objective < b.validation_objective; });
}

std::string CnnHistoryJson(const std::vector<CnnEpoch>& history) {
  Json epochs = Json::array();
  for (const CnnEpoch& e : history) epochs.push_back(EpochJson(e));
  return epochs.dump(1);
}

Result<std::vector<CnnEpoch>> ParseCnnHistory(const std::string& text, const std::string& file) {
  std::vector<CnnEpoch> history;
  try {
    for (const Json& e : Json::parse(text)) history.push_back(EpochFromJson(e));
  } catch (const std::exception& e) {
    return DataLossError(file, std::string("not a training history: ") + e.what());
  }
  return history;
}

nlohmann::json CnnTrainingOptions::ToJson() const {
  return {{"epochs", epochs},
          {"tile", tile},
          {"tiles_per_step", tiles_per_step},
          {"steps_per_epoch", steps_per_epoch},
          {"lr_start", learning_rate_start},
          {"lr_end", learning_rate_end},
          {"weight_decay", weight_decay},
          {"radiance_noise", radiance_noise},
          {"rerender_weight", rerender_weight},
          {"alpha_weight", alpha_weight},
          {"normal_lobe_reference", normal_lobe_reference},
          {"rerender_pixels", rerender_pixels},
          {"rerender_lobe_reference", rerender_lobe_reference},
          {"rerender_strip_samples", rerender_strip_samples},
          {"rerender_huber", rerender_huber},
          {"resident_materials", resident_materials},
          {"device", device == Device::kCuda ? "cuda" : "cpu"},
          {"seed", seed}};
}

Status CnnTrainingOptions::Check() const {
  std::vector<std::string> problems;
  if (epochs < 1) problems.push_back("epochs must be ≥ 1");
  if (tile < 1) problems.push_back("tile must be ≥ 1");
  if (tiles_per_step < 1) problems.push_back("tiles_per_step must be ≥ 1");
  if (steps_per_epoch < 0) problems.push_back("steps_per_epoch must be ≥ 0");
  if (!(learning_rate_start > 0 && learning_rate_start <= 10) || !(learning_rate_end > 0 && learning_rate_end <= 10)) {
    problems.push_back("learning rates must be in (0, 10]");
  }
  if (!(weight_decay >= 0)) problems.push_back("weight_decay must be ≥ 0");
  if (!(radiance_noise >= 0)) problems.push_back("radiance_noise must be ≥ 0");
  if (!(rerender_weight >= 0)) problems.push_back("rerender_weight must be ≥ 0");
  if (!(alpha_weight > 0) || !std::isfinite(alpha_weight)) problems.push_back("alpha_weight must be finite and > 0");
  if (!(normal_lobe_reference >= 0) || !std::isfinite(normal_lobe_reference)) {
    problems.push_back("normal_lobe_reference must be finite and ≥ 0");
  }
  if (rerender_pixels < 1) problems.push_back("rerender_pixels must be ≥ 1");
  if (!(rerender_lobe_reference >= 0) || !std::isfinite(rerender_lobe_reference)) {
    problems.push_back("rerender_lobe_reference must be finite and ≥ 0");
  }
  if (rerender_strip_samples < 0) problems.push_back("rerender_strip_samples must be ≥ 0");
  if (!(rerender_huber > 0)) problems.push_back("rerender_huber must be > 0");
  if (resident_materials < 0) problems.push_back("resident_materials must be ≥ 0");
  if (threads < 0) problems.push_back("threads must be ≥ 0");
  if (resume && checkpoint_dir.empty()) problems.push_back("resume needs a checkpoint_dir");
  return ProblemsStatus("CnnTrainingOptions", problems);
}

// What needs LibTorch goes to the CNN engine (internal/cnn_engine.h), loaded by the first call.
Status CheckTrainingDevice(CnnTrainingOptions::Device device) {
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  return engine->CheckTrainingDevice(device);
}

Result<int> CudaDevices() {
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  return engine->CudaDevices();
}

Result<CnnTensor> WithRadianceNoise(const CnnTensor& input, double relative_sigma, uint64_t seed) {
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  return engine->WithRadianceNoise(input, relative_sigma, seed);
}

Result<CnnScore> ScoreCnn(const Cnn& cnn, const std::vector<CnnExample>& examples, int threads) {
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  return engine->Score(cnn, examples, threads);
}

Result<std::vector<CnnEpoch>> TrainCnn(Cnn& cnn, const std::vector<CnnExample>& train, const std::vector<CnnExample>& validation,
                                       const CnnTrainingOptions& options) {
  const CnnExampleSource source{static_cast<int>(train.size()),
                                [&](int i) -> Result<CnnExample> { return train[static_cast<size_t>(i)]; }};
  return TrainCnn(cnn, source, validation, options);
}

Result<std::vector<CnnEpoch>> TrainCnn(Cnn& cnn, const CnnExampleSource& train, const std::vector<CnnExample>& validation,
                                       const CnnTrainingOptions& options) {
  LOOM_ASSIGN_OR_RETURN(const internal::CnnEngine* engine, internal::BuiltCnnEngine());
  return engine->Train(cnn, train, validation, options);
}

}  // namespace loom::fitting
