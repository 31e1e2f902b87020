// loom train: a CNN for one rig and gloss preset, trained on simulated materials
// (training/train_model.h does the work).
//
//   loom train --rig configs/rig/tac7-mini.yaml --preset low --out MODEL [--data DIR] ...
#include <cstdint>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "apps/command.h"
#include "apps/config_paths.h"
#include "core/progress_bar.h"
#include "training/train_model.h"

namespace loom::apps {
namespace {

struct TrainArguments {
  std::string rig;
  std::string preset = "low";
  training::TrainRequest request;
  bool quiet = false;
};

Status Train(TrainArguments args) {
  training::TrainRequest& request = args.request;
  request.rig = ResolveRigPath(args.rig);
  LOOM_ASSIGN_OR_RETURN(const std::vector<std::string> presets, training::PresetNames(args.preset));
  for (const std::string& name : presets) request.presets.push_back({name, ResolvePresetPath(name)});
  StageProgressBars bars("", args.quiet);
  request.dataset_progress = [&](int done, int total, const std::string& name) {
    bars.Update("dataset", done, total, "materials", name);
  };
  request.training.progress = [&](const fitting::CnnTrainingProgress& p) {
    std::ostringstream detail;
    detail << "epoch " << p.epoch << "/" << p.epochs << ", loss " << std::setprecision(4) << p.loss;
    bars.Update("training", static_cast<int64_t>(p.epoch - 1) * p.steps + p.step, static_cast<int64_t>(p.epochs) * p.steps,
                "steps", detail.str());
  };
  LOOM_ASSIGN_OR_RETURN(const training::TrainedModel trained, training::TrainModel(std::move(request)));
  bars.Close();
  trained.Report(std::cout);
  return Status::Ok();
}

}  // namespace

int RunTrain(int argc, char** argv) {
  CLI::App app("Train the SVBRDF CNN for a rig and gloss preset on simulated materials", "loom train");
  AddCommonOptions(app);
  TrainArguments args;
  fitting::CnnTrainingOptions& t = args.request.training;
  app.add_option("--rig", args.rig, "Simulated rig YAML (its geometry renders the dataset), or its name in configs/rig/")
      ->required();
  app.add_option("--preset", args.preset,
                 "Gloss preset whose material plan makes the observations; several (low,medium,high) need --input-layout paper");
  app.add_option("--input-layout", args.request.input_layout,
                 "stack: the dataset's observations as they are (one preset); paper: the paper's layout, one input for "
                 "every preset")
      ->check(CLI::IsMember({"stack", "paper"}));
  app.add_option("--out", args.request.out, "Model directory: model.json, weights.pt, training.json, checkpoints/")->required();
  app.add_option("--data", args.request.data, "Dataset directory (default OUT/data): NAME.stack.exr + NAME.truth.exr pairs");
  app.add_option("--materials", args.request.dataset.materials, "Procedural fabrics to render into the dataset")
      ->check(CLI::Range(3, 100000));
  app.add_option("--validation", args.request.validation, "Materials held out for validation")->check(CLI::Range(1, 100000));
  app.add_option("--test", args.request.test, "Materials held out for the final test")->check(CLI::Range(1, 100000));
  app.add_option("--size", args.request.dataset.size_px, "Material size in pixels (square)")->check(CLI::Range(16, 4096));
  app.add_option("--first-seed", args.request.dataset.first_seed, "Seed of the first fabric");
  app.add_option("--width-divisor", args.request.width_divisor,
                 "Network width: the paper's divided by this (default 8, or --init's, which a smaller divisor widens)")
      ->check(CLI::Range(1, 256));
  app.add_option("--dropout", args.request.dropout, "Dropout before the last layer")->check(CLI::Range(0.0, 0.9));
  app.add_flag("--centre-skip", args.request.centre_skip,
               "Add a linear readout of each pixel's own features to its label (loom's, not the paper's)");
  app.add_option("--weights", args.request.weights,
                 "How OUT/weights.pt stores the trained weights: float32, or float16 (half the file)")
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
  app.add_option("--radiance-noise", t.radiance_noise, "Relative noise multiplied into the training tiles' radiance (0: none)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--out-of-model-share", args.request.dataset.out_of_model_share,
                 "Share of the fabrics with what GD10 cannot represent")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--scan-like-share", args.request.dataset.scan_like_share,
                 "Share of the fabrics degraded as a scan's reconstruction would be (needs --scan-emulation)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--scan-emulation", args.request.scan_emulation,
                 "How scans degrade the fast path on this rig: a loom sim match-scan --out file")
      ->check(CLI::ExistingFile);
  app.add_option("--init", args.request.init,
                 "Start from this model (fine-tuning): its weights, architecture and input normalisation")
      ->check(CLI::ExistingDirectory);
  app.add_option("--rerender-weight", t.rerender_weight,
                 "Weight of the re-rendering loss beside the label loss (0: off); the kept epoch minimises their sum")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--alpha-weight", t.alpha_weight,
                 "Weight of the anisotropy angle's channels in the training's label loss (the paper's: 1)")
      ->check(CLI::PositiveNumber);
  app.add_option("--normal-lobe-reference", t.normal_lobe_reference,
                 "Lobe width (rad) below which the shading normal's label error weighs more (0: the paper's weight)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--rerender-pixels", t.rerender_pixels, "Pixels per tile the re-rendering loss renders")
      ->check(CLI::Range(1, 100000));
  app.add_option("--rerender-lobe-reference", t.rerender_lobe_reference,
                 "Lobe width (rad) below which the re-rendering loss draws a pixel more often (0: uniformly)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--resident-materials", t.resident_materials,
                 "Training materials in memory at once (0: all; fewer stream --data and need --steps-per-epoch)")
      ->check(CLI::Range(0, 100000000));
  app.add_option("--threads", t.threads, "Threads that render and read the dataset, and torch's on the cpu (0: one per core)")
      ->check(CLI::Range(0, 1024));
  app.add_option("--device", args.request.device,
                 "Where the network trains: cpu, or cuda (a CUDA LibTorch build: docs/gpu-training.md)")
      ->check(CLI::IsMember({"cpu", "cuda"}));
  app.add_option("--seed", t.seed, "Seed of the weights, tiles and dropout");
  app.add_flag("--resume", t.resume, "Go on from OUT/checkpoints (same options as the interrupted run)");
  app.add_flag("--quiet", args.quiet, "No progress output");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  return ExitCode(Train(args));
}

}  // namespace loom::apps
