#include "fitting/cnn/cnn_training.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <random>
#include <utility>

#include "fitting/model/label.h"
#include "fitting/testing/tac7_mini.h"
#include "sim/fabric.h"
#include "sim/stack.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;
constexpr int kChannels = 6;

Cnn SmallCnn() {
  CnnModelInfo info;
  info.architecture = {.input_channels = kChannels, .width_divisor = 32, .dropout = 0.02};
  info.observation_groups.assign(kChannels - kCnnGeometryChannels, ObservationGroup::kMonochrome);
  Result<Cnn> cnn = Cnn::Create(info, 11);
  EXPECT_TRUE(cnn.ok());
  return std::move(*cnn);
}

// A learnable task: every label channel is an affine function of one input channel at the
// same pixel; the last column is off the material.
CnnExample Example(uint64_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const int size = 24;
  CnnExample e;
  e.name = "example " + std::to_string(seed);
  e.input = {kChannels, size, size, std::vector<float>(kChannels * size * size)};
  for (float& v : e.input.values) v = unit(rng);
  e.labels.labels = {kLabelSize, size, size, std::vector<float>(kLabelSize * size * size)};
  e.labels.valid.assign(size * size, 1);
  for (int y = 0; y < size; ++y) {
    e.labels.valid[y * size + size - 1] = 0;
    for (int x = 0; x < size; ++x) {
      for (int c = 0; c < kLabelSize; ++c) {
        e.labels.labels.values[(c * size + y) * size + x] = 0.5f * e.input.at(c % kChannels, y, x) + 0.1f;
      }
    }
  }
  return e;
}

fs::path TempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("loom_cnn_training_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

CnnTrainingOptions FastOptions() {
  CnnTrainingOptions options;
  options.epochs = 3;
  options.tile = 8;
  options.tiles_per_step = 2;
  options.steps_per_epoch = 25;
  options.learning_rate_start = 1e-2;
  options.learning_rate_end = 1e-3;
  options.threads = 1;  // bit-identical runs for the resume test
  return options;
}

TEST(CnnTrainingTest, TheValidationLossFallsOnALearnableTask) {
  Cnn cnn = SmallCnn();
  const std::vector<CnnExample> train = {Example(1), Example(2)}, validation = {Example(3)};
  const Result<CnnScore> before = ScoreCnn(cnn, validation, 1);
  ASSERT_TRUE(before.ok());
  EXPECT_EQ(before->pixels, 24 * 23);  // the invalid column is not scored
  const Result<std::vector<CnnEpoch>> history = TrainCnn(cnn, train, validation, FastOptions());
  ASSERT_TRUE(history.ok()) << history.status().ToString();
  ASSERT_EQ(history->size(), 3u);
  EXPECT_LT(history->back().validation_loss, 0.2 * before->loss);
  EXPECT_NEAR(history->front().learning_rate, 1e-2, 1e-12);
  EXPECT_NEAR(history->back().learning_rate, 1e-3, 1e-12);
  EXPECT_GT(history->back().samples_per_second, 0);
}

// The angle's RMSE is also stated over the pixels whose true lobe is anisotropic (≥ 1.5:1).
TEST(CnnTrainingTest, TheScoreStatesTheAnglesErrorWhereTheTrueLobeIsAnisotropic) {
  const CnnExample example = Example(3);
  int64_t anisotropic = 0;
  for (size_t i = 0; i < example.labels.valid.size(); ++i) {
    const double a = DecodeSigma(example.labels.labels.values[9 * example.labels.valid.size() + i]);
    const double b = DecodeSigma(example.labels.labels.values[10 * example.labels.valid.size() + i]);
    anisotropic += example.labels.valid[i] && std::max(a, b) >= 1.5 * std::min(a, b);
  }
  ASSERT_GT(anisotropic, 0);
  const Result<CnnScore> score = ScoreCnn(SmallCnn(), {example}, 1);
  ASSERT_TRUE(score.ok()) << score.status().ToString();
  EXPECT_EQ(score->anisotropic_pixels, anisotropic);
  EXPECT_LT(score->anisotropic_pixels, score->pixels);
  for (int c = 0; c < 2; ++c) EXPECT_GT(score->angle_rmse_where_anisotropic[c], 0) << c;

  // Every valid lobe 3:1: the angle's RMSE where anisotropic is its RMSE over every pixel.
  CnnExample elongated = example;
  const size_t plane = elongated.labels.valid.size();
  std::fill_n(elongated.labels.labels.values.begin() + 9 * plane, plane, static_cast<float>(EncodeSigma(0.1)));
  std::fill_n(elongated.labels.labels.values.begin() + 10 * plane, plane, static_cast<float>(EncodeSigma(0.3)));
  const Result<CnnScore> all = ScoreCnn(SmallCnn(), {elongated}, 1);
  ASSERT_TRUE(all.ok()) << all.status().ToString();
  EXPECT_EQ(all->anisotropic_pixels, all->pixels);
  for (int c = 0; c < 2; ++c) EXPECT_NEAR(all->angle_rmse_where_anisotropic[c], all->rmse[11 + c], 1e-6) << c;
}

TEST(CnnTrainingTest, AStreamedDatasetTrainsWithOneMaterialInMemoryAtATime) {
  const std::vector<CnnExample> examples = {Example(1), Example(2), Example(4)}, validation = {Example(3)};
  int loads = 0;
  const CnnExampleSource source{3, [&](int i) -> Result<CnnExample> {
                                  ++loads;
                                  return examples[static_cast<size_t>(i)];
                                }};
  Cnn cnn = SmallCnn();
  const Result<CnnScore> before = ScoreCnn(cnn, validation, 1);
  ASSERT_TRUE(before.ok());
  CnnTrainingOptions options = FastOptions();
  options.resident_materials = 1;
  options.steps_per_epoch = 36;  // 12 per material
  const Result<std::vector<CnnEpoch>> history = TrainCnn(cnn, source, validation, options);
  ASSERT_TRUE(history.ok()) << history.status().ToString();
  EXPECT_EQ(loads, options.epochs * 3);  // each material read once per epoch
  EXPECT_LT(history->back().validation_loss, 0.3 * before->loss);

  options.steps_per_epoch = 0;
  const Result<std::vector<CnnEpoch>> refused = TrainCnn(cnn, source, validation, options);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().ToString().find("steps_per_epoch"), std::string::npos) << refused.status().ToString();
}

