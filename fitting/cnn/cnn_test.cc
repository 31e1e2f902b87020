#include "fitting/cnn/cnn.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>

#include "core/file_io.h"
#include "fitting/model/label.h"
#include "fitting/model/svbrdf_maps.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

CnnModelInfo SmallModel(int channels) {
  CnnModelInfo info;
  info.architecture = {.input_channels = channels, .width_divisor = 16, .dropout = 0.1};
  info.rig = "test";
  info.observation_groups.assign(channels - kCnnGeometryChannels, ObservationGroup::kMonochrome);
  return info;
}

CnnTensor RandomInput(int channels, int height, int width, uint64_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  CnnTensor input{channels, height, width, std::vector<float>(static_cast<size_t>(channels) * height * width)};
  for (float& v : input.values) v = unit(rng);
  return input;
}

fs::path TempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("loom_cnn_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

TEST(CnnTest, DenseEvaluationEqualsTheSlidingWindow) {
  Result<Cnn> cnn = Cnn::Create(SmallModel(12), 3);
  ASSERT_TRUE(cnn.ok()) << cnn.status().ToString();
  // 20 × 23 px in tiles of 8: tile seams and partial tiles at both edges, and the padded border.
  const CnnTensor input = RandomInput(12, 20, 23, 5);
  Result<CnnTensor> dense = cnn->PredictDense(input, 8, 1);
  Result<CnnTensor> sliding = cnn->PredictSliding(input, 0, 20 * 23, 64, 1);
  ASSERT_TRUE(dense.ok() && sliding.ok());
  ASSERT_EQ(dense->channels, kLabelSize);
  ASSERT_EQ(dense->values.size(), sliding->values.size());
  double worst = 0, spread = 0;
  for (size_t i = 0; i < dense->values.size(); ++i) {
    worst = std::max(worst, static_cast<double>(std::abs(dense->values[i] - sliding->values[i])));
    spread = std::max(spread, static_cast<double>(std::abs(dense->values[i] - dense->values[0])));
  }
  EXPECT_LE(worst, 1e-4);
  EXPECT_GT(spread, 1e-3) << "outputs do not depend on the input: the comparison proves nothing";
}

// The maps, and every fit started from them, do not change with the thread count: the tiles
// are shared out, never a tile's sums (torch's intra-op threads would split those by their count).
TEST(CnnTest, DenseEvaluationIsTheSameOnAnyNumberOfThreads) {
  CnnModelInfo info = SmallModel(24);
  info.architecture.width_divisor = 2;
  Result<Cnn> cnn = Cnn::Create(info, 3);
  ASSERT_TRUE(cnn.ok()) << cnn.status().ToString();
  const CnnTensor input = RandomInput(24, 48, 40, 9);
  const Result<CnnTensor> one = cnn->PredictDense(input, 16, 1);
  ASSERT_TRUE(one.ok()) << one.status().ToString();
  for (int threads : {2, 3}) EXPECT_EQ(cnn->PredictDense(input, 16, threads)->values, one->values) << threads << " threads";
}

TEST(CnnTest, PixelsNearTheEdgeSeeTheEdgeReplicated) {
  Result<Cnn> cnn = Cnn::Create(SmallModel(5), 6);
  ASSERT_TRUE(cnn.ok());
  const int size = 4, padded_size = size + 2 * kPatchHalo;
  const CnnTensor input = RandomInput(5, size, size, 2);
  // The same image with its border written out: each pixel takes its nearest image pixel.
  CnnTensor padded{5, padded_size, padded_size, std::vector<float>(5 * padded_size * padded_size)};
  for (int c = 0; c < 5; ++c) {
    for (int y = 0; y < padded_size; ++y) {
      for (int x = 0; x < padded_size; ++x) {
        const int source_y = std::clamp(y - kPatchHalo, 0, size - 1), source_x = std::clamp(x - kPatchHalo, 0, size - 1);
        padded.values[(static_cast<size_t>(c) * padded_size + y) * padded_size + x] = input.at(c, source_y, source_x);
      }
    }
  }
  const CnnTensor outputs = *cnn->PredictDense(input, 128, 1);
  const CnnTensor padded_outputs = *cnn->PredictDense(padded, 128, 1);
  for (int c = 0; c < kLabelSize; ++c) {
    for (int y = 0; y < size; ++y) {
      for (int x = 0; x < size; ++x) {
        EXPECT_NEAR(outputs.at(c, y, x), padded_outputs.at(c, y + kPatchHalo, x + kPatchHalo), 1e-5) << c << " " << x << "," << y;
      }
    }
  }
}

TEST(CnnTest, TheDenseOutputOfAPixelDependsOnlyOnIts15x15Neighbourhood) {
  Result<Cnn> cnn = Cnn::Create(SmallModel(6), 4);
  ASSERT_TRUE(cnn.ok());
  CnnTensor input = RandomInput(6, 31, 31, 1);
  const CnnTensor before = *cnn->PredictDense(input, 128, 1);
  // Change one input pixel: outputs within 7 px of it change, those further away do not.
  for (int c = 0; c < 6; ++c) input.values[(static_cast<size_t>(c) * 31 + 15) * 31 + 15] += 1;
  const CnnTensor after = *cnn->PredictDense(input, 128, 1);
  for (int y = 0; y < 31; ++y) {
    for (int x = 0; x < 31; ++x) {
      const bool inside = std::abs(y - 15) <= kPatchHalo && std::abs(x - 15) <= kPatchHalo;
      double change = 0;
      for (int c = 0; c < kLabelSize; ++c) {
        change = std::max(change, static_cast<double>(std::abs(after.at(c, y, x) - before.at(c, y, x))));
      }
      if (!inside) {
        EXPECT_EQ(change, 0) << "pixel " << x << "," << y;
      } else if (y == 15 && x == 15) {
        EXPECT_GT(change, 0);
      }
    }
  }
}

TEST(CnnTest, ThePaperArchitecturesWorkPerPixel) {
  // The paper's widths: 475 MFLOP per pixel as patches, 13.3 dense (36× less).
  const CnnArchitecture paper;
  EXPECT_NEAR(paper.SlidingFlopsPerPixel() / 1e6, 475, 1);
  EXPECT_NEAR(paper.DenseFlopsPerPixel() / 1e6, 13.3, 0.1);
  EXPECT_EQ(paper.HiddenWidths(), (std::array<int, 4>{512, 256, 512, 1024}));
  EXPECT_NEAR(paper.WeightCount() / 1e6, 6.64, 0.005);  // README: the paper's width has 6.6 M weights
  const CnnArchitecture small{.input_channels = 232, .width_divisor = 8};
  EXPECT_EQ(small.HiddenWidths(), (std::array<int, 4>{64, 32, 64, 128}));
  EXPECT_FALSE((CnnArchitecture{.input_channels = 0, .width_divisor = 3, .dropout = 1}).Check().ok());
}

TEST(CnnTest, ASavedModelLoadsWithTheSameWeights) {
  const fs::path dir = TempDir("save");
  Result<Cnn> cnn = Cnn::Create(SmallModel(8), 7);
  ASSERT_TRUE(cnn.ok());
  cnn->mutable_info().radiance_scale = 0.25;
  ASSERT_TRUE(cnn->Save(dir).ok());
  Result<Cnn> loaded = Cnn::Load(dir);
  ASSERT_TRUE(loaded.ok()) << loaded.status().ToString();
  EXPECT_EQ(loaded->info().radiance_scale, 0.25);
  EXPECT_EQ(loaded->info().observation_groups.size(), 4u);
  const CnnTensor input = RandomInput(8, 9, 9, 2);
  EXPECT_EQ(cnn->PredictDense(input, 128, 1)->values, loaded->PredictDense(input, 128, 1)->values);
  fs::remove_all(dir);
}

// float16 storage halves weights.pt; the loaded model computes from the rounded weights, and
// saving rounds a copy, not the model that saved.
TEST(CnnTest, AModelStoredAsFloat16LoadsItsWeightsRounded) {
  const fs::path dir32 = TempDir("save32"), dir16 = TempDir("save16");
  Result<Cnn> cnn = Cnn::Create(SmallModel(8), 7);
  ASSERT_TRUE(cnn.ok() && cnn->Save(dir32).ok());
  const CnnTensor input = RandomInput(8, 9, 9, 2);
  const std::vector<float> before = cnn->PredictDense(input, 128, 1)->values;
  cnn->mutable_info().weights = WeightStorage::kFloat16;
  ASSERT_TRUE(cnn->Save(dir16).ok());
  EXPECT_EQ(cnn->PredictDense(input, 128, 1)->values, before);
  // WeightCount counts what the file holds: 4 bytes each, and the archive's few kB around them.
  const double weight_bytes = 4.0 * cnn->info().architecture.WeightCount();
  EXPECT_GT(static_cast<double>(fs::file_size(dir32 / "weights.pt")), weight_bytes);
  EXPECT_LT(static_cast<double>(fs::file_size(dir32 / "weights.pt")), weight_bytes + 32768);
  EXPECT_LT(fs::file_size(dir16 / "weights.pt"), 0.6 * fs::file_size(dir32 / "weights.pt"));
  EXPECT_NE(ReadFile(dir16 / "model.json").value().find("\"weights\": \"float16\""), std::string::npos);
  EXPECT_EQ(ReadFile(dir32 / "model.json").value().find("\"weights\""), std::string::npos);  // as before the option
  Result<Cnn> loaded = Cnn::Load(dir16);
  ASSERT_TRUE(loaded.ok()) << loaded.status().ToString();
  EXPECT_EQ(loaded->info().weights, WeightStorage::kFloat16);
  EXPECT_EQ(Cnn::Load(dir32)->info().weights, WeightStorage::kFloat32);
  const std::vector<float> after = loaded->PredictDense(input, 128, 1)->values;
  ASSERT_EQ(after.size(), before.size());
  double worst = 0, largest = 0;
  for (size_t i = 0; i < after.size(); ++i) {
    worst = std::max(worst, static_cast<double>(std::abs(after[i] - before[i])));
    largest = std::max(largest, static_cast<double>(std::abs(before[i])));
  }
  EXPECT_GT(worst, 0);  // rounded: 11 significant bits
  EXPECT_LT(worst, 1e-2 * std::max(1.0, largest));
  // Weights stored otherwise than model.json says are refused, naming the file.
  fs::copy_file(dir32 / "weights.pt", dir16 / "weights.pt", fs::copy_options::overwrite_existing);
  const Result<Cnn> wider = Cnn::Load(dir16);
  ASSERT_FALSE(wider.ok());
  EXPECT_NE(wider.status().ToString().find("weights.pt: its weights are not stored as float16"), std::string::npos)
      << wider.status().ToString();
  ASSERT_TRUE(cnn->Save(dir16 / "half").ok());
  fs::copy_file(dir16 / "half" / "weights.pt", dir32 / "weights.pt", fs::copy_options::overwrite_existing);
  const Result<Cnn> narrower = Cnn::Load(dir32);
  ASSERT_FALSE(narrower.ok());
  EXPECT_NE(narrower.status().ToString().find("stored as float32"), std::string::npos) << narrower.status().ToString();
  fs::remove_all(dir32);
  fs::remove_all(dir16);
}

TEST(CnnTest, AWidenedModelComputesWhatTheNarrowOneDid) {
  Result<Cnn> narrow = Cnn::Create(SmallModel(8), 7);  // width divisor 16
  ASSERT_TRUE(narrow.ok());
  const Result<Cnn> wide = narrow->Widened(4, 3);
  ASSERT_TRUE(wide.ok()) << wide.status().ToString();
  EXPECT_EQ(wide->info().architecture.width_divisor, 4);
  const CnnTensor input = RandomInput(8, 11, 9, 2);
  const std::vector<float> a = narrow->PredictDense(input, 128, 1)->values, b = wide->PredictDense(input, 128, 1)->values;
  ASSERT_EQ(a.size(), b.size());
  double worst = 0, largest = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    worst = std::max(worst, static_cast<double>(std::abs(a[i] - b[i])));
    largest = std::max(largest, static_cast<double>(std::abs(a[i])));
  }
  EXPECT_GT(largest, 1e-3);  // a function worth comparing
  EXPECT_LT(worst, 1e-5 * std::max(1.0, largest));
  // The copies' shares are drawn: another seed gives other weights for the same function.
  const Result<Cnn> other = narrow->Widened(4, 4);
  const fs::path dir_a = TempDir("wide_a"), dir_b = TempDir("wide_b");
  ASSERT_TRUE(wide->Save(dir_a).ok() && other->Save(dir_b).ok());
  EXPECT_NE(ReadFile(dir_a / "weights.pt").value(), ReadFile(dir_b / "weights.pt").value());
  fs::remove_all(dir_a);
  fs::remove_all(dir_b);
}

