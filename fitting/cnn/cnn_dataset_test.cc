#include "fitting/cnn/cnn_dataset.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>

#include "fitting/io/axf_export.h"
#include "fitting/model/label.h"
#include "fitting/report/export.h"
#include "fitting/testing/tac7_mini.h"
#include "sim/test_materials.h"
#include "sim/training_set.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

bool Contains(const Status& status, const std::string& text) { return status.ToString().find(text) != std::string::npos; }

// Four 16 × 16 px fabrics of tac7-mini under three observations.
fs::path FourPairs(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / (name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  WardParams<double> matte;
  matte.a_d = Eigen::Vector3d::Constant(0.5);
  const sim::Scene rig(testing::TacMiniGeometry(), sim::UniformMaterial("placeholder", matte, {16, 16, 0.2}));
  const std::vector<sim::Observation> observations = {
      {0, {.leds = {{0, 1000}}}}, {1, {.leds = {{3, 1000}}}}, {0, {.linear_light_on = true, .linear_light_mm = 100}}};
  sim::TrainingSetSpec spec;
  spec.materials = 4;
  spec.size_px = 16;
  EXPECT_TRUE(sim::RenderTrainingSet(rig, observations, spec, dir).ok());
  return dir;
}

// A model of tac7-mini for stacks of `observations` monochrome observations.
CnnModelInfo MonochromeModel(int observations) {
  CnnModelInfo info;
  info.architecture = {kCnnGeometryChannels + observations, 32, 0.02};
  info.rig = "tac7-mini";
  info.observation_groups.assign(static_cast<size_t>(observations), ObservationGroup::kMonochrome);
  return info;
}

TEST(CnnDatasetTest, SplitsByNameAndDescribesTheModelItsStacksNeed) {
  const fs::path dir = FourPairs("cnn_dataset");
  const Result<CnnDataset> dataset = CnnDataset::Open(dir, 1, 1);
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  EXPECT_EQ(dataset->size(), 4);
  EXPECT_EQ(dataset->train_count(), 2);
  const Result<CnnModelInfo> info = dataset->ModelInfo({0, 32, 0.02}, 64);
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->architecture.input_channels, kCnnGeometryChannels + 3);
  EXPECT_EQ(info->architecture.width_divisor, 32);
  ASSERT_EQ(info->observation_groups.size(), 3u);
  EXPECT_EQ(info->observation_groups[2], ObservationGroup::kLinearLight);
  EXPECT_GT(info->radiance_scale, 0);
  EXPECT_NE(info->radiance_scale, 1);  // measured, not the fallback

  // The test example is the last fabric by name, with its stack only when asked for.
  const Result<CnnExample> test = dataset->Example(3, *info, false);
  ASSERT_TRUE(test.ok()) << test.status().ToString();
  EXPECT_NE(test->name.find("fabric-1003.truth.exr"), std::string::npos) << test->name;
  EXPECT_EQ(test->input.channels, info->architecture.input_channels);
  EXPECT_EQ(test->labels.labels.channels, kLabelSize);
  EXPECT_EQ(test->stack, nullptr);
  EXPECT_NE(dataset->Example(0, *info, true)->stack, nullptr);
  fs::remove_all(dir);
}

TEST(CnnDatasetTest, AMissingTruthOrTooFewMaterialsAreNamed) {
  const fs::path dir = FourPairs("cnn_dataset_bad");
  const Result<CnnDataset> too_few = CnnDataset::Open(dir, 2, 2);
  ASSERT_FALSE(too_few.ok());
  EXPECT_TRUE(Contains(too_few.status(), "4 materials")) << too_few.status().ToString();
  fs::remove(dir / "fabric-1002.truth.exr");
  const Result<CnnDataset> missing = CnnDataset::Open(dir, 1, 1);
  ASSERT_FALSE(missing.ok());
  EXPECT_TRUE(Contains(missing.status(), "fabric-1002.truth.exr")) << missing.status().ToString();
  EXPECT_FALSE(CnnDataset::Open(dir / "nowhere", 1, 1).ok());
  fs::remove_all(dir);
}