TEST(CnnTrainingTest, RadianceNoiseMultipliesTheObservationsAndLeavesTheGeometry) {
  CnnTensor input = Example(1).input;
  const int first_radiance = kCnnGeometryChannels * input.height * input.width;
  std::fill_n(input.values.begin() + first_radiance, input.width, 0.0f);  // its first row unseen
  const Result<CnnTensor> noisy_result = WithRadianceNoise(input, 0.1, 7);
  ASSERT_TRUE(noisy_result.ok()) << noisy_result.status().ToString();
  const CnnTensor& noisy = *noisy_result;
  ASSERT_EQ(noisy.values.size(), input.values.size());
  double sum = 0, sum2 = 0;
  int count = 0;
  for (int c = 0; c < kChannels; ++c) {
    for (int y = 0; y < input.height; ++y) {
      for (int x = 0; x < input.width; ++x) {
        const float before = input.at(c, y, x), after = noisy.at(c, y, x);
        if (c < kCnnGeometryChannels || before == 0) {
          EXPECT_EQ(after, before) << c << " " << x << "," << y;
          continue;
        }
        // The features are log(1 + L / scale).
        const double factor = std::expm1(after) / std::expm1(before);
        sum += factor;
        sum2 += factor * factor;
        ++count;
      }
    }
  }
  const double mean = sum / count, sigma = std::sqrt(sum2 / count - mean * mean);
  EXPECT_NEAR(mean, 1, 0.02) << count;  // 1128 factors: the mean's own spread is 0.003
  EXPECT_NEAR(sigma, 0.1, 0.01) << count;
  EXPECT_NE(WithRadianceNoise(input, 0.1, 8)->values, noisy.values);  // the seed draws anew

  CnnTrainingOptions negative = FastOptions();
  negative.radiance_noise = -0.1;
  EXPECT_NE(negative.Check().ToString().find("radiance_noise"), std::string::npos) << negative.Check().ToString();
}