TEST(CnnTest, AModelWidensOnlyToADivisorOfItsOwnWidth) {
  Result<Cnn> narrow = Cnn::Create(SmallModel(8), 7);  // width divisor 16
  for (int divisor : {32, 3, 0}) {
    const Result<Cnn> wide = narrow->Widened(divisor, 1);
    ASSERT_FALSE(wide.ok()) << divisor;
    EXPECT_NE(wide.status().ToString().find("width divisor " + std::to_string(divisor)), std::string::npos);
  }
  EXPECT_TRUE(narrow->Widened(16, 1).ok());  // the same width: a copy
}

double LargestDifference(const std::vector<float>& a, const std::vector<float>& b) {
  EXPECT_EQ(a.size(), b.size());
  double worst = 0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) worst = std::max(worst, static_cast<double>(std::abs(a[i] - b[i])));
  return worst;
}

// Averaging weights: of one model, the model itself; of two, a third function, whatever their
// order; of four, the average of their pairs' averages, as only the uniform mean is. Models of
// other networks are refused, naming which.
TEST(CnnTest, AveragingWeighsEveryModelAlike) {
  std::vector<Cnn> models;
  for (uint64_t seed : {1, 2, 3, 4}) models.push_back(*Cnn::Create(SmallModel(8), seed));
  const CnnTensor input = RandomInput(8, 9, 7, 5);
  const auto predict = [&](const Result<Cnn>& cnn) {
    EXPECT_TRUE(cnn.ok()) << cnn.status().ToString();
    return cnn.ok() ? cnn->PredictDense(input, 128, 1)->values : std::vector<float>();
  };
  const std::vector<float> a = predict(models[0]), b = predict(models[1]);
  EXPECT_LT(LargestDifference(predict(Cnn::Average({models[0], models[0]})), a), 1e-6);
  const std::vector<float> ab = predict(Cnn::Average({models[0], models[1]}));
  EXPECT_GT(LargestDifference(ab, a), 1e-3);
  EXPECT_GT(LargestDifference(ab, b), 1e-3);
  EXPECT_LT(LargestDifference(predict(Cnn::Average({models[1], models[0]})), ab), 1e-6);
  const Result<Cnn> cd = Cnn::Average({models[2], models[3]});
  const std::vector<float> pairs = predict(Cnn::Average({*Cnn::Average({models[0], models[1]}), *cd}));
  EXPECT_LT(LargestDifference(predict(Cnn::Average(models)), pairs), 1e-5);

  CnnModelInfo wider = SmallModel(8);
  wider.architecture.width_divisor = 8;
  CnnModelInfo rescaled = SmallModel(8);
  rescaled.radiance_scale *= 2;
  for (const CnnModelInfo& other : {wider, rescaled}) {
    const Result<Cnn> mixed = Cnn::Average({models[0], models[1], *Cnn::Create(other, 5)});
    ASSERT_FALSE(mixed.ok());
    EXPECT_EQ(mixed.status().subject(), "model 3 of 3") << mixed.status().ToString();
  }
  EXPECT_FALSE(Cnn::Average({}).ok());
}

