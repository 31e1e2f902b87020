// loom fit's methods as one call: the CNN's maps alone, and the refiner started from them, on a
// small fabric of tac7-mini with an untrained model; a missing model is named.
#include "fitting/method_fit.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>

#include "fitting/cnn/cnn.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/testing/tac7_mini.h"
#include "sim/fabric.h"
#include "sim/stack.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

TEST(MethodFitTest, TheCnnAloneGivesItsMapsAndCnnRefineStartsFromThem) {
  const sim::Scene scene(testing::TacMiniGeometry(), sim::GenerateFabric(4, {.width_px = 6, .height_px = 6, .pixel_mm = 0.2}));
  const ObservationStack stack = sim::RenderStack(scene, testing::TacMiniObservations(scene.rig(), 4), {});
  CnnModelInfo info;
  info.architecture = {kCnnGeometryChannels + static_cast<int>(stack.observations.size()), 32, 0};
  info.rig = stack.rig;
  for (const StackObservation& o : stack.observations) info.observation_groups.push_back(o.group);
  info.radiance_scale = 0.1;
  const fs::path model = fs::path(::testing::TempDir()) / ("method_fit_model_" + std::to_string(::getpid()));
  const Result<Cnn> cnn = Cnn::Create(info, 3);
  ASSERT_TRUE(cnn.ok()) << cnn.status().ToString();
  ASSERT_TRUE(cnn->Save(model).ok());
  StackFitOptions options;
  options.threads = 1;

  const Result<MethodFit> alone = FitWithMethod(stack, FitMethod::kCnn, model, options);
  ASSERT_TRUE(alone.ok()) << alone.status().ToString();
  EXPECT_FALSE(alone->summary.has_value());
  EXPECT_NE(alone->cnn.find(model.string()), std::string::npos) << alone->cnn;
  const Image expected = *cnn->PredictMaps(stack, 1);
  ASSERT_EQ(alone->maps.num_channels(), expected.num_channels());
  for (int c = 0; c < expected.num_channels(); ++c) {
    EXPECT_TRUE(std::equal(expected.channel(c).begin(), expected.channel(c).end(), alone->maps.channel(c).begin())) << c;
  }
  EXPECT_EQ(alone->ToJson()["pixels"], 36);

  const Result<MethodFit> refined = FitWithMethod(stack, FitMethod::kCnnRefine, model, options);
  ASSERT_TRUE(refined.ok()) << refined.status().ToString();
  ASSERT_TRUE(refined->summary.has_value());
  EXPECT_EQ(refined->summary->pixels, 36);
  const std::optional<int> cluster = refined->maps.FindChannel(kFitClusterChannel);
  ASSERT_TRUE(cluster.has_value());
  EXPECT_EQ(refined->maps.at(*cluster, 2, 3), -1);  // started from the CNN's maps, not a cluster
  const nlohmann::json json = refined->ToJson();
  EXPECT_NE(json["solver"].get<std::string>().find("batch refiner"), std::string::npos) << json.dump(2);
  EXPECT_FALSE(json["uncertainty_channels"].empty()) << json.dump(2);
  EXPECT_GT(json["cnn_seconds"].get<double>(), 0);

  const fs::path nowhere = model / "nowhere";
  const Result<MethodFit> missing = FitWithMethod(stack, FitMethod::kCnnCeres, nowhere, options);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().subject(), nowhere.string());
  EXPECT_TRUE(FitWithMethod(stack, FitMethod::kCeres, nowhere, options).ok());  // needs no model

  // The method loom fit takes by default.
  EXPECT_EQ(RecommendedMethod(stack, model, false), FitMethod::kCnnRefine);
  EXPECT_EQ(RecommendedMethod(stack, model, true), FitMethod::kRefine);  // start maps: no CNN
  EXPECT_EQ(RecommendedMethod(stack, nowhere, false), FitMethod::kRefine);
  ObservationStack photographs = stack;
  photographs.rig = std::string(kImportedRigPrefix) + "ps";
  EXPECT_EQ(RecommendedMethod(photographs, model, false), FitMethod::kCeres);

  // The recommended fit: cnn+refine with the model; refine, saying why, where the model cannot
  // take the stack (here: a stack of another plan's observations).
  const Result<RecommendedFit> recommended =
      FitWithRecommendedMethod(stack, RecommendedMethod(stack, model, false), model, options);
  ASSERT_TRUE(recommended.ok()) << recommended.status().ToString();
  EXPECT_EQ(recommended->method, FitMethod::kCnnRefine);
  EXPECT_TRUE(recommended->fallback.empty());
  const ObservationStack other_plan = sim::RenderStack(scene, testing::TacMiniObservations(scene.rig(), 5), {});
  const Result<RecommendedFit> fallen_back =
      FitWithRecommendedMethod(other_plan, RecommendedMethod(other_plan, model, false), model, options);
  ASSERT_TRUE(fallen_back.ok()) << fallen_back.status().ToString();
  EXPECT_EQ(fallen_back->method, FitMethod::kRefine);
  EXPECT_NE(fallen_back->fallback.find("cnn+refine cannot fit this stack"), std::string::npos) << fallen_back->fallback;
  EXPECT_TRUE(fallen_back->fit.cnn.empty());
  fs::remove_all(model);
}

TEST(MethodFitTest, ManyPixelsAtTheAlbedoBoundAreWarnedOf) {
  Image maps = MakeSvbrdfImage(10, 10, /*with_height=*/false);
  WardParams<double> p;
  p.a_d = Eigen::Vector3d::Constant(0.4);
  for (int y = 0; y < 10; ++y) {
    for (int x = 0; x < 10; ++x) SetParams(maps, x, y, p);
  }
  EXPECT_FALSE(AlbedoBoundWarning(maps).has_value());
  p.a_d.x() = kMaxAlbedo;  // 2 of 100 px: above 1 %
  SetParams(maps, 3, 4, p);
  SetParams(maps, 5, 6, p);
  const std::optional<std::string> warning = AlbedoBoundWarning(maps);
  ASSERT_TRUE(warning.has_value());
  EXPECT_NE(warning->find("2 of 100 px"), std::string::npos) << *warning;
}

}  // namespace
}  // namespace loom::fitting