TEST(CnnTrainingTest, TrainingFeedsTheNetworkNoisyRadianceWhenAsked) {
  const std::vector<CnnExample> train = {Example(1), Example(2)}, validation = {Example(3)};
  CnnTrainingOptions options = FastOptions();
  options.epochs = 1;
  Cnn exact = SmallCnn(), noisy = SmallCnn();
  const Result<std::vector<CnnEpoch>> exact_history = TrainCnn(exact, train, validation, options);
  options.radiance_noise = 0.3;
  const Result<std::vector<CnnEpoch>> noisy_history = TrainCnn(noisy, train, validation, options);
  ASSERT_TRUE(exact_history.ok() && noisy_history.ok());
  // Same weights, tiles and dropout: only the noise can tell the two runs apart.
  EXPECT_NE(exact_history->front().train_loss, noisy_history->front().train_loss);
}

// The first epoch of one run without and with `weigh` applied to its options: its tiles, weights
// and dropout the same, and a learning rate so small that the network stays as it was, so that
// the losses differ by the loss's weights alone.
std::pair<CnnEpoch, CnnEpoch> FirstEpochWithoutAndWith(const std::function<void(CnnTrainingOptions&)>& weigh) {
  const std::vector<CnnExample> train = {Example(1), Example(2)}, validation = {Example(3)};
  CnnTrainingOptions options = FastOptions();
  options.epochs = 1;
  options.learning_rate_start = options.learning_rate_end = 1e-12;
  Cnn without = SmallCnn(), with = SmallCnn();
  const Result<std::vector<CnnEpoch>> without_history = TrainCnn(without, train, validation, options);
  weigh(options);
  const Result<std::vector<CnnEpoch>> with_history = TrainCnn(with, train, validation, options);
  if (!without_history.ok() || !with_history.ok()) {
    ADD_FAILURE() << without_history.status().ToString() << " / " << with_history.status().ToString();
    return {};
  }
  return {without_history->front(), with_history->front()};
}

// The anisotropy angle's channels weighed 10×: a larger training loss; recorded, and checked.
TEST(CnnTrainingTest, TheAlphaWeightWeighsTheAnglesChannelsInTheTrainingLoss) {
  const auto [paper, heavier] = FirstEpochWithoutAndWith([](CnnTrainingOptions& o) { o.alpha_weight = 10; });
  EXPECT_GT(heavier.train_loss, paper.train_loss);

  CnnTrainingOptions options;
  options.alpha_weight = 10;
  EXPECT_EQ(options.ToJson().at("alpha_weight"), 10);
  for (const double bad : {0.0, -1.0, std::nan("")}) {
    options.alpha_weight = bad;
    EXPECT_NE(options.Check().ToString().find("alpha_weight"), std::string::npos) << bad;
  }
}

// Every normal weighed more (a reference wider than any lobe): a larger training loss, the
// validation loss (the paper's weights) the same; recorded, and checked.
TEST(CnnTrainingTest, TheNormalLobeReferenceWeighsTheNormalsInTheTrainingLossButNotInValidation) {
  const auto [paper, weighted] = FirstEpochWithoutAndWith([](CnnTrainingOptions& o) { o.normal_lobe_reference = 10; });
  EXPECT_GT(weighted.train_loss, paper.train_loss);
  EXPECT_NEAR(weighted.validation_loss, paper.validation_loss, 1e-6);

  CnnTrainingOptions options;
  options.normal_lobe_reference = 10;
  EXPECT_EQ(options.ToJson().at("normal_lobe_reference"), 10);
  for (const double bad : {-1.0, std::nan(""), HUGE_VAL}) {
    options.normal_lobe_reference = bad;
    EXPECT_NE(options.Check().ToString().find("normal_lobe_reference"), std::string::npos) << bad;
  }
}

