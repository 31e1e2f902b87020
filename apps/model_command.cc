// loom model: what a trained CNN takes and how it was made, a copy of it with its weights
// stored otherwise (float16 halves weights.pt, for a model that lives in git), the average of
// its weights and other models', or its score on a training dataset's held-out materials (to
// choose between checkpoints without training on).
//
//   loom model configs/models/tac7-mini
//   loom model MODEL --out DIR --weights float16
//   loom model MODEL --average OTHER [--average ...] --out DIR
//   loom model MODEL --score DATA --validation 12 --test 12 [--json FILE]
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include "apps/command.h"
#include "core/file_io.h"
#include "core/output_file.h"
#include "fitting/cnn/cnn.h"
#include "fitting/cnn/model_directory.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

// What a new model directory's weights take on disk, for the operator.
void ReportWritten(const fs::path& to, fitting::WeightStorage storage) {
  std::cout << "wrote " << to.string() << ": weights " << fitting::WeightStorageName(storage) << ", " << std::setprecision(4)
            << static_cast<double>(fs::file_size(to / "weights.pt")) / 1e6 << " MB\n";
}

struct ScoreArguments {
  std::string data;  // empty: no scoring
  int validation = 3;
  int test = 3;
  int threads = 0;
  std::string json;
  bool force = false;
};

// The model's losses on DATA's validation and test materials (fitting::ScoreModel).
Status Score(const fs::path& model, const ScoreArguments& args) {
  LOOM_RETURN_IF_ERROR(CheckOutputFiles({{"--json", args.json}}, args.force));
  LOOM_ASSIGN_OR_RETURN(const fitting::ModelScore score,
                        fitting::ScoreModel(model, args.data, args.validation, args.test, args.threads));
  score.Report(std::cout);
  return WriteJsonReport(args.json, score.ToJson());
}

Status RunModelCommand(const fs::path& model, const std::string& out, const std::string& weights,
                       const std::vector<std::string>& average, const ScoreArguments& score) {
  if (!score.data.empty()) return Score(model, score);
  if (out.empty()) {
    LOOM_ASSIGN_OR_RETURN(const fitting::Cnn cnn, fitting::Cnn::Load(model));
    fitting::DescribeModel(model, cnn.info(), std::cout);
    return Status::Ok();
  }
  const std::optional<fitting::WeightStorage> storage = fitting::WeightStorageFromName(weights.empty() ? "float32" : weights);
  std::vector<fs::path> models = {model};
  models.insert(models.end(), average.begin(), average.end());
  LOOM_RETURN_IF_ERROR(average.empty() ? fitting::ConvertModel(model, out, *storage)
                                       : fitting::AverageModels(models, out, *storage));
  ReportWritten(out, *storage);
  return Status::Ok();
}

}  // namespace

int RunModel(int argc, char** argv) {
  CLI::App app(
      "Show a trained CNN, copy it with its weights stored otherwise, average its weights with other models', or "
      "score it on a training dataset's held-out materials",
      "loom model");
  AddCommonOptions(app);
  std::string model, out, weights;
  app.add_option("model", model, "Model folder (model.json + weights.pt), e.g. configs/models/tac7-mini")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("--out", out, "Write a copy of the model (with refine.json, README.md, ...) here instead of showing it");
  app.add_option("--weights", weights,
                 "How the copy stores its weights: float32, or float16 (half the file; computed in float32 either way)")
      ->check(CLI::IsMember({"float32", "float16"}))
      ->needs("--out");
  std::vector<std::string> average;
  app.add_option("--average", average,
                 "With --out: write the average of this model's weights and these models' (one architecture and input) "
                 "instead of a copy")
      ->check(CLI::ExistingDirectory)
      ->needs("--out");
  ScoreArguments score;
  CLI::Option* score_option =
      app.add_option("--score", score.data,
                     "Score the model on this loom train dataset's validation and test materials, as loom train does")
          ->check(CLI::ExistingDirectory)
          ->excludes("--out")
          ->excludes("--weights")
          ->excludes("--average");
  app.add_option("--validation", score.validation,
                 "With --score: the validation materials, as loom train --validation split them")
      ->check(CLI::Range(1, 100000))
      ->needs(score_option);
  app.add_option("--test", score.test, "With --score: the test materials (the last by name), as loom train --test split them")
      ->check(CLI::Range(1, 100000))
      ->needs(score_option);
  app.add_option("--threads", score.threads, "With --score: threads that read the stacks and run the network (0: one per core)")
      ->check(CLI::Range(0, 1024))
      ->needs(score_option);
  AddForceOption(app, score.force);
  app.add_option("--json", score.json, "With --score: also write the scores to this JSON file")->needs(score_option);
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  return ExitCode(RunModelCommand(model, out, weights, average, score));
}

}  // namespace loom::apps
