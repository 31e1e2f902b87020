#pragma once
// New model directories made from others, as `loom model --out` makes them: a model with its
// weights stored otherwise (float16 halves weights.pt, for a model that lives in git), and the
// uniform average of several models' weights. Each carries the files beside its first model
// (refine.json, README.md, ...; folders such as checkpoints/ and data/ stay behind), appears
// whole or not at all (core/output_directory.h), and is never one of the models it is made from.

#include <filesystem>
#include <vector>

#include "core/status.h"
#include "fitting/cnn/cnn.h"

namespace loom::fitting {

// The model in `from` written to `to` with its weights stored as `storage`.
Status ConvertModel(const std::filesystem::path& from, const std::filesystem::path& to, WeightStorage storage);

// The uniform average of the weights of `models` (at least one; one network and input,
// CheckSameNetwork) written to `to`, stored as `storage`; its training text names every model
// averaged and keeps the first's.
Status AverageModels(const std::vector<std::filesystem::path>& models, const std::filesystem::path& to, WeightStorage storage);

}  // namespace loom::fitting