// A simulated tac7-mini fabric as a training example, with its stack for the re-rendering loss.
CnnExample SimulatedExample(uint64_t seed, CnnModelInfo& info) {
  const sim::Material fabric = sim::GenerateFabric(seed, {.width_px = 12, .height_px = 12, .pixel_mm = 0.2});
  const sim::Scene scene(testing::TacMiniGeometry(), fabric);
  auto stack = std::make_shared<ObservationStack>(sim::RenderStack(scene, testing::TacMiniObservations(scene.rig(), 8), {}));
  info.architecture = {
      .input_channels = kCnnGeometryChannels + static_cast<int>(stack->observations.size()), .width_divisor = 32, .dropout = 0};
  info.observation_groups.clear();
  for (const StackObservation& o : stack->observations) info.observation_groups.push_back(o.group);
  info.radiance_scale = 0.05;
  Result<CnnTensor> input = CnnInputFromStack(*stack, info);
  EXPECT_TRUE(input.ok()) << input.status().ToString();
  return {"fabric " + std::to_string(seed), std::move(*input), CnnLabelsFromMaps(sim::TruthOnStackGrid(scene, {}).maps),
          std::move(stack)};
}

// Two simulated training fabrics and a validation one, and options whose tiles fit them.
struct SimulatedSplit {
  CnnModelInfo info;
  std::vector<CnnExample> train, validation;
  CnnTrainingOptions options;
};

SimulatedSplit SimulatedFabrics(int epochs, int rerender_pixels) {
  SimulatedSplit split;
  split.train = {SimulatedExample(3, split.info), SimulatedExample(4, split.info)};
  split.validation = {SimulatedExample(5, split.info)};
  split.options = FastOptions();
  split.options.tile = 6;
  split.options.epochs = epochs;
  split.options.rerender_pixels = rerender_pixels;
  return split;
}

TEST(CnnTrainingTest, TheRerenderingLossTrainsTheNetworkTowardsTheObservations) {
  auto [info, train, validation, options] = SimulatedFabrics(/*epochs=*/4, /*rerender_pixels=*/8);
  // Two copies of one network trained on the labels alone (from a random start its normals lie
  // below the horizon, where nothing renders), then on with and without the re-rendering loss;
  // a weight of 1e-9 only records the loss.
  std::vector<double> rerender_loss, validation_rerender_loss;
  for (const double weight : {1e-9, 10.0}) {
    Result<Cnn> cnn = Cnn::Create(info, 3);
    ASSERT_TRUE(cnn.ok());
    ASSERT_TRUE(TrainCnn(*cnn, train, validation, options).ok());
    CnnTrainingOptions more = options;
    more.rerender_weight = weight;
    more.learning_rate_start = more.learning_rate_end = 1e-3;
    // Validated on a training fabric: two fabrics teach the re-rendering of no other.
    const Result<std::vector<CnnEpoch>> history = TrainCnn(*cnn, train, {train[0]}, more);
    ASSERT_TRUE(history.ok()) << history.status().ToString();
    rerender_loss.push_back(history->back().train_rerender_loss);
    validation_rerender_loss.push_back(history->back().validation_rerender_loss);
    for (const CnnEpoch& e : *history) {
      EXPECT_DOUBLE_EQ(e.validation_objective, e.validation_loss + weight * e.validation_rerender_loss) << e.epoch;
    }
  }
  EXPECT_GT(rerender_loss[0], 0);
  EXPECT_LT(rerender_loss[1], 0.7 * rerender_loss[0]);
  // Validation renders what training renders (on its own pixels, drawn uniformly): 0.70× here.
  EXPECT_GT(validation_rerender_loss[0], 0);
  EXPECT_LT(validation_rerender_loss[1], 0.8 * validation_rerender_loss[0]);

  std::vector<CnnExample> without_stacks = train;
  without_stacks[1].stack.reset();
  options.rerender_weight = 1;
  Result<Cnn> cnn = Cnn::Create(info, 3);
  const Result<std::vector<CnnEpoch>> refused = TrainCnn(*cnn, without_stacks, validation, options);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().ToString().find("fabric 4"), std::string::npos) << refused.status().ToString();
}

