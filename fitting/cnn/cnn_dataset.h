#pragma once
// A CNN's dataset on disk: NAME.stack.exr + NAME.truth.exr pairs (sim/training_set.h renders
// them; reconstructed stacks with reference fits can be put beside them under the same names,
// the references also as AxF files, NAME.truth.axf, as the paper's dataset keeps its labels),
// split by material: the last `test` pairs (sorted by name) are the test set, the `validation`
// before them validate every epoch, the rest train. Examples are read on demand, so training
// pairs can stay on disk and stream (CnnExampleSource) when the set is larger than memory.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fitting/cnn/cnn.h"
#include "fitting/cnn/cnn_training.h"

namespace loom::fitting {

// What a new model's input is: its dataset's stack observations as they are, or the paper's
// layout (cnn_input.h), which takes every gloss preset's stacks of the rig.
enum class CnnInputKind { kStackObservations, kPaperLayout };

class CnnDataset {
 public:
  // Every pair in `dir`; a stack without its truth is an error naming it, and so is a split that
  // leaves no training pair.
  static Result<CnnDataset> Open(const std::filesystem::path& dir, int validation, int test);

  int size() const { return static_cast<int>(pairs_.size()); }
  int train_count() const { return size() - validation_ - test_; }
  int validation_count() const { return validation_; }
  int test_count() const { return test_; }

  // A new model's description for these stacks: input channels and observation groups (the first
  // stack's) and rig, and the input normalisation, the median positive radiance of the first
  // `max_stacks` training stacks. With the paper layout, the layout of the stack among those
  // with the fewest linear-light observations (the coarsest sweep, which finer ones are
  // resampled to: a mixed set's low-preset stacks).
  Result<CnnModelInfo> ModelInfo(const CnnArchitecture& architecture, int max_stacks,
                                 CnnInputKind input = CnnInputKind::kStackObservations) const;
  // Example `i` (0 ≤ i < size(): training, then validation, then test) as a model with `info`
  // sees it; `keep_stack` keeps its stack for the re-rendering loss.
  Result<CnnExample> Example(int i, const CnnModelInfo& info, bool keep_stack) const;

 private:
  struct Pair {
    std::filesystem::path stack, truth;
  };
  CnnDataset(std::vector<Pair> pairs, int validation, int test)
      : pairs_(std::move(pairs)), validation_(validation), test_(test) {}
  Result<std::shared_ptr<const ObservationStack>> Stack(int i) const;

  std::vector<Pair> pairs_;
  int validation_ = 0;
  int test_ = 0;
};

// What training starts from: a new model for `info` (weights from `seed`), or the model in
// `init` (fine-tuning, its input normalisation kept) when it takes the same stacks — widened to
// `info`'s width divisor where that is set (not 0) and differs from the model's (Cnn::Widened),
// and given the centre skip where `info` has it and the model has not (Cnn::WithCentreSkip).
Result<Cnn> StartingCnn(const CnnModelInfo& info, const std::string& init, uint64_t seed);

// A trained model on a dataset's held-out materials: the label loss, per-channel RMSE and
// re-rendering loss on its validation and on its test materials, each stack read as the model
// sees it (loom model --score). The same measures as training's validation loss and test score
// (and, on the validation set, the validation_rerender_loss of a run with the default δ and
// strip samples), so that checkpoints and shipped models compare on the fabrics a run held out
// without training any further.
struct CnnHeldOutScore {
  CnnScore validation;
  CnnScore test;
};
Result<CnnHeldOutScore> ScoreOnHeldOut(const Cnn& cnn, const CnnDataset& dataset, int threads);

// `score` as JSON: loss, rmse (per label channel), pixels, the angle's RMSE where anisotropic (and
// those pixels) and, when scored with the stacks, rerender_loss.
nlohmann::json CnnScoreJson(const CnnScore& score);
// The RMSE per label channel on one line: "a_d.R 0.012  a_d.G ...", and on the next the angle's
// where the true lobe is anisotropic.
void ReportRmsePerChannel(std::ostream& out, const CnnScore& score);

// What TrainOnDataset did: every epoch, the one kept and its score on the test materials.
struct CnnDatasetTraining {
  std::vector<CnnEpoch> history;
  CnnEpoch kept;  // the epoch with the lowest validation objective (CnnEpoch)
  CnnScore test;  // of the kept epoch, on the test materials
  int train_materials = 0;
  int validation_materials = 0;
  int test_materials = 0;
  bool streamed = false;     // the training stacks were read from disk a window at a time
  std::optional<Cnn> model;  // the kept epoch's

  nlohmann::json ToJson() const;         // epochs, kept_epoch, test, label_channels, materials
  void Report(std::ostream& out) const;  // one line per epoch, the kept one, the test RMSE per channel
};

// Trains a model on `dataset` (what loom train does between rendering the dataset and saving):
// a new model of `architecture` for the dataset's stacks, or the one in `init` (fine-tuning);
// the training stacks in memory, or streamed options.resident_materials at a time when that is
// fewer; then the epoch with the lowest validation loss, reloaded from
// options.checkpoint_dir/best (later epochs may have overfitted) and scored on the test set.
// The input normalisation comes from the first 64 training stacks, and so does the paper layout.
Result<CnnDatasetTraining> TrainOnDataset(const CnnDataset& dataset, const CnnArchitecture& architecture, const std::string& init,
                                          const CnnTrainingOptions& options,
                                          CnnInputKind input = CnnInputKind::kStackObservations);

}  // namespace loom::fitting