// The centre skip: dense and sliding agree with it; added to a trained model it starts at zero
// (the same function), it is saved and loaded, and widening keeps what it computes.
TEST(CnnTest, TheCentreSkipReadsEachPixelsOwnFeatures) {
  CnnModelInfo info = SmallModel(8);
  info.architecture.centre_skip = true;
  const Result<Cnn> skip = Cnn::Create(info, 3);
  ASSERT_TRUE(skip.ok()) << skip.status().ToString();
  EXPECT_EQ(info.architecture.WeightCount() - SmallModel(8).architecture.WeightCount(), (256 / 16 + 1) * kLabelSize);
  const CnnTensor input = RandomInput(8, 13, 11, 2);
  const std::vector<float> dense = skip->PredictDense(input, 8, 1)->values;
  EXPECT_LE(LargestDifference(dense, skip->PredictSliding(input, 0, 13 * 11, 32, 1)->values), 1e-4);

  const Result<Cnn> plain = Cnn::Create(SmallModel(8), 3);
  const Result<Cnn> added = plain->WithCentreSkip();
  ASSERT_TRUE(added.ok()) << added.status().ToString();
  EXPECT_TRUE(added->info().architecture.centre_skip);
  const std::vector<float> before = plain->PredictDense(input, 128, 1)->values;
  EXPECT_EQ(added->PredictDense(input, 128, 1)->values, before);
  EXPECT_GT(LargestDifference(dense, before), 1e-3);  // the same seed's weights with a non-zero skip differ

  const fs::path dir = TempDir("skip");
  ASSERT_TRUE(skip->Save(dir).ok());
  EXPECT_NE(ReadFile(dir / "model.json").value().find("\"centre_skip\": true"), std::string::npos);
  const Result<Cnn> loaded = Cnn::Load(dir);
  ASSERT_TRUE(loaded.ok()) << loaded.status().ToString();
  EXPECT_EQ(loaded->PredictDense(input, 8, 1)->values, dense);
  const Result<Cnn> wide = skip->Widened(4, 5);
  ASSERT_TRUE(wide.ok()) << wide.status().ToString();
  EXPECT_TRUE(wide->info().architecture.centre_skip);
  EXPECT_LT(LargestDifference(wide->PredictDense(input, 8, 1)->values, dense), 1e-5);
  fs::remove_all(dir);
}