// One code path for every device: from the same seed, training on a GPU computes the losses the
// CPU does (to float rounding: the devices sum in other orders). The draws (tiles, re-rendered
// pixels) come from the host; radiance noise is drawn where the network trains, so it is off here.
// Needs a CUDA build and a GPU: skipped elsewhere (the gathering it relies on is tested on the CPU
// in fitting/cnn/torch/rerender_loss_test.cc).
TEST(CnnTrainingTest, AGpuTrainsToTheLossesTheCpuDoes) {
  const Result<int> gpus = CudaDevices();
  if (!gpus.ok() || *gpus == 0) GTEST_SKIP() << "no CUDA GPU here";
  auto [info, train, validation, options] = SimulatedFabrics(/*epochs=*/2, /*rerender_pixels=*/8);
  options.rerender_weight = 1;
  options.rerender_lobe_reference = 0.3;
  std::vector<std::vector<CnnEpoch>> runs;
  for (const CnnTrainingOptions::Device device : {CnnTrainingOptions::Device::kCpu, CnnTrainingOptions::Device::kCuda}) {
    Result<Cnn> cnn = Cnn::Create(info, 3);
    ASSERT_TRUE(cnn.ok());
    options.device = device;
    Result<std::vector<CnnEpoch>> history = TrainCnn(*cnn, train, validation, options);
    ASSERT_TRUE(history.ok()) << history.status().ToString();
    runs.push_back(std::move(*history));
  }
  for (size_t e = 0; e < runs[0].size(); ++e) {
    EXPECT_NEAR(runs[1][e].train_loss, runs[0][e].train_loss, 1e-3 * runs[0][e].train_loss) << e;
    EXPECT_NEAR(runs[1][e].train_rerender_loss, runs[0][e].train_rerender_loss, 1e-3 * runs[0][e].train_rerender_loss) << e;
    EXPECT_NEAR(runs[1][e].validation_loss, runs[0][e].validation_loss, 1e-3 * runs[0][e].validation_loss) << e;
  }
}

// The re-rendered pixels drawn by their lobe widths: the same first epoch renders other pixels (a
// learning rate so small that only the pixels can tell the runs apart); recorded, and checked.
TEST(CnnTrainingTest, TheRerenderLobeReferenceDrawsOtherPixelsToRender) {
  auto [info, train, validation, options] = SimulatedFabrics(/*epochs=*/1, /*rerender_pixels=*/4);
  options.rerender_weight = 1;
  options.learning_rate_start = options.learning_rate_end = 1e-12;
  std::vector<double> rerender_loss;
  // 0.3 rad: these fabrics' lobes are narrower than that by more in some pixels than in others,
  // so the draws' weights differ between pixels.
  for (const double reference : {0.0, 0.3}) {
    Result<Cnn> cnn = Cnn::Create(info, 3);
    ASSERT_TRUE(cnn.ok());
    options.rerender_lobe_reference = reference;
    const Result<std::vector<CnnEpoch>> history = TrainCnn(*cnn, train, validation, options);
    ASSERT_TRUE(history.ok()) << history.status().ToString();
    rerender_loss.push_back(history->front().train_rerender_loss);
  }
  EXPECT_NE(rerender_loss[0], rerender_loss[1]);

  EXPECT_EQ(options.ToJson().at("rerender_lobe_reference"), 0.3);
  for (const double bad : {-1.0, std::nan(""), HUGE_VAL}) {
    options.rerender_lobe_reference = bad;
    EXPECT_NE(options.Check().ToString().find("rerender_lobe_reference"), std::string::npos) << bad;
  }
}

// Validation renders the same pixels every epoch (a learning rate so small that only other
// pixels could change the loss), and none without the re-rendering loss.
TEST(CnnTrainingTest, ValidationReRendersTheSamePixelsEveryEpoch) {
  auto [info, train, validation, options] = SimulatedFabrics(/*epochs=*/2, /*rerender_pixels=*/4);
  options.learning_rate_start = options.learning_rate_end = 1e-12;
  for (const double weight : {0.0, 1.0}) {
    Result<Cnn> cnn = Cnn::Create(info, 3);
    ASSERT_TRUE(cnn.ok());
    options.rerender_weight = weight;
    const Result<std::vector<CnnEpoch>> history = TrainCnn(*cnn, train, validation, options);
    ASSERT_TRUE(history.ok()) << history.status().ToString();
    const CnnEpoch &first = history->front(), &second = history->back();
    if (weight == 0) {
      EXPECT_EQ(first.validation_rerender_loss, 0);
      EXPECT_EQ(first.validation_objective, first.validation_loss);
      continue;
    }
    EXPECT_GT(first.validation_rerender_loss, 0);
    EXPECT_NEAR(second.validation_rerender_loss, first.validation_rerender_loss, 1e-6 * first.validation_rerender_loss);
  }
}

