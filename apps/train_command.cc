// loom train: a CNN for one rig and gloss preset, trained on simulated materials.
//
//   loom train --rig configs/rig/tac7-mini.yaml --preset low --out MODEL [--data DIR] ...
//
// 1. The dataset in DIR: the procedural fabrics of --materials rendered with the simulator's fast
//    path where missing (sim/training_set.h), split by material (fitting/cnn/cnn_dataset.h).
// 2. Training (fitting/cnn/cnn_training.h) with checkpoints in MODEL/checkpoints; --resume goes on
//    from the last one; --init starts from another model's weights (fine-tuning) instead of
//    random ones; --rerender-weight adds the re-rendering loss.
// 3. MODEL/model.json + weights.pt (loom fit --model MODEL) and MODEL/training.json: every
//    epoch, the options it was trained with, the test set's loss and per-channel RMSE.
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>

#include "apps/command.h"
#include "apps/config_paths.h"
#include "apps/progress.h"
#include "core/file_io.h"
#include "core/version.h"
#include "fitting/cnn/cnn_dataset.h"
#include "fitting/cnn/cnn_training.h"
#include "sim/training_set.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

struct TrainArguments {
  std::string rig;
  std::string preset = "low";
  std::string out;
  std::string data;  // empty: OUT/data
  sim::TrainingSetSpec dataset;
  int validation = 3;
  int test = 3;
  std::string init;                    // a model to start from
  std::string scan_emulation;          // a sim match-scan file, for dataset.scan_like_share
  std::string input_layout = "stack";  // or "paper" (fitting/cnn/cnn_input.h)
  std::string device = "cpu";          // or "cuda"
  int width_divisor = 0;               // 0: 8 for a new model, --init's own
  double dropout = 0.02;
  bool centre_skip = false;
  std::string weights = "float32";  // how MODEL/weights.pt stores them; checkpoints keep float32
  fitting::CnnTrainingOptions training;
  bool quiet = false;
};

// The network's width divisor: --width-divisor; without it 8 for a new model and --init's own
// (0) for a fine-tuned one, which a given divisor widens (fitting::Cnn::Widened).
int WidthDivisor(const TrainArguments& args) {
  if (args.width_divisor > 0) return args.width_divisor;
  return args.init.empty() ? 8 : 0;
}

// --preset's comma-separated names.
std::vector<std::string> PresetNames(const std::string& presets) {
  std::vector<std::string> names;
  std::stringstream list(presets);
  for (std::string name; std::getline(list, name, ',');) names.push_back(name);
  return names;
}

// Renders the fabrics of --materials missing from `dir` (sim/training_set.h), with each preset
// in turn.
Status RenderDataset(const TrainArguments& args, const fs::path& dir) {
  sim::TrainingDatasetRequest request{ResolveRigPath(args.rig), {}, args.dataset, args.training.resident_materials};
  for (const std::string& name : PresetNames(args.preset)) request.presets.push_back({name, ResolvePresetPath(name)});
  ProgressBar bar("dataset", args.quiet);
  return sim::RenderTrainingDataset(
      request, dir, [&](int done, int total, const std::string& name) { bar.Update(done, total, "materials", name); });
}

// What the dataset's stacks are and where the model came from, kept in model.json.
std::string TrainingDescription(const TrainArguments& args, const fitting::CnnDatasetTraining& run) {
  std::ostringstream text;
  text << "epoch " << run.kept.epoch << " (lowest validation "
       << (run.kept.validation_rerender_loss > 0 ? "objective, " : "loss, ") << run.kept.validation_objective << ") of "
       << run.history.size() << " epochs on " << run.train_materials << " simulated fabrics (" << args.dataset.size_px
       << " px, seeds " << args.dataset.first_seed << "…, out-of-model share " << args.dataset.out_of_model_share
       << ", scan-like share " << args.dataset.scan_like_share << "), preset " << args.preset
       << (args.init.empty() ? "" : ", from " + args.init)
       << (args.init.empty() || args.width_divisor == 0 ? "" : " at width divisor " + std::to_string(args.width_divisor))
       << (run.model->info().architecture.centre_skip ? ", with the centre skip" : "") << "; test loss " << run.test.loss
       << " on " << run.test_materials << " held-out fabrics; loom " << VersionWithCommit();
  return text.str();
}