TEST(CnnTest, ABrokenModelDirectoryIsAnErrorNamingTheFile) {
  const fs::path dir = TempDir("broken");
  Result<Cnn> cnn = Cnn::Create(SmallModel(8), 7);
  ASSERT_TRUE(cnn.ok() && cnn->Save(dir).ok());
  // Weights of another architecture under this model.json.
  Result<Cnn> other = Cnn::Create(SmallModel(10), 7);
  ASSERT_TRUE(other.ok() && other->Save(dir / "other").ok());
  fs::copy_file(dir / "other" / "weights.pt", dir / "weights.pt", fs::copy_options::overwrite_existing);
  Result<Cnn> mismatched = Cnn::Load(dir);
  ASSERT_FALSE(mismatched.ok());
  EXPECT_NE(mismatched.status().ToString().find("weights.pt"), std::string::npos) << mismatched.status().ToString();
  // A model.json that is not one.
  ASSERT_TRUE(WriteFileAtomically(dir / "model.json", "{\"format\": \"something else\"}").ok());
  Result<Cnn> wrong = Cnn::Load(dir);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.status().ToString().find("model.json"), std::string::npos) << wrong.status().ToString();
  fs::remove_all(dir);
}

ObservationStack TinyStack(int observations) {
  std::vector<StackObservation> table(observations);
  ObservationStack stack = MakeObservationStack(4, 3, 0.1, table);
  stack.rig = "test";
  stack.source = "cnn_test";
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 4; ++x) {
      stack.image.at(2, y, x) = 0.1f * x;  // pos.Z
      stack.image.at(5, y, x) = 1;         // normal.Z
      for (int k = 0; k < observations; ++k) stack.image.at(ObservationStack::ObservationChannel(k), y, x) = 0.5f * k;
    }
  }
  stack.image.at(ObservationStack::ObservationChannel(1), 0, 0) = std::numeric_limits<float>::quiet_NaN();
  return stack;
}