// The kept epoch is the one with the lowest objective, which with the re-rendering loss need not
// have the lowest label loss; histories written before the objective existed keep by the label loss.
TEST(CnnTrainingTest, TheKeptEpochHasTheLowestValidationObjective) {
  std::vector<CnnEpoch> history(3);
  for (int i = 0; i < 3; ++i) history[i].epoch = i + 1;
  history[0].validation_loss = 0.020, history[0].validation_rerender_loss = 0.030;
  history[1].validation_loss = 0.022, history[1].validation_rerender_loss = 0.020;
  history[2].validation_loss = 0.021, history[2].validation_rerender_loss = 0.025;
  for (CnnEpoch& e : history) e.validation_objective = e.validation_loss + 10 * e.validation_rerender_loss;
  EXPECT_EQ(KeptEpoch(history).epoch, 2);

  nlohmann::json old = nlohmann::json::parse(CnnHistoryJson(history));
  for (nlohmann::json& e : old) {
    e.erase("validation_rerender_loss");
    e.erase("validation_objective");
  }
  const Result<std::vector<CnnEpoch>> read = ParseCnnHistory(old.dump(), "history.json");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(KeptEpoch(*read).epoch, 1);
  EXPECT_EQ((*read)[2].validation_objective, 0.021);
}

TEST(CnnTrainingTest, AResumedRunEndsWhereAnUninterruptedOneDoes) {
  const std::vector<CnnExample> train = {Example(1), Example(2)}, validation = {Example(3)};
  CnnTrainingOptions options = FastOptions();
  options.checkpoint_dir = TempDir("straight");
  Cnn straight = SmallCnn();
  ASSERT_TRUE(TrainCnn(straight, train, validation, options).ok());

  options.checkpoint_dir = TempDir("interrupted");
  options.epochs = 1;  // stops after the first epoch, as if interrupted
  Cnn interrupted = SmallCnn();
  ASSERT_TRUE(TrainCnn(interrupted, train, validation, options).ok());
  options.epochs = 3;
  options.resume = true;
  Cnn resumed = SmallCnn();  // fresh weights: resume must replace them with the checkpoint's
  const Result<std::vector<CnnEpoch>> history = TrainCnn(resumed, train, validation, options);
  ASSERT_TRUE(history.ok()) << history.status().ToString();
  ASSERT_EQ(history->size(), 3u);
  // The first epoch was trained with 1 epoch planned: its learning rate was the start's.
  EXPECT_EQ(history->front().epoch, 1);

  const CnnTensor input = Example(4).input;
  const std::vector<float> a = straight.PredictDense(input, 128, 1)->values;
  const std::vector<float> b = resumed.PredictDense(input, 128, 1)->values;
  ASSERT_EQ(a.size(), b.size());
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, static_cast<double>(std::abs(a[i] - b[i])));
  EXPECT_LT(worst, 1e-5);
  fs::remove_all(TempDir("straight"));
  fs::remove_all(TempDir("interrupted"));
}

