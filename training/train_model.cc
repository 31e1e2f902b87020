#include "training/train_model.h"

#include <algorithm>
#include <ostream>
#include <sstream>

#include "core/file_io.h"
#include "core/version.h"
#include "fitting/cnn/cnn.h"
#include "sim/scan_emulation.h"

namespace loom::training {
namespace {

namespace fs = std::filesystem;

// The network's width divisor: the one asked for; without it 8 for a new model and the init
// model's own (0) for a fine-tuned one, which a given divisor widens (fitting::Cnn::Widened).
int WidthDivisor(const TrainRequest& request) {
  if (request.width_divisor > 0) return request.width_divisor;
  return request.init.empty() ? 8 : 0;
}

std::vector<std::string> Names(const std::vector<sim::TrainingPreset>& presets) {
  std::vector<std::string> names;
  for (const sim::TrainingPreset& preset : presets) names.push_back(preset.name);
  return names;
}

std::string Joined(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ",") + name;
  return text;
}

// What the dataset's stacks are and where the model came from, kept in model.json.
std::string TrainingDescription(const TrainRequest& request, const fitting::CnnDatasetTraining& run) {
  std::ostringstream text;
  text << "epoch " << run.kept.epoch << " (lowest validation "
       << (run.kept.validation_rerender_loss > 0 ? "objective, " : "loss, ") << run.kept.validation_objective << ") of "
       << run.history.size() << " epochs on " << run.train_materials << " simulated fabrics (" << request.dataset.size_px
       << " px, seeds " << request.dataset.first_seed << "…, out-of-model share " << request.dataset.out_of_model_share
       << ", scan-like share " << request.dataset.scan_like_share << "), preset " << Joined(Names(request.presets))
       << (request.init.empty() ? "" : ", from " + request.init.string())
       << (request.init.empty() || request.width_divisor == 0 ? "" : " at width divisor " + std::to_string(request.width_divisor))
       << (run.model->info().architecture.centre_skip ? ", with the centre skip" : "") << "; test loss " << run.test.loss
       << " on " << run.test_materials << " held-out fabrics; loom " << VersionWithCommit();
  return text.str();
}

Status CheckInit(const TrainRequest& request) {
  LOOM_ASSIGN_OR_RETURN(const fitting::Cnn init, fitting::Cnn::Load(request.init));
  const fitting::CnnArchitecture& from = init.info().architecture;  // a centre skip it has, it keeps
  const int divisor = WidthDivisor(request) == 0 ? from.width_divisor : WidthDivisor(request);
  const Status growable = fitting::CheckGrowable(from, {0, divisor, request.dropout, request.centre_skip || from.centre_skip});
  if (!growable.ok()) return InvalidArgumentError(request.init.string(), growable.subject() + ": " + growable.message());
  return Status::Ok();
}

Status CheckDataset(TrainRequest& request) {
  const std::string presets = Joined(Names(request.presets));
  if (request.presets.empty()) return InvalidArgumentError("--preset", "a preset name, or several separated by commas");
  if (request.presets.size() > 1 && request.input_layout != "paper") {
    return InvalidArgumentError("--preset " + presets,
                                "several presets make stacks of different observations: they need --input-layout paper");
  }
  if (request.validation + request.test >= request.dataset.materials) {
    return InvalidArgumentError("--validation/--test", "leave at least one of the --materials " +
                                                           std::to_string(request.dataset.materials) + " for training");
  }
  if (!request.scan_emulation.empty() && !(request.dataset.scan_like_share > 0)) {
    return InvalidArgumentError("--scan-emulation " + request.scan_emulation.string(), "is used only with --scan-like-share > 0");
  }
  if (!request.init.empty()) LOOM_RETURN_IF_ERROR(CheckInit(request));
  if (request.dataset.scan_like_share > 0) {
    if (request.scan_emulation.empty()) return InvalidArgumentError("--scan-like-share", "needs --scan-emulation FILE");
    LOOM_ASSIGN_OR_RETURN(request.dataset.scan_emulation, sim::LoadScanEmulation(request.scan_emulation));
  }
  return Status::Ok();
}

// Everything checked before the dataset's minutes of rendering.
Status CheckRequest(TrainRequest& request) {
  LOOM_RETURN_IF_ERROR(CheckDirectoryOutputPath(request.out, "--out"));
  if (request.data.empty()) {
    request.data = request.out / "data";
  } else {
    LOOM_RETURN_IF_ERROR(CheckDirectoryOutputPath(request.data, "--data"));
  }
  LOOM_RETURN_IF_ERROR(CheckDataset(request));
  request.dataset.threads = request.training.threads;
  request.training.device =
      request.device == "cuda" ? fitting::CnnTrainingOptions::Device::kCuda : fitting::CnnTrainingOptions::Device::kCpu;
  LOOM_RETURN_IF_ERROR(fitting::CheckTrainingDevice(request.training.device).WithContext("--device " + request.device));
  request.training.checkpoint_dir = request.out / "checkpoints";
  return request.training.Check();
}

nlohmann::json TrainingJson(const TrainRequest& request, const fitting::CnnDatasetTraining& run) {
  const fitting::CnnArchitecture& architecture = run.model->info().architecture;
  nlohmann::json report = run.ToJson();
  report["options"] = request.training.ToJson();
  report["options"].update(request.dataset.ToJson());
  report["options"].update({{"width_divisor", architecture.width_divisor},
                            {"centre_skip", architecture.centre_skip},
                            {"presets", Names(request.presets)},
                            {"input_layout", request.input_layout},
                            {"dropout", request.dropout},
                            {"weights", request.weights},
                            {"init", request.init.string()},
                            {"scan_emulation_file", request.scan_emulation.string()}});
  report["loom_version"] = std::string(VersionWithCommit());
  return report;
}

}  // namespace