TEST(CnnTest, TheInputIsRelativeHeightNormalAndCompressedRadiance) {
  CnnModelInfo info = SmallModel(kCnnGeometryChannels + 3);
  info.radiance_scale = 0.5;
  const Result<CnnTensor> input = CnnInputFromStack(TinyStack(3), info);
  ASSERT_TRUE(input.ok()) << input.status().ToString();
  EXPECT_EQ(input->channels, 7);
  EXPECT_FLOAT_EQ(input->at(0, 1, 3), 0.3f - 0.2f);  // the median height is 0.2 mm
  EXPECT_FLOAT_EQ(input->at(3, 1, 3), 1.0f);
  EXPECT_FLOAT_EQ(input->at(kCnnGeometryChannels + 2, 1, 1), std::log1p(1.0f / 0.5f));
  EXPECT_EQ(input->at(kCnnGeometryChannels + 1, 0, 0), 0.0f);  // unseen
}

TEST(CnnTest, AStackOfAnotherLayoutIsRejectedNamingIt) {
  const CnnModelInfo info = SmallModel(kCnnGeometryChannels + 5);
  const Result<CnnTensor> input = CnnInputFromStack(TinyStack(3), info);
  ASSERT_FALSE(input.ok());
  EXPECT_NE(input.status().ToString().find("cnn_test"), std::string::npos) << input.status().ToString();
  EXPECT_NE(input.status().ToString().find("'test'"), std::string::npos) << input.status().ToString();
}