// A reference may be an AxF file's SVBRDF (NAME.truth.axf), as the paper's dataset keeps its
// labels: the same labels as from the maps it was written from.
TEST(CnnDatasetTest, ReferencesMayBeAxfFiles) {
  const fs::path dir = FourPairs("cnn_dataset_axf");
  const CnnModelInfo info = *CnnDataset::Open(dir, 1, 1)->ModelInfo({0, 32, 0.02}, 64);
  const CnnExample from_exr = *CnnDataset::Open(dir, 1, 1)->Example(1, info, false);
  const Result<SvbrdfFile> maps = ReadSvbrdf(dir / "fabric-1001.truth.exr");
  ASSERT_TRUE(maps.ok()) << maps.status().ToString();
  ASSERT_TRUE(WriteAxf(maps->maps, maps->pixel_mm, dir / "fabric-1001.truth.axf").ok());
  fs::remove(dir / "fabric-1001.truth.exr");
  const Result<CnnDataset> dataset = CnnDataset::Open(dir, 1, 1);
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  const Result<CnnExample> from_axf = dataset->Example(1, info, false);
  ASSERT_TRUE(from_axf.ok()) << from_axf.status().ToString();
  EXPECT_NE(from_axf->name.find("fabric-1001.truth.axf"), std::string::npos) << from_axf->name;
  ASSERT_EQ(from_axf->labels.labels.values.size(), from_exr.labels.labels.values.size());
  for (size_t i = 0; i < from_exr.labels.labels.values.size(); ++i) {
    ASSERT_NEAR(from_axf->labels.labels.values[i], from_exr.labels.labels.values[i], 1e-5) << i;
  }
  fs::remove_all(dir);
}

TEST(CnnDatasetTest, FineTuningNeedsAModelForTheSameStacks) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("cnn_dataset_init_" + std::to_string(::getpid()));
  const CnnModelInfo info = MonochromeModel(3);
  const Result<Cnn> fresh = StartingCnn(info, "", 1);
  ASSERT_TRUE(fresh.ok()) << fresh.status().ToString();
  ASSERT_TRUE(fresh->Save(dir).ok());
  EXPECT_TRUE(StartingCnn(info, dir.string(), 1).ok());
  // A start stored as float16 trains (and checkpoints) in float32.
  Cnn half = *fresh;
  half.mutable_info().weights = WeightStorage::kFloat16;
  ASSERT_TRUE(half.Save(dir / "half").ok());
  const Result<Cnn> from_half = StartingCnn(info, (dir / "half").string(), 1);
  ASSERT_TRUE(from_half.ok()) << from_half.status().ToString();
  EXPECT_EQ(from_half->info().weights, WeightStorage::kFloat32);
  CnnModelInfo other = info;
  other.architecture.input_channels += 1;
  other.observation_groups.push_back(ObservationGroup::kColour);
  const Result<Cnn> mismatched = StartingCnn(other, dir.string(), 1);
  ASSERT_FALSE(mismatched.ok());
  EXPECT_TRUE(Contains(mismatched.status(), "other stacks")) << mismatched.status().ToString();
  fs::remove_all(dir);
}

