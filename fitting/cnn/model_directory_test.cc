#include "fitting/cnn/model_directory.h"

#include <gtest/gtest.h>

#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "fitting/model/label.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

class ModelDirectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("loom_model_directory_test_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  // A small random model in root/NAME, with a refine.json and a checkpoints/ folder beside it.
  fs::path SavedModel(const std::string& name, uint64_t seed, const std::string& rig = "test") {
    CnnModelInfo info;
    info.architecture = {.input_channels = 8, .width_divisor = 16, .dropout = 0.1};
    info.rig = rig;
    info.observation_groups.assign(8 - kCnnGeometryChannels, ObservationGroup::kMonochrome);
    info.training = name + "'s run";
    Result<Cnn> cnn = Cnn::Create(info, seed);
    EXPECT_TRUE(cnn.ok()) << cnn.status().ToString();
    const fs::path dir = root_ / name;
    EXPECT_TRUE(cnn->Save(dir).ok());
    std::ofstream(dir / "refine.json") << R"({"smoothing_weight": 2})";
    fs::create_directories(dir / "checkpoints");
    return dir;
  }

  fs::path root_;
};

TEST_F(ModelDirectoryTest, AModelIsDescribedByItsRigInputWidthWeightsAndTraining) {
  const fs::path model = SavedModel("a", 1);
  Result<Cnn> cnn = Cnn::Load(model);
  ASSERT_TRUE(cnn.ok()) << cnn.status().ToString();
  std::ostringstream text;
  DescribeModel(model, cnn->info(), text);
  EXPECT_NE(text.str().find("rig test, 8 input channels; observations: 4 monochrome"), std::string::npos) << text.str();
  EXPECT_NE(text.str().find("width divisor 16"), std::string::npos) << text.str();
  EXPECT_NE(text.str().find("training: a's run"), std::string::npos) << text.str();
}

TEST_F(ModelDirectoryTest, AScoreOnAMissingDatasetNamesIt) {
  const Result<ModelScore> score = ScoreModel(SavedModel("a", 1), root_ / "no-such-data", 1, 1, 1);
  ASSERT_FALSE(score.ok());
  EXPECT_NE(score.status().ToString().find("no-such-data"), std::string::npos) << score.status().ToString();
}

TEST_F(ModelDirectoryTest, AConvertedModelKeepsItsFilesAndLeavesItsFoldersBehind) {
  const fs::path model = SavedModel("a", 1);
  ASSERT_TRUE(ConvertModel(model, root_ / "half", WeightStorage::kFloat16).ok());
  Result<Cnn> half = Cnn::Load(root_ / "half");
  ASSERT_TRUE(half.ok()) << half.status().ToString();
  EXPECT_EQ(half->info().weights, WeightStorage::kFloat16);
  EXPECT_LT(fs::file_size(root_ / "half" / "weights.pt"), fs::file_size(model / "weights.pt"));
  EXPECT_TRUE(fs::exists(root_ / "half" / "refine.json"));
  EXPECT_FALSE(fs::exists(root_ / "half" / "checkpoints"));
}

TEST_F(ModelDirectoryTest, TheModelItselfIsNeverTheOutput) {
  const fs::path model = SavedModel("a", 1);
  const auto written = fs::last_write_time(model / "weights.pt");
  const Status into_itself = ConvertModel(model, model, WeightStorage::kFloat16);
  EXPECT_FALSE(into_itself.ok());
  EXPECT_NE(into_itself.message().find("the model itself"), std::string::npos) << into_itself.ToString();
  EXPECT_EQ(fs::last_write_time(model / "weights.pt"), written);
  const fs::path other = SavedModel("b", 2);
  const Status into_an_input = AverageModels({model, other}, other, WeightStorage::kFloat32);
  EXPECT_NE(into_an_input.message().find("a model it averages"), std::string::npos) << into_an_input.ToString();
}

TEST_F(ModelDirectoryTest, TheAverageNamesEveryModelAndRefusesAnotherNetwork) {
  const fs::path a = SavedModel("a", 1), b = SavedModel("b", 2);
  ASSERT_TRUE(AverageModels({a, b}, root_ / "mean", WeightStorage::kFloat32).ok());
  Result<Cnn> mean = Cnn::Load(root_ / "mean");
  ASSERT_TRUE(mean.ok()) << mean.status().ToString();
  EXPECT_NE(mean->info().training.find("2 models"), std::string::npos) << mean->info().training;
  EXPECT_NE(mean->info().training.find("a's run"), std::string::npos) << mean->info().training;
  const fs::path elsewhere = SavedModel("c", 3, "another-rig");
  const Status refused = AverageModels({a, elsewhere}, root_ / "mixed", WeightStorage::kFloat32);
  EXPECT_FALSE(refused.ok());
  EXPECT_EQ(refused.subject(), elsewhere.string()) << refused.ToString();
  EXPECT_FALSE(fs::exists(root_ / "mixed"));
}

}  // namespace
}  // namespace loom::fitting
