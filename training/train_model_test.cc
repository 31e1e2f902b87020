// `loom train`'s work as one call, at toy size: the dataset rendered, the network trained, the
// model directory and training.json written with what it was trained with; a request that cannot
// train is refused before any rendering, naming its option, with nothing written.
#include "training/train_model.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

#include "core/testing/build_tree.h"

namespace loom::training {
namespace {

namespace fs = std::filesystem;

class TrainModelTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("train_model_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  TrainRequest ToyRequest(const std::string& out) const {
    TrainRequest request;
    request.rig = loom::testing::SourceDir() + "/configs/rig/tac7-mini.yaml";
    request.presets = {{"low", loom::testing::SourceDir() + "/configs/plans/low.yaml"}};
    request.out = dir_ / out;
    request.validation = 1;
    request.test = 1;
    request.dataset.materials = 4;
    request.dataset.size_px = 16;
    request.training.tile = 8;
    request.training.epochs = 1;
    request.training.threads = 1;
    return request;
  }

  fs::path dir_;
};

TEST_F(TrainModelTest, ATrainedModelIsWrittenWithWhatItWasTrainedOn) {
  int rendered = 0;
  TrainRequest request = ToyRequest("model");
  request.dataset_progress = [&](int done, int, const std::string&) { rendered = done; };
  const Result<TrainedModel> trained = TrainModel(request);
  ASSERT_TRUE(trained.ok()) << trained.status().ToString();
  EXPECT_EQ(rendered, 4);
  EXPECT_EQ(trained->run.train_materials, 2);
  for (const char* file : {"model.json", "weights.pt", "training.json", "data/fabric-1000.stack.exr"}) {
    EXPECT_TRUE(fs::exists(dir_ / "model" / file)) << file;
  }
  std::ifstream file(dir_ / "model" / "training.json");
  const nlohmann::json training = nlohmann::json::parse(file);
  EXPECT_EQ(training["options"]["presets"], nlohmann::json::array({"low"}));
  EXPECT_EQ(training["options"]["size_px"], 16);
  EXPECT_EQ(training["epochs"].size(), 1u);
  std::ostringstream report;
  trained->Report(report);
  EXPECT_NE(report.str().find("2 training, 1 validation, 1 test materials"), std::string::npos) << report.str();
}

TEST_F(TrainModelTest, ARequestThatCannotTrainIsRefusedBeforeRenderingNamingItsOption) {
  TrainRequest too_few = ToyRequest("too-few");
  too_few.validation = 2;
  too_few.test = 2;
  const Result<TrainedModel> refused = TrainModel(too_few);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().subject(), "--validation/--test");

  TrainRequest two_presets = ToyRequest("two-presets");
  two_presets.presets.push_back({"high", loom::testing::SourceDir() + "/configs/plans/high.yaml"});
  const Result<TrainedModel> layout = TrainModel(two_presets);
  ASSERT_FALSE(layout.ok());
  EXPECT_EQ(layout.status().subject(), "--preset low,high");

  TrainRequest missing_init = ToyRequest("missing-init");
  missing_init.init = dir_ / "no-such-model";
  const Result<TrainedModel> init = TrainModel(missing_init);
  ASSERT_FALSE(init.ok());
  EXPECT_NE(init.status().ToString().find("no-such-model"), std::string::npos) << init.status().ToString();
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST(PresetNamesTest, ACommaSeparatedListIsSplitAndAnEmptyNameIsRefused) {
  EXPECT_EQ(*PresetNames("low,medium"), (std::vector<std::string>{"low", "medium"}));
  for (const char* bad : {"", "low,,high", ",low"}) {
    const Result<std::vector<std::string>> names = PresetNames(bad);
    ASSERT_FALSE(names.ok()) << bad;
    EXPECT_NE(names.status().ToString().find("--preset " + std::string(bad)), std::string::npos) << names.status().ToString();
  }
}

}  // namespace
}  // namespace loom::training