// The whole of loom train between rendering and saving, in memory and streamed: the kept model
// is the epoch with the lowest validation loss, scored on the test fabric.
TEST(CnnDatasetTest, TrainsKeepsTheBestEpochAndScoresItOnTheTestSet) {
  const fs::path dir = FourPairs("cnn_dataset_train");
  const Result<CnnDataset> dataset = CnnDataset::Open(dir, 1, 1);
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  CnnTrainingOptions options;
  options.epochs = 2;
  options.tile = 8;
  options.steps_per_epoch = 3;
  options.threads = 1;
  EXPECT_FALSE(TrainOnDataset(*dataset, {0, 32, 0.02}, "", options).ok());  // no checkpoint_dir to keep the best in
  options.checkpoint_dir = dir / "in-memory";
  const Result<CnnDatasetTraining> resident = TrainOnDataset(*dataset, {0, 32, 0.02}, "", options);
  ASSERT_TRUE(resident.ok()) << resident.status().ToString();
  options.checkpoint_dir = dir / "streamed";
  options.resident_materials = 1;
  const Result<CnnDatasetTraining> streamed = TrainOnDataset(*dataset, {0, 32, 0.02}, "", options);
  ASSERT_TRUE(streamed.ok()) << streamed.status().ToString();

  EXPECT_FALSE(resident->streamed);
  EXPECT_TRUE(streamed->streamed);
  ASSERT_EQ(resident->history.size(), 2u);
  const CnnEpoch& best =
      resident->history[0].validation_loss < resident->history[1].validation_loss ? resident->history[0] : resident->history[1];
  EXPECT_EQ(resident->kept.epoch, best.epoch);
  ASSERT_TRUE(resident->model.has_value());
  EXPECT_EQ(resident->model->info().architecture.input_channels, kCnnGeometryChannels + 3);
  EXPECT_EQ(resident->test_materials, 1);
  EXPECT_EQ(resident->test.pixels, 16 * 16);
  EXPECT_GT(resident->test.loss, 0);
  const nlohmann::json json = resident->ToJson();
  EXPECT_EQ(json["materials"]["train"], 2);
  EXPECT_EQ(json["epochs"].size(), 2u);
  EXPECT_EQ(json["kept_epoch"], best.epoch);
  ASSERT_EQ(streamed->history.size(), 2u);  // its tiles come a window of materials at a time: other steps
  EXPECT_TRUE(std::isfinite(streamed->test.loss));

  // Scored again afterwards on the same split, the kept model gives what training reported for
  // it; another model (the streamed run's) scores otherwise.
  const Result<CnnHeldOutScore> again = ScoreOnHeldOut(*resident->model, *dataset, 1);
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  EXPECT_NEAR(again->validation.loss, resident->kept.validation_loss, 1e-6 * resident->kept.validation_loss);
  EXPECT_NEAR(again->test.loss, resident->test.loss, 1e-6 * resident->test.loss);
  EXPECT_EQ(again->validation.pixels, 16 * 16);
  EXPECT_EQ(again->test.rmse, resident->test.rmse);
  const Result<CnnHeldOutScore> other = ScoreOnHeldOut(*streamed->model, *dataset, 1);
  ASSERT_TRUE(other.ok()) << other.status().ToString();
  EXPECT_NE(other->test.loss, again->test.loss);

  // Trained with the re-rendering loss, the kept epoch's validation re-rendering loss is what
  // scoring its model again gives: the same pixels rendered the same way.
  options.checkpoint_dir = dir / "rerender";
  options.resident_materials = 0;
  options.rerender_weight = 1;
  const Result<CnnDatasetTraining> rerendered = TrainOnDataset(*dataset, {0, 32, 0.02}, "", options);
  ASSERT_TRUE(rerendered.ok()) << rerendered.status().ToString();
  EXPECT_GT(rerendered->kept.validation_rerender_loss, 0);
  const Result<CnnHeldOutScore> rescored = ScoreOnHeldOut(*rerendered->model, *dataset, 1);
  ASSERT_TRUE(rescored.ok()) << rescored.status().ToString();
  EXPECT_NEAR(rescored->validation.rerender_loss, rerendered->kept.validation_rerender_loss,
              1e-6 * rerendered->kept.validation_rerender_loss);
  EXPECT_NEAR(rescored->test.rerender_loss, rerendered->test.rerender_loss, 1e-6 * rerendered->test.rerender_loss);
  EXPECT_GT(rescored->test.rerender_loss, 0);
  EXPECT_FALSE(resident->ToJson()["test"].contains("rerender_loss"));  // not measured without the loss
  EXPECT_EQ(rerendered->ToJson()["test"]["rerender_loss"], rerendered->test.rerender_loss);
  fs::remove_all(dir);
}

// A model for other stacks is refused, naming the stack it cannot read.
TEST(CnnDatasetTest, ScoringNeedsAModelForTheDatasetsStacks) {
  const fs::path dir = FourPairs("cnn_dataset_score");
  const Result<CnnDataset> dataset = CnnDataset::Open(dir, 1, 1);
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  const Result<Cnn> other = Cnn::Create(MonochromeModel(4), 1);
  ASSERT_TRUE(other.ok()) << other.status().ToString();
  const Result<CnnHeldOutScore> score = ScoreOnHeldOut(*other, *dataset, 1);
  ASSERT_FALSE(score.ok());
  EXPECT_TRUE(Contains(score.status(), "fabric-1002.stack.exr")) << score.status().ToString();
  EXPECT_TRUE(Contains(score.status(), "not the layout the model was trained on")) << score.status().ToString();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace loom::fitting
