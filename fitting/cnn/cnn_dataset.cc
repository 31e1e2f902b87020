#include "fitting/cnn/cnn_dataset.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <optional>

#include "core/exr_io.h"
#include "core/parallel.h"
#include "fitting/io/svbrdf_file.h"
#include "fitting/model/label.h"
#include "fitting/model/svbrdf_maps.h"

namespace loom::fitting {

namespace fs = std::filesystem;

namespace {

// NAME.truth.exr, else NAME.truth.axf (an AxF file's SVBRDF, as the paper's dataset keeps its
// labels); nothing when neither exists.
std::optional<fs::path> TruthOf(const fs::path& dir, const std::string& name) {
  for (const char* extension : {".truth.exr", ".truth.axf"}) {
    if (fs::exists(dir / (name + extension))) return dir / (name + extension);
  }
  return std::nullopt;
}

}  // namespace

Result<CnnDataset> CnnDataset::Open(const fs::path& dir, int validation, int test) {
  if (!fs::is_directory(dir)) return NotFoundError(dir.string(), "no such dataset directory");
  std::vector<Pair> pairs;
  constexpr std::string_view kStack = ".stack.exr";
  for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
    const std::string file = entry.path().filename().string();
    if (file.size() <= kStack.size() || !file.ends_with(kStack)) continue;
    const std::string name = file.substr(0, file.size() - kStack.size());
    const std::optional<fs::path> truth = TruthOf(dir, name);
    if (!truth) {
      return NotFoundError((dir / (name + ".truth.exr")).string(),
                           "the reference maps of " + entry.path().string() + " (nor " + name + ".truth.axf)");
    }
    pairs.push_back({entry.path(), *truth});
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.stack < b.stack; });
  if (validation < 1 || test < 1 || static_cast<int>(pairs.size()) <= validation + test) {
    return FailedPreconditionError(dir.string(), std::to_string(pairs.size()) + " materials, too few for " +
                                                     std::to_string(validation) + " validation and " + std::to_string(test) +
                                                     " test materials and at least one to train on");
  }
  return CnnDataset(std::move(pairs), validation, test);
}

Result<std::shared_ptr<const ObservationStack>> CnnDataset::Stack(int i) const {
  LOOM_ASSIGN_OR_RETURN(ObservationStack stack, ReadObservationStack(pairs_[static_cast<size_t>(i)].stack));
  return std::make_shared<const ObservationStack>(std::move(stack));
}

Result<CnnModelInfo> CnnDataset::ModelInfo(const CnnArchitecture& architecture, int max_stacks, CnnInputKind input) const {
  CnnModelInfo info;
  info.architecture = architecture;
  std::vector<float> values;
  int fewest_linear = std::numeric_limits<int>::max();
  for (int i = 0; i < std::min(train_count(), std::max(max_stacks, 1)); ++i) {
    LOOM_ASSIGN_OR_RETURN(const std::shared_ptr<const ObservationStack> stack, Stack(i));
    if (i == 0) {
      info.architecture.input_channels = kCnnGeometryChannels + static_cast<int>(stack->observations.size());
      info.rig = stack->rig;
      for (const StackObservation& o : stack->observations) info.observation_groups.push_back(o.group);
    }
    if (input == CnnInputKind::kPaperLayout) {
      const int linear =
          static_cast<int>(std::count_if(stack->observations.begin(), stack->observations.end(),
                                         [](const StackObservation& o) { return o.group == ObservationGroup::kLinearLight; }));
      if (linear < fewest_linear) {
        LOOM_ASSIGN_OR_RETURN(info.paper_layout, PaperLayoutOf(*stack));
        fewest_linear = linear;
      }
    }
    for (int c = kStackGeometryChannels; c < stack->image.num_channels(); c += 7) {  // a sample of the channels
      for (float v : stack->image.channel(c)) {
        if (std::isfinite(v) && v > 0) values.push_back(v);
      }
    }
  }
  if (info.paper_layout) {
    info.observation_groups.clear();
    info.architecture.input_channels = info.paper_layout->Channels();
  }
  info.radiance_scale = 1;
  if (!values.empty()) {
    std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
    info.radiance_scale = values[values.size() / 2];
  }
  return info;
}

