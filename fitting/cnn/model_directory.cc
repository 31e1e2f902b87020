#include "fitting/cnn/model_directory.h"

#include <string>
#include <system_error>

#include "core/output_directory.h"

namespace loom::fitting {
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
