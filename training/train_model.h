#pragma once
// What `loom train` does: a CNN for one rig and gloss preset (or several, in the paper's input
// layout), trained on simulated materials.
//   1. The dataset: the procedural fabrics rendered with the simulator's fast path where missing
//      (sim/training_set.h), split by material (fitting/cnn/cnn_dataset.h).
//   2. Training (fitting/cnn/cnn_training.h) with checkpoints in OUT/checkpoints; `resume` goes on
//      from the last one; `init` starts from another model's weights (fine-tuning).
//   3. OUT/model.json + weights.pt (loom fit --model OUT) and OUT/training.json: every epoch, the
//      options it was trained with, the test set's loss and per-channel RMSE.
// Every option, the outputs and an `init` model are checked before the dataset's minutes of
// rendering.

#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/status.h"
#include "fitting/cnn/cnn_dataset.h"
#include "fitting/cnn/cnn_training.h"
#include "sim/training_set.h"

namespace loom::training {

struct TrainRequest {
  std::filesystem::path rig;                 // a simulated rig's YAML: its geometry renders the dataset
  std::vector<sim::TrainingPreset> presets;  // several take turns by material (input_layout "paper")
  std::filesystem::path out;                 // the model directory
  std::filesystem::path data;                // the dataset's directory; empty: OUT/data
  sim::TrainingSetSpec dataset;
  int validation = 3;
  int test = 3;
  std::filesystem::path init;            // a model to start from (empty: random weights)
  std::filesystem::path scan_emulation;  // a sim match-scan file, for dataset.scan_like_share
  std::string input_layout = "stack";    // or "paper" (fitting/cnn/cnn_input.h)
  std::string device = "cpu";            // or "cuda"
  int width_divisor = 0;                 // 0: 8 for a new model, init's own
  double dropout = 0.02;
  bool centre_skip = false;
  std::string weights = "float32";  // how OUT/weights.pt stores them; checkpoints keep float32
  fitting::CnnTrainingOptions training;
  // Called as each material of the dataset is rendered.
  sim::TrainingSetProgress dataset_progress;
};

struct TrainedModel {
  fitting::CnnDatasetTraining run;
  std::filesystem::path out, data;
  int resident_materials = 0;

  // What `loom train` prints: the dataset's split, the run's epochs and test score, what was written.
  void Report(std::ostream& out) const;
};

// The presets' names as given to `--preset`, comma-separated; none, or an empty one, is an error
// naming the option.
Result<std::vector<std::string>> PresetNames(const std::string& presets);

Result<TrainedModel> TrainModel(TrainRequest request);

}  // namespace loom::training