Result<CnnExample> CnnDataset::Example(int i, const CnnModelInfo& info, bool keep_stack) const {
  LOOM_ASSIGN_OR_RETURN(std::shared_ptr<const ObservationStack> stack, Stack(i));
  const fs::path& truth_path = pairs_[static_cast<size_t>(i)].truth;
  LOOM_ASSIGN_OR_RETURN(const SvbrdfFile truth, ReadSvbrdf(truth_path));
  if (truth.maps.width() != stack->image.width() || truth.maps.height() != stack->image.height()) {
    return InvalidArgumentError(truth_path.string(), "not on the grid of its stack " + stack->source);
  }
  Result<CnnTensor> input = CnnInputFromStack(*stack, info);
  if (!input.ok()) {  // the stack's own name ("sim fast path") does not say which file it is
    const Status& why = input.status();
    return Status(why.code(), pairs_[static_cast<size_t>(i)].stack.string(), why.subject() + ": " + why.message());
  }
  return CnnExample{truth_path.string(), std::move(*input), CnnLabelsFromMaps(truth.maps),
                    keep_stack ? std::move(stack) : nullptr};
}

Result<Cnn> StartingCnn(const CnnModelInfo& info, const std::string& init, uint64_t seed) {
  if (init.empty()) return Cnn::Create(info, seed);
  LOOM_ASSIGN_OR_RETURN(Cnn cnn, Cnn::Load(init));
  // Training's checkpoints keep full precision, whatever storage the start came in.
  cnn.mutable_info().weights = WeightStorage::kFloat32;
  if (!SameInputLayout(cnn.info(), info)) {
    return InvalidArgumentError(init, "a model for other stacks (rig '" + cnn.info().rig + "', " +
                                          std::to_string(cnn.info().architecture.input_channels) +
                                          " input channels) than the dataset's ('" + info.rig + "', " +
                                          std::to_string(info.architecture.input_channels) + ")");
  }
  const int divisor = info.architecture.width_divisor;
  if (divisor != 0 && divisor != cnn.info().architecture.width_divisor) {
    Result<Cnn> wide = cnn.Widened(divisor, seed);
    if (!wide.ok()) return InvalidArgumentError(init, wide.status().subject() + ": " + wide.status().message());
    cnn = std::move(*wide);
  }
  if (!info.architecture.centre_skip || cnn.info().architecture.centre_skip) return cnn;
  return cnn.WithCentreSkip();
}

namespace {

// The radiance scale is a median: 64 stacks measure it as well as all of them.
constexpr int kNormalisationStacks = 64;

// Read on `threads` threads (a material's EXR decode and input layout take ~0.25 s: a thousand
// of them, minutes on one core); the first error in the dataset's order is the one returned.
Result<std::vector<CnnExample>> ReadExamples(const CnnDataset& dataset, int first, int count, const CnnModelInfo& info,
                                             bool keep_stacks, int threads) {
  std::vector<std::optional<Result<CnnExample>>> read(static_cast<size_t>(count));
  ParallelFor(count, threads, [&](int i) { read[static_cast<size_t>(i)] = dataset.Example(first + i, info, keep_stacks); });
  std::vector<CnnExample> examples;
  for (std::optional<Result<CnnExample>>& e : read) {
    if (!e->ok()) return e->status();
    examples.push_back(std::move(**e));
  }
  return examples;
}

}  // namespace

Result<CnnDatasetTraining> TrainOnDataset(const CnnDataset& dataset, const CnnArchitecture& architecture, const std::string& init,
                                          const CnnTrainingOptions& options, CnnInputKind input) {
  LOOM_RETURN_IF_ERROR(options.Check());
  if (options.checkpoint_dir.empty()) {
    return InvalidArgumentError("CnnTrainingOptions.checkpoint_dir", "is needed: the kept epoch is reloaded from it");
  }
  CnnDatasetTraining run;
  run.train_materials = dataset.train_count();
  run.validation_materials = dataset.validation_count();
  run.test_materials = dataset.test_count();
  run.streamed = options.resident_materials > 0 && options.resident_materials < run.train_materials;
  LOOM_ASSIGN_OR_RETURN(const CnnModelInfo new_info, dataset.ModelInfo(architecture, kNormalisationStacks, input));
  LOOM_ASSIGN_OR_RETURN(Cnn cnn, StartingCnn(new_info, init, options.seed));
  const CnnModelInfo info = cnn.info();
  const bool keep_stacks = options.rerender_weight > 0;
  // The trainer reads the training materials through this (all at once, or a window at a time
  // when streamed) and keeps them as its own tensors: holding the examples here as well doubled
  // what a resident training set took.
  const CnnExampleSource source{run.train_materials, [&](int i) { return dataset.Example(i, info, keep_stacks); }};
  LOOM_ASSIGN_OR_RETURN(const std::vector<CnnExample> validation,
                        ReadExamples(dataset, run.train_materials, run.validation_materials, info, keep_stacks, options.threads));
  LOOM_ASSIGN_OR_RETURN(const std::vector<CnnExample> test, ReadExamples(dataset, run.train_materials + run.validation_materials,
                                                                         run.test_materials, info, keep_stacks, options.threads));
  LOOM_ASSIGN_OR_RETURN(run.history, TrainCnn(cnn, source, validation, options));
  run.kept = KeptEpoch(run.history);
  LOOM_ASSIGN_OR_RETURN(run.model, Cnn::Load(options.checkpoint_dir / "best"));
  LOOM_ASSIGN_OR_RETURN(run.test, ScoreCnn(*run.model, test, options.threads));
  return run;
}