Status CheckDatasetArguments(TrainArguments& args) {
  const std::vector<std::string> presets = PresetNames(args.preset);
  if (presets.empty() || std::find(presets.begin(), presets.end(), "") != presets.end()) {
    return InvalidArgumentError("--preset " + args.preset, "a preset name, or several separated by commas");
  }
  if (presets.size() > 1 && args.input_layout != "paper") {
    return InvalidArgumentError("--preset " + args.preset,
                                "several presets make stacks of different observations: they need --input-layout paper");
  }
  if (args.validation + args.test >= args.dataset.materials) {
    return InvalidArgumentError("--validation/--test", "leave at least one of the --materials " +
                                                           std::to_string(args.dataset.materials) + " for training");
  }
  if (!args.scan_emulation.empty() && !(args.dataset.scan_like_share > 0)) {
    return InvalidArgumentError("--scan-emulation " + args.scan_emulation, "is used only with --scan-like-share > 0");
  }
  if (!args.init.empty()) {  // before the dataset's minutes of rendering
    LOOM_ASSIGN_OR_RETURN(const fitting::Cnn init, fitting::Cnn::Load(args.init));
    const fitting::CnnArchitecture& from = init.info().architecture;  // a centre skip it has, it keeps
    const int divisor = WidthDivisor(args) == 0 ? from.width_divisor : WidthDivisor(args);
    const Status growable = fitting::CheckGrowable(from, {0, divisor, args.dropout, args.centre_skip || from.centre_skip});
    if (!growable.ok()) return InvalidArgumentError(args.init, growable.subject() + ": " + growable.message());
  }
  if (args.dataset.scan_like_share > 0) {
    if (args.scan_emulation.empty()) return InvalidArgumentError("--scan-like-share", "needs --scan-emulation FILE");
    LOOM_ASSIGN_OR_RETURN(args.dataset.scan_emulation, sim::LoadScanEmulation(args.scan_emulation));
  }
  return Status::Ok();
}

Status Train(TrainArguments args) {
  const fs::path out(args.out);
  const fs::path data = args.data.empty() ? out / "data" : fs::path(args.data);
  LOOM_RETURN_IF_ERROR(CheckDirectoryOutputPath(out, "--out"));
  if (!args.data.empty()) LOOM_RETURN_IF_ERROR(CheckDirectoryOutputPath(data, "--data"));
  LOOM_RETURN_IF_ERROR(CheckDatasetArguments(args));
  args.dataset.threads = args.training.threads;
  args.training.device =
      args.device == "cuda" ? fitting::CnnTrainingOptions::Device::kCuda : fitting::CnnTrainingOptions::Device::kCpu;
  LOOM_RETURN_IF_ERROR(fitting::CheckTrainingDevice(args.training.device).WithContext("--device " + args.device));
  args.training.checkpoint_dir = out / "checkpoints";
  LOOM_RETURN_IF_ERROR(args.training.Check());  // before the dataset's minutes of rendering
  LOOM_RETURN_IF_ERROR(RenderDataset(args, data));
  LOOM_ASSIGN_OR_RETURN(const fitting::CnnDataset dataset, fitting::CnnDataset::Open(data, args.validation, args.test));
  ProgressBar bar("training", args.quiet);
  args.training.progress = [&](const fitting::CnnTrainingProgress& p) {
    std::ostringstream detail;
    detail << "epoch " << p.epoch << "/" << p.epochs << ", loss " << std::setprecision(4) << p.loss;
    bar.Update(static_cast<int64_t>(p.epoch - 1) * p.steps + p.step, static_cast<int64_t>(p.epochs) * p.steps, "steps",
               detail.str());
  };
  LOOM_ASSIGN_OR_RETURN(
      fitting::CnnDatasetTraining run,
      fitting::TrainOnDataset(
          dataset, {0, WidthDivisor(args), args.dropout, args.centre_skip}, args.init, args.training,
          args.input_layout == "paper" ? fitting::CnnInputKind::kPaperLayout : fitting::CnnInputKind::kStackObservations));
  fitting::Cnn& cnn = *run.model;
  std::cout << "dataset " << data.string() << ": " << run.train_materials << " training"
            << (run.streamed ? " (read " + std::to_string(args.training.resident_materials) + " at a time)" : "") << ", "
            << run.validation_materials << " validation, " << run.test_materials << " test materials; "
            << cnn.info().architecture.input_channels << " input channels; radiance scale " << cnn.info().radiance_scale << "\n";
  run.Report(std::cout);
  cnn.mutable_info().training = TrainingDescription(args, run);
  cnn.mutable_info().weights = *fitting::WeightStorageFromName(args.weights);
  LOOM_RETURN_IF_ERROR(cnn.Save(out));
  nlohmann::json report = run.ToJson();
  report["options"] = args.training.ToJson();
  report["options"].update(args.dataset.ToJson());
  report["options"].update({{"width_divisor", cnn.info().architecture.width_divisor},
                            {"centre_skip", cnn.info().architecture.centre_skip},
                            {"presets", PresetNames(args.preset)},
                            {"input_layout", args.input_layout},
                            {"dropout", args.dropout},
                            {"weights", args.weights},
                            {"init", args.init},
                            {"scan_emulation_file", args.scan_emulation}});
  report["loom_version"] = std::string(VersionWithCommit());
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(out / "training.json", report.dump(2) + "\n"));
  std::cout << "wrote " << out.string() << "/model.json, weights.pt and training.json\n";
  return Status::Ok();
}

}  // namespace

