#pragma once
// A model directory described, scored on a training dataset's held-out materials, and new model
// directories made from others, as `loom model` does it. New directories: a model with its
// weights stored otherwise (float16 halves weights.pt, for a model that lives in git), and the
// uniform average of several models' weights. Each carries the files beside its first model
// (refine.json, README.md, ...; folders such as checkpoints/ and data/ stay behind), appears
// whole or not at all (core/output_directory.h), and is never one of the models it is made from.

#include <filesystem>
#include <iosfwd>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/status.h"
#include "fitting/cnn/cnn.h"
#include "fitting/cnn/cnn_dataset.h"

namespace loom::fitting {

// What the model in `dir` takes (its rig and observations), its width and cost, how its weights
// are stored and how it was trained, for people.
void DescribeModel(const std::filesystem::path& dir, const CnnModelInfo& info, std::ostream& out);

// The model's label loss, RMSE and re-rendering loss on a training dataset's validation and test
// materials, split as loom train splits them (the last `test` by name, the `validation` before them).
struct ModelScore {
  std::filesystem::path model, dataset;
  int train = 0, validation = 0, test = 0;  // materials
  CnnHeldOutScore score;

  void Report(std::ostream& out) const;
  nlohmann::json ToJson() const;
};
Result<ModelScore> ScoreModel(const std::filesystem::path& model, const std::filesystem::path& dataset, int validation, int test,
                              int threads);

// The model in `from` written to `to` with its weights stored as `storage`.
Status ConvertModel(const std::filesystem::path& from, const std::filesystem::path& to, WeightStorage storage);

// The uniform average of the weights of `models` (at least one; one network and input,
// CheckSameNetwork) written to `to`, stored as `storage`; its training text names every model
// averaged and keeps the first's.
Status AverageModels(const std::vector<std::filesystem::path>& models, const std::filesystem::path& to, WeightStorage storage);

}  // namespace loom::fitting
