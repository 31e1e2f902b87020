#pragma once
// What `loom fit` does with files, for the command and the main job alike: reads the stack (and
// any start maps, checked against its grid), picks the method (the recommended one where none is
// asked for), applies the model directory's refine.json, fits (method_fit.h) and writes
// svbrdf.exr, its previews and fit.json into a new directory, whole or not at all.

#include <filesystem>
#include <functional>
#include <iosfwd>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "core/status.h"
#include "fitting/method_fit.h"
#include "fitting/solve/refine_settings.h"
#include "fitting/solve/stack_fitter.h"

namespace loom::fitting {

// `loom fit`'s option defaults: the prior toward the CNN's maps at the weight and noise level it
// was picked at (a training fabric's reconstructed stack, fabric:1003 on tac7-mini; docs/benchmarks.md).
StackFitOptions DefaultFitOptions();

struct FitRequest {
  std::filesystem::path stack;
  std::filesystem::path out;         // a new (or empty) directory
  std::string method;                // empty: RecommendedMethod
  std::filesystem::path start;       // maps that start every pixel instead of the clusters' fits (empty: none)
  std::filesystem::path model;       // empty: `models_dir` / the stack's rig
  std::filesystem::path models_dir;  // where the shipped models are (configs/models)
  std::string f0 = "1";              // ParseFixedF0's text
  bool no_retries = false;
  double min_sigma = 0;       // 0: from the stack's sampling
  RefineSettingsGiven given;  // what the user set, which refine.json leaves alone
  StackFitOptions options = DefaultFitOptions();
  CnnDevice cnn_device = CnnDevice::kCpu;  // where the cnn methods' network runs
};

struct FitDirectory {
  std::string method;    // the method that fitted
  std::string fallback;  // why the recommended cnn+refine fell back to refine ("" where it did not)
  MethodFit fit;
  nlohmann::json summary;  // fit.json
  std::filesystem::path out;

  // What `loom fit` prints: the CNN's time, the fit's summary, photometric stereo's and the view
  // selection's counts, a warning where albedos sit at the model's bound, what was written.
  void Report(std::ostream& out) const;
};

// Notes on what it is doing (the stack read, the method chosen, a fallback) go to `notes` as it goes.
Result<FitDirectory> FitToDirectory(FitRequest request, std::ostream& notes);

}  // namespace loom::fitting