TEST(CnnTest, LabelsOfMapsDecodeBackToTheMaps) {
  Image maps = MakeSvbrdfImage(2, 1, false);
  WardParams<double> p;
  p.n_s = Eigen::Vector3d(0.1, -0.2, 1).normalized();
  p.a_d = {0.5, 0.3, 0.1};
  p.a_s = {0.2, 0.2, 0.25};
  p.sigma_x = 0.05;
  p.sigma_y = 0.2;
  p.alpha = 0.7;
  p.f0 = 0.6;
  SetParams(maps, 0, 0, p);  // pixel 1 stays all zero: off the material
  const CnnLabels labels = CnnLabelsFromMaps(maps);
  EXPECT_EQ(labels.valid, (std::vector<uint8_t>{1, 0}));
  const WardParams<double> back = GetParams(MapsFromLabels(labels.labels), 0, 0);
  EXPECT_NEAR((back.n_s - p.n_s).norm(), 0, 1e-6);
  EXPECT_NEAR((back.a_d - p.a_d).norm(), 0, 1e-6);
  EXPECT_NEAR(back.sigma_x, p.sigma_x, 1e-5);
  EXPECT_NEAR(back.alpha, p.alpha, 1e-5);
  EXPECT_NEAR(back.f0, p.f0, 1e-6);
}

}  // namespace
}  // namespace loom::fitting