Result<std::vector<std::string>> PresetNames(const std::string& presets) {
  std::vector<std::string> names;
  std::stringstream list(presets);
  for (std::string name; std::getline(list, name, ',');) names.push_back(name);
  if (names.empty() || std::find(names.begin(), names.end(), "") != names.end()) {
    return InvalidArgumentError("--preset " + presets, "a preset name, or several separated by commas");
  }
  return names;
}

Result<TrainedModel> TrainModel(TrainRequest request) {
  LOOM_RETURN_IF_ERROR(CheckRequest(request));
  LOOM_RETURN_IF_ERROR(
      sim::RenderTrainingDataset({request.rig, request.presets, request.dataset, request.training.resident_materials},
                                 request.data, request.dataset_progress));
  LOOM_ASSIGN_OR_RETURN(const fitting::CnnDataset dataset,
                        fitting::CnnDataset::Open(request.data, request.validation, request.test));
  const fitting::CnnInputKind input =
      request.input_layout == "paper" ? fitting::CnnInputKind::kPaperLayout : fitting::CnnInputKind::kStackObservations;
  TrainedModel trained;
  trained.out = request.out;
  trained.data = request.data;
  trained.resident_materials = request.training.resident_materials;
  LOOM_ASSIGN_OR_RETURN(trained.run,
                        fitting::TrainOnDataset(dataset, {0, WidthDivisor(request), request.dropout, request.centre_skip},
                                                request.init.string(), request.training, input));
  fitting::Cnn& cnn = *trained.run.model;
  cnn.mutable_info().training = TrainingDescription(request, trained.run);
  cnn.mutable_info().weights = *fitting::WeightStorageFromName(request.weights);
  LOOM_RETURN_IF_ERROR(cnn.Save(request.out));
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(request.out / "training.json", TrainingJson(request, trained.run).dump(2) + "\n"));
  return trained;
}

void TrainedModel::Report(std::ostream& out) const {
  const fitting::Cnn& cnn = *run.model;
  out << "dataset " << data.string() << ": " << run.train_materials << " training"
      << (run.streamed ? " (read " + std::to_string(resident_materials) + " at a time)" : "") << ", " << run.validation_materials
      << " validation, " << run.test_materials << " test materials; " << cnn.info().architecture.input_channels
      << " input channels; radiance scale " << cnn.info().radiance_scale << "\n";
  run.Report(out);
  out << "wrote " << this->out.string() << "/model.json, weights.pt and training.json\n";
}

}  // namespace loom::training