int RunTrain(int argc, char** argv) {
  CLI::App app("Train the SVBRDF CNN for a rig and gloss preset on simulated materials", "loom train");
  AddCommonOptions(app);
  TrainArguments args;
  fitting::CnnTrainingOptions& t = args.training;
  app.add_option("--rig", args.rig, "Simulated rig YAML (its geometry renders the dataset), or its name in configs/rig/")
      ->required();
  app.add_option("--preset", args.preset,
                 "Gloss preset whose material plan makes the observations; several separated by commas (low,medium,high) "
                 "take turns by material and need --input-layout paper");
  app.add_option("--input-layout", args.input_layout,
                 "stack: the dataset's observations as they are (one preset); paper: the paper's layout, the same input "
                 "for every preset, linear-light sweeps resampled to the coarsest one's positions (fitting/cnn/cnn_input.h)")
      ->check(CLI::IsMember({"stack", "paper"}));
  app.add_option("--out", args.out, "Model directory: model.json, weights.pt, training.json, checkpoints/")->required();
  app.add_option("--data", args.data, "Dataset directory (default OUT/data): NAME.stack.exr + NAME.truth.exr pairs");
  app.add_option("--materials", args.dataset.materials, "Procedural fabrics to render into the dataset")
      ->check(CLI::Range(3, 100000));
  app.add_option("--validation", args.validation, "Materials held out for validation")->check(CLI::Range(1, 100000));
  app.add_option("--test", args.test, "Materials held out for the final test")->check(CLI::Range(1, 100000));
  app.add_option("--size", args.dataset.size_px, "Material size in pixels (square)")->check(CLI::Range(16, 4096));
  app.add_option("--first-seed", args.dataset.first_seed,
                 "Seed of the first fabric (the main job's fabric:1 is not among the defaults)");
  app.add_option("--width-divisor", args.width_divisor,
                 "Network width: the paper's divided by this (1, 2, 4, 8, ...; default 8, or --init's, which a smaller "
                 "divisor widens: the same function, more units to train)")
      ->check(CLI::Range(1, 256));
  app.add_option("--dropout", args.dropout, "Dropout before the last layer")->check(CLI::Range(0.0, 0.9));
  app.add_flag("--centre-skip", args.centre_skip,
               "Add a linear readout of each pixel's own features to its label (loom's, not the paper's; added to an "
               "--init model as zeros: the same function to start from)");
  app.add_option("--weights", args.weights,
                 "How OUT/weights.pt stores the trained weights: float32, or float16 (half the file, for a model kept in "
                 "git; checkpoints stay float32; loom model converts a trained model)")
      ->check(CLI::IsMember({"float32", "float16"}));
  app.add_option("--epochs", t.epochs, "Epochs")->check(CLI::Range(1, 100000));
  app.add_option("--tile", t.tile, "Output pixels per training tile side")->check(CLI::Range(1, 1024));
  app.add_option("--tiles-per-step", t.tiles_per_step, "Tiles per Adam step")->check(CLI::Range(1, 1024));
  app.add_option("--steps-per-epoch", t.steps_per_epoch, "Steps per epoch (0: cover the training pixels once)")
      ->check(CLI::Range(0, 100000000));
  app.add_option("--lr-start", t.learning_rate_start, "Learning rate at the first epoch")->check(CLI::PositiveNumber);
  app.add_option("--lr-end", t.learning_rate_end, "Learning rate at the last epoch (exponential decay)")
      ->check(CLI::PositiveNumber);
  app.add_option("--weight-decay", t.weight_decay, "Adam weight decay")->check(CLI::NonNegativeNumber);
  app.add_option("--radiance-noise", t.radiance_noise,
                 "Relative noise multiplied into the training tiles' radiance, as reconstructed stacks carry (0: none)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--out-of-model-share", args.dataset.out_of_model_share,
                 "Share of the fabrics made out of model: with what GD10 cannot represent (sim/fabric.h)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--scan-like-share", args.dataset.scan_like_share,
                 "Share of the fabrics degraded as a scan's reconstruction would be (needs --scan-emulation)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--scan-emulation", args.scan_emulation,
                 "How scans degrade the fast path on this rig: a loom sim match-scan --out file (sim/scan_emulation.h)")
      ->check(CLI::ExistingFile);
  app.add_option("--init", args.init,
                 "Start from this model (fine-tuning): its weights, architecture (widened by a smaller --width-divisor) and "
                 "input normalisation")
      ->check(CLI::ExistingDirectory);
  app.add_option(
         "--rerender-weight", t.rerender_weight,
         "Weight of the re-rendering loss beside the label loss (0: off; fitting/cnn/cnn_training.h); the kept epoch is then "
         "the one with the lowest sum of both on the validation fabrics")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--alpha-weight", t.alpha_weight,
                 "Weight of the anisotropy angle's (cos 2α, sin 2α) channels in the label loss (the paper's: 1; the "
                 "validation and test losses keep it)")
      ->check(CLI::PositiveNumber);
  app.add_option("--normal-lobe-reference", t.normal_lobe_reference,
                 "Lobe width (rad) below which the shading normal's label error weighs more, by (width / σ_min)² up to "
                 "100 (0: the paper's weight; fitting/cnn/cnn_training.h)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--rerender-pixels", t.rerender_pixels, "Pixels per tile the re-rendering loss renders")
      ->check(CLI::Range(1, 100000));
  app.add_option("--rerender-lobe-reference", t.rerender_lobe_reference,
                 "Lobe width (rad) below which the re-rendering loss draws a pixel more often, by (width / σ_min)² up "
                 "to 100 (0: uniformly; fitting/cnn/cnn_training.h)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--resident-materials", t.resident_materials,
                 "Training materials in memory at once (0: all); fewer stream the dataset from --data, "
                 "a window at a time (needs --steps-per-epoch)")
      ->check(CLI::Range(0, 100000000));
  app.add_option("--threads", t.threads, "Threads that render and read the dataset, and torch's on the cpu (0: one per core)")
      ->check(CLI::Range(0, 1024));
  app.add_option("--device", args.device,
                 "Where the network trains: cpu, or cuda (the first GPU; needs loom built against a CUDA LibTorch, "
                 "docs/gpu-training.md). The dataset is rendered on the CPU either way")
      ->check(CLI::IsMember({"cpu", "cuda"}));
  app.add_option("--seed", t.seed, "Seed of the weights, tiles and dropout");
  app.add_flag("--resume", t.resume, "Go on from OUT/checkpoints (same options as the interrupted run)");
  app.add_flag("--quiet", args.quiet, "No progress output");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  return ExitCode(Train(args));
}

}  // namespace loom::apps