Result<CnnHeldOutScore> ScoreOnHeldOut(const Cnn& cnn, const CnnDataset& dataset, int threads) {
  const int first_validation = dataset.train_count();
  const int first_test = first_validation + dataset.validation_count();
  CnnHeldOutScore score;
  // With their stacks: the score's re-rendering loss needs them.
  LOOM_ASSIGN_OR_RETURN(const std::vector<CnnExample> validation,
                        ReadExamples(dataset, first_validation, dataset.validation_count(), cnn.info(), true, threads));
  LOOM_ASSIGN_OR_RETURN(score.validation, ScoreCnn(cnn, validation, threads));
  LOOM_ASSIGN_OR_RETURN(const std::vector<CnnExample> test,
                        ReadExamples(dataset, first_test, dataset.test_count(), cnn.info(), true, threads));
  LOOM_ASSIGN_OR_RETURN(score.test, ScoreCnn(cnn, test, threads));
  return score;
}

nlohmann::json CnnScoreJson(const CnnScore& score) {
  nlohmann::json json = {{"loss", score.loss}, {"rmse", score.rmse}, {"pixels", score.pixels}};
  if (score.rerender_loss > 0) json["rerender_loss"] = score.rerender_loss;  // scored with the stacks
  json["angle_rmse_where_anisotropic"] = score.angle_rmse_where_anisotropic;
  json["anisotropic_pixels"] = score.anisotropic_pixels;
  return json;
}

void ReportRmsePerChannel(std::ostream& out, const CnnScore& score) {
  out << std::fixed << std::setprecision(3);
  for (int c = 0; c < kLabelSize; ++c) out << (c == 0 ? "" : "  ") << kLabelChannelNames[c] << " " << score.rmse[c];
  out << "\n   where the true lobe is anisotropic (" << std::setprecision(1)
      << 100.0 * static_cast<double>(score.anisotropic_pixels) / static_cast<double>(std::max<int64_t>(score.pixels, 1))
      << " % of the pixels): cos2alpha " << std::setprecision(3) << score.angle_rmse_where_anisotropic[0] << "  sin2alpha "
      << score.angle_rmse_where_anisotropic[1] << std::defaultfloat;
}

nlohmann::json CnnDatasetTraining::ToJson() const {
  return {{"epochs", nlohmann::json::parse(CnnHistoryJson(history))},
          {"kept_epoch", kept.epoch},
          {"test", CnnScoreJson(test)},
          {"label_channels", kLabelChannelNames},
          {"materials", {{"train", train_materials}, {"validation", validation_materials}, {"test", test_materials}}}};
}

void CnnDatasetTraining::Report(std::ostream& out) const {
  for (const CnnEpoch& e : history) {
    out << std::setprecision(4) << "epoch " << e.epoch << ": lr " << e.learning_rate << ", train " << e.train_loss
        << ", validation " << e.validation_loss;
    if (e.validation_rerender_loss > 0) out << " + re-rendering " << e.validation_rerender_loss;
    out << " (" << std::fixed << std::setprecision(0) << e.samples_per_second << " samples/s)" << std::defaultfloat << "\n";
  }
  out << std::setprecision(4) << "kept epoch " << kept.epoch << " (lowest validation "
      << (kept.validation_rerender_loss > 0 ? "objective " : "loss ") << kept.validation_objective << ")\ntest loss "
      << test.loss;
  if (test.rerender_loss > 0) out << " + re-rendering " << test.rerender_loss;
  out << " on " << test_materials << " materials; RMSE per label channel:\n   ";
  ReportRmsePerChannel(out, test);
  out << "\n";
}

}  // namespace loom::fitting
