#include "fitting/cnn/model_directory.h"

#include <iomanip>
#include <map>
#include <ostream>
#include <string>
#include <system_error>

#include "core/output_directory.h"
#include "fitting/cnn/cnn_training.h"

namespace loom::fitting {
namespace {

std::string GroupCounts(const std::vector<ObservationGroup>& groups) {
  std::map<std::string, int> counts;
  for (ObservationGroup g : groups) ++counts[std::string(ObservationGroupName(g))];
  std::string text;
  for (const auto& [name, count] : counts) text += (text.empty() ? "" : ", ") + std::to_string(count) + " " + name;
  return text;
}

void ReportScore(std::ostream& out, const std::string& set, int materials, const CnnScore& score) {
  out << std::setprecision(4) << set << " loss " << score.loss << ", re-rendering loss " << score.rerender_loss << " on "
      << materials << " materials (" << score.pixels << " pixels); RMSE per label channel:\n   ";
  ReportRmsePerChannel(out, score);
  out << "\n";
}

}  // namespace

void DescribeModel(const std::filesystem::path& dir, const CnnModelInfo& info, std::ostream& out) {
  const CnnArchitecture& a = info.architecture;
  const std::array<int, 4> w = a.HiddenWidths();
  out << "model " << dir.string() << "\n"
      << "  rig " << info.rig << ", " << a.input_channels << " input channels; "
      << (info.paper_layout ? "the paper's layout (every preset of the rig)"
                            : "observations: " + GroupCounts(info.observation_groups))
      << "\n"
      << "  width divisor " << a.width_divisor << " (" << w[0] << ", " << w[1] << ", " << w[2] << ", " << w[3] << " features), "
      << std::setprecision(3) << a.WeightCount() / 1e6 << " M weights, " << a.DenseFlopsPerPixel() / 1e6
      << " MFLOP per pixel, dropout " << a.dropout << (a.centre_skip ? ", centre skip" : "") << "\n"
      << "  weights " << WeightStorageName(info.weights) << ", " << std::setprecision(4)
      << std::filesystem::file_size(dir / "weights.pt") / 1e6 << " MB; radiance scale " << info.radiance_scale << "\n"
      << "  training: " << (info.training.empty() ? "(not described)" : info.training) << "\n";
}

Result<ModelScore> ScoreModel(const std::filesystem::path& model, const std::filesystem::path& dataset, int validation, int test,
                              int threads) {
  LOOM_ASSIGN_OR_RETURN(const Cnn cnn, Cnn::Load(model));
  LOOM_ASSIGN_OR_RETURN(const CnnDataset data, CnnDataset::Open(dataset, validation, test));
  LOOM_ASSIGN_OR_RETURN(const CnnHeldOutScore score, ScoreOnHeldOut(cnn, data, threads));
  return ModelScore{model, dataset, data.train_count(), data.validation_count(), data.test_count(), score};
}

void ModelScore::Report(std::ostream& out) const {
  out << "model " << model.string() << " on dataset " << dataset.string() << " (" << train << " training, " << validation
      << " validation, " << test << " test materials)\n";
  ReportScore(out, "validation", validation, score.validation);
  ReportScore(out, "test", test, score.test);
}

nlohmann::json ModelScore::ToJson() const {
  return {{"model", model.string()},
          {"dataset", dataset.string()},
          {"materials", {{"train", train}, {"validation", validation}, {"test", test}}},
          {"label_channels", kLabelChannelNames},
          {"validation", CnnScoreJson(score.validation)},
          {"test", CnnScoreJson(score.test)}};
}

namespace {

namespace fs = std::filesystem;

// Refuses an output folder that is one of the models it is made from: they stay as they are.
Status CheckNotAnInput(const fs::path& to, const std::vector<fs::path>& inputs) {
  std::error_code error;
  for (const fs::path& input : inputs) {
    if (fs::exists(to) && fs::equivalent(input, to, error)) {
      const std::string which = inputs.size() == 1 ? "the model itself" : input.string() + ", a model it averages";
      return InvalidArgumentError(to.string(), "is " + which + ": write into another folder, the original stays");
    }
  }
  return Status::Ok();
}

// `cnn` saved in `to` (its info's weight storage), with the regular files beside the model `from`.
Status WriteModel(const Cnn& cnn, const fs::path& from, const fs::path& to) {
  LOOM_ASSIGN_OR_RETURN(OutputDirectory out, OutputDirectory::Create(to, "--out"));
  LOOM_RETURN_IF_ERROR(cnn.Save(out.partial()));
  std::error_code error;
  for (const fs::directory_entry& entry : fs::directory_iterator(from)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_regular_file() || name == "model.json" || name == "weights.pt") continue;
    fs::copy_file(entry.path(), out.partial() / name, error);
    if (error) return IoError((to / name).string(), "cannot copy " + entry.path().string() + ": " + error.message());
  }
  return out.Commit();
}

}  // namespace

Status ConvertModel(const fs::path& from, const fs::path& to, WeightStorage storage) {
  LOOM_RETURN_IF_ERROR(CheckNotAnInput(to, {from}));
  LOOM_ASSIGN_OR_RETURN(Cnn cnn, Cnn::Load(from));
  cnn.mutable_info().weights = storage;
  return WriteModel(cnn, from, to);
}

Status AverageModels(const std::vector<fs::path>& models, const fs::path& to, WeightStorage storage) {
  if (models.empty()) return InvalidArgumentError("model average", "needs at least one model");
  LOOM_RETURN_IF_ERROR(CheckNotAnInput(to, models));
  std::vector<Cnn> loaded;
  std::string names;
  for (const fs::path& model : models) {
    LOOM_ASSIGN_OR_RETURN(Cnn cnn, Cnn::Load(model));
    if (!loaded.empty()) {
      const Status same = CheckSameNetwork(loaded.front().info(), cnn.info());
      if (!same.ok()) return Status(same.code(), model.string(), same.message());
    }
    loaded.push_back(std::move(cnn));
    names += (names.empty() ? "" : ", ") + model.string();
  }
  LOOM_ASSIGN_OR_RETURN(Cnn mean, Cnn::Average(loaded));
  mean.mutable_info().weights = storage;
  mean.mutable_info().training = "the uniform average of the weights of " + std::to_string(loaded.size()) + " models (" + names +
                                 "); the first's training: " + loaded.front().info().training;
  return WriteModel(mean, models.front(), to);
}

}  // namespace loom::fitting
