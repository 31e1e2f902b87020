#include "sim/training_set.h"

#include <gtest/gtest.h>

#include <unistd.h>
#include <algorithm>

#include "core/testing/build_tree.h"
#include "core/testing/shipped_rig.h"
#include "sim/material.h"
#include "sim/test_materials.h"

namespace loom::sim {
namespace {

namespace fs = std::filesystem;

fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / (name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

// tac7-mini under two observations: enough to make pairs, fast to render.
Scene MiniRig() {
  fitting::WardParams<double> matte;
  matte.a_d = Eigen::Vector3d::Constant(0.5);
  return Scene(testing::ShippedRigModel("tac7-mini"), UniformMaterial("placeholder", matte, {16, 16, 0.2}));
}
const std::vector<Observation> kObservations = {{0, {.leds = {{0, 1000}}}}, {1, {.leds = {{3, 1000}}}}};

TEST(TrainingSetTest, RendersEachFabricOnceWithItsTruthAndTheOutOfModelShareSpread) {
  const fs::path dir = FreshDir("training_set");
  TrainingSetSpec spec;
  spec.materials = 3;
  spec.size_px = 16;
  spec.out_of_model_share = 1.0 / 3;
  std::vector<std::string> names;
  ASSERT_TRUE(RenderTrainingSet(MiniRig(), kObservations, spec, dir, [&](int, int, const std::string& name) {
                names.push_back(name);
              }).ok());
  std::sort(names.begin(), names.end());  // rendered in parallel
  EXPECT_EQ(names, (std::vector<std::string>{"fabric-1000", "fabric-1001", "fabric-1002-out-of-model"}));
  for (const std::string& name : names) {
    const Result<ObservationStack> stack = ReadObservationStack(dir / (name + ".stack.exr"));
    ASSERT_TRUE(stack.ok()) << stack.status().ToString();
    EXPECT_EQ(stack->observations.size(), kObservations.size());
    const Result<Material> truth = ReadMaterial(dir / (name + ".truth.exr"));
    ASSERT_TRUE(truth.ok()) << truth.status().ToString();
    EXPECT_EQ(truth->width(), stack->image.width());
  }

  // A pair already there is kept, not rendered again; a missing one is.
  const fs::file_time_type kept = fs::last_write_time(dir / "fabric-1000.stack.exr");
  fs::remove(dir / "fabric-1001.truth.exr");
  ASSERT_TRUE(RenderTrainingSet(MiniRig(), kObservations, spec, dir).ok());
  EXPECT_EQ(fs::last_write_time(dir / "fabric-1000.stack.exr"), kept);
  EXPECT_TRUE(fs::exists(dir / "fabric-1001.truth.exr"));
  fs::remove_all(dir);
}

TEST(TrainingSetTest, AScanLikeShareDegradesItsStacksAndKeepsTheirTruth) {
  const fs::path plain_dir = FreshDir("training_set_plain"), scan_like_dir = FreshDir("training_set_scan_like");
  TrainingSetSpec spec;
  spec.materials = 4;
  spec.size_px = 16;
  ASSERT_TRUE(RenderTrainingSet(MiniRig(), kObservations, spec, plain_dir).ok());
  spec.scan_like_share = 0.5;
  spec.scan_emulation = {.footprints = {{"cam0", 0.4, 0.4}, {"cam1", 0.8, 0.5}}, .gain_spread = 0.1, .noise = 0.2};
  std::vector<std::string> names;
  ASSERT_TRUE(RenderTrainingSet(MiniRig(), kObservations, spec, scan_like_dir, [&](int, int, const std::string& name) {
                names.push_back(name);
              }).ok());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"fabric-1000", "fabric-1001", "fabric-1002-scan-like", "fabric-1003-scan-like"}));
  const auto radiance = [](const fs::path& path) {
    const Result<ObservationStack> stack = ReadObservationStack(path);
    EXPECT_TRUE(stack.ok()) << stack.status().ToString();
    const auto values = stack->image.channel(ObservationStack::ObservationChannel(0));
    return std::vector<float>(values.begin(), values.end());
  };
  const auto truth = [](const fs::path& path) {
    const Result<Material> material = ReadMaterial(path);
    EXPECT_TRUE(material.ok()) << material.status().ToString();
    const float* data = material->maps.data();
    return std::vector<float>(data, data + material->maps.pixel_count() * material->maps.num_channels());
  };
  EXPECT_EQ(radiance(plain_dir / "fabric-1001.stack.exr"), radiance(scan_like_dir / "fabric-1001.stack.exr"));
  EXPECT_NE(radiance(plain_dir / "fabric-1002.stack.exr"), radiance(scan_like_dir / "fabric-1002-scan-like.stack.exr"));
  EXPECT_EQ(truth(plain_dir / "fabric-1002.truth.exr"), truth(scan_like_dir / "fabric-1002-scan-like.truth.exr"));
  fs::remove_all(plain_dir);
  fs::remove_all(scan_like_dir);
}

TEST(TrainingSetTest, ABadSpecNamesEveryFieldAndRendersNothing) {
  const fs::path dir = FreshDir("training_set_bad");
  TrainingSetSpec spec;
  spec.materials = 0;
  spec.size_px = 2;
  spec.out_of_model_share = NAN;
  spec.scan_like_share = 0.5;  // with no emulation
  const Status status = RenderTrainingSet(MiniRig(), kObservations, spec, dir);
  ASSERT_FALSE(status.ok());
  for (const char* field : {"materials", "size_px", "out_of_model_share", "footprints"}) {
    EXPECT_NE(status.ToString().find(field), std::string::npos) << status.ToString();
  }
  EXPECT_FALSE(fs::exists(dir));
}

// loom train's dataset from a rig file and preset files: the fabrics rendered with the presets in
// turn; a rig without `geometry:` and a set beyond memory refused before anything renders.
TEST(TrainingSetTest, ADatasetFromARigFileAndItsPresetsRendersOrIsRefusedFirst) {
  const std::string configs = loom::testing::SourceDir() + "/configs/";
  TrainingDatasetRequest request{configs + "rig/tac7-mini.yaml",
                                 {{"low", configs + "plans/low.yaml"}, {"medium", configs + "plans/medium.yaml"}},
                                 {.materials = 2, .size_px = 8, .first_seed = 7}};
  const fs::path dir = FreshDir("training_dataset");
  ASSERT_TRUE(RenderTrainingDataset(request, dir).ok());
  for (const char* name : {"fabric-7-low", "fabric-8-medium"}) {
    EXPECT_TRUE(fs::exists(dir / (std::string(name) + ".stack.exr"))) << name;
    EXPECT_TRUE(fs::exists(dir / (std::string(name) + ".truth.exr"))) << name;
  }

  const fs::path untouched = FreshDir("training_dataset_refused");
  TrainingDatasetRequest devices = request;
  devices.rig = configs + "rig/peer.yaml";  // real devices, no geometry to render
  const Status no_geometry = RenderTrainingDataset(devices, untouched);
  EXPECT_NE(no_geometry.ToString().find("peer.yaml: not a simulated rig"), std::string::npos) << no_geometry.ToString();
  TrainingDatasetRequest huge = request;
  huge.spec.size_px = 4096;
  huge.spec.materials = 64;
  const Status beyond_memory = RenderTrainingDataset(huge, untouched);
  EXPECT_NE(beyond_memory.ToString().find("--size 4096 × --materials 64"), std::string::npos) << beyond_memory.ToString();
  EXPECT_FALSE(fs::exists(untouched));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace loom::sim