// The run keeps the lowest objective over the resumed epochs and its own: resumed with another
// objective than its epochs were scored by, it is refused, naming the history and the way on
// (--init); resumed as it ran, it goes on.
TEST(CnnTrainingTest, ResumingWithAnotherValidationObjectiveIsRefused) {
  auto [info, train, validation, options] = SimulatedFabrics(/*epochs=*/1, /*rerender_pixels=*/4);
  options.checkpoint_dir = TempDir("objective");
  const std::string history_file = (options.checkpoint_dir / "last" / "history.json").string();
  // {the re-rendering weight the run had, the one it is resumed with}
  for (const auto& [had, resumed_with] : {std::pair{0.0, 1.0}, {1.0, 0.0}, {1.0, 3.0}}) {
    fs::remove_all(options.checkpoint_dir);
    options.resume = false, options.epochs = 1, options.rerender_weight = had;
    Result<Cnn> cnn = Cnn::Create(info, 3);
    ASSERT_TRUE(cnn.ok());
    ASSERT_TRUE(TrainCnn(*cnn, train, validation, options).ok());
    options.resume = true, options.epochs = 2, options.rerender_weight = resumed_with;
    const Result<std::vector<CnnEpoch>> refused = TrainCnn(*cnn, train, validation, options);
    ASSERT_FALSE(refused.ok()) << had << " -> " << resumed_with;
    EXPECT_EQ(refused.status().code(), StatusCode::kFailedPrecondition);
    const std::string message = refused.status().ToString();
    EXPECT_NE(message.find(history_file), std::string::npos) << message;
    EXPECT_NE(message.find("--init"), std::string::npos) << message;
    options.rerender_weight = had;
    const Result<std::vector<CnnEpoch>> resumed = TrainCnn(*cnn, train, validation, options);
    ASSERT_TRUE(resumed.ok()) << resumed.status().ToString();
    EXPECT_EQ(resumed->size(), 2u);
  }
  fs::remove_all(options.checkpoint_dir);
}

TEST(CnnTrainingTest, ResumingWithoutACheckpointIsAnErrorNamingTheDirectory) {
  CnnTrainingOptions options = FastOptions();
  options.checkpoint_dir = TempDir("none");
  options.resume = true;
  Cnn cnn = SmallCnn();
  const Result<std::vector<CnnEpoch>> history = TrainCnn(cnn, {Example(1)}, {Example(2)}, options);
  ASSERT_FALSE(history.ok());
  EXPECT_NE(history.status().ToString().find(options.checkpoint_dir.string()), std::string::npos);
}

// A checkpoint's history.json read back as written; a damaged one is DataLoss naming the file.
TEST(CnnTrainingTest, AHistoryReadsBackAndADamagedOneIsNamed) {
  CnnEpoch epoch;
  epoch.epoch = 3;
  epoch.learning_rate = 1e-4;
  epoch.validation_loss = 0.25;
  epoch.validation_rmse[11] = 0.5;
  epoch.validation_rerender_loss = 0.03;
  epoch.validation_objective = 0.55;
  const Result<std::vector<CnnEpoch>> history = ParseCnnHistory(CnnHistoryJson({epoch, epoch}), "history.json");
  ASSERT_TRUE(history.ok()) << history.status().ToString();
  ASSERT_EQ(history->size(), 2u);
  EXPECT_EQ((*history)[1].epoch, 3);
  EXPECT_EQ((*history)[1].learning_rate, 1e-4);
  EXPECT_EQ((*history)[1].validation_rmse[11], 0.5);
  EXPECT_EQ((*history)[1].validation_rerender_loss, 0.03);
  EXPECT_EQ((*history)[1].validation_objective, 0.55);
  const Result<std::vector<CnnEpoch>> damaged = ParseCnnHistory("[{\"epoch\": 1}]", "run/last/history.json");
  ASSERT_FALSE(damaged.ok());
  EXPECT_EQ(damaged.status().code(), StatusCode::kDataLoss);
  EXPECT_NE(damaged.status().ToString().find("run/last/history.json"), std::string::npos) << damaged.status().ToString();
}

TEST(CnnTrainingTest, AnExampleOfTheWrongShapeIsNamed) {
  CnnExample small = Example(1);
  small.name = "tiny.stack.exr";
  small.input.channels = kChannels;
  CnnTrainingOptions options = FastOptions();
  options.tile = 32;  // larger than the 24 px examples
  Cnn cnn = SmallCnn();
  const Result<std::vector<CnnEpoch>> history = TrainCnn(cnn, {small}, {Example(2)}, options);
  ASSERT_FALSE(history.ok());
  EXPECT_NE(history.status().ToString().find("tiny.stack.exr"), std::string::npos) << history.status().ToString();
  CnnTrainingOptions bad;
  bad.epochs = 0;
  bad.tile = 0;
  EXPECT_FALSE(bad.Check().ok());
}

}  // namespace
}  // namespace loom::fitting
