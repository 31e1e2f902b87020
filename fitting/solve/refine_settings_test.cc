// A model directory's refine.json applied to a fit's options: the file's values, the command
// line's where it gave them, the refiner-only keys only for the refiner, and a bad file refused
// naming the file and the key, the options untouched.
#include "fitting/solve/refine_settings.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

class RefineSettingsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("refine_settings_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  void Write(const std::string& json) { std::ofstream(dir_ / kRefineSettingsFile, std::ios::trunc) << json; }

  fs::path dir_;
};

TEST_F(RefineSettingsTest, TheFilesValuesApplyAndTheCommandLinesWin) {
  Write(R"({"smoothing_weight": 3, "smoothing_specular_albedo": 0.03, "retries": false, "function_tolerance": 0.001,
            "f0": "material", "picked_on": "fabric:1003"})");
  StackFitOptions options;
  ASSERT_TRUE(ApplyRefineSettings(dir_, true, {}, options).ok());
  EXPECT_EQ(options.smoothing.weight, 3);
  EXPECT_EQ(options.smoothing.specular_albedo, 0.03);
  EXPECT_FALSE(options.retry_poor_fits);
  EXPECT_EQ(options.refiner.function_tolerance, 0.001);
  EXPECT_FALSE(options.fixed_f0.has_value());  // one F0 per material

  StackFitOptions given;
  given.smoothing.weight = 0;
  given.fixed_f0 = 1;
  ASSERT_TRUE(ApplyRefineSettings(dir_, true, {.smoothing_weight = true, .retries = true, .f0 = true}, given).ok());
  EXPECT_EQ(given.smoothing.weight, 0);
  EXPECT_TRUE(given.retry_poor_fits);
  EXPECT_EQ(given.fixed_f0, 1.0);

  StackFitOptions ceres;  // not the refiner: its retries and F0 stay loom fit's
  ceres.fixed_f0 = 1;
  ASSERT_TRUE(ApplyRefineSettings(dir_, false, {}, ceres).ok());
  EXPECT_TRUE(ceres.retry_poor_fits);
  EXPECT_EQ(ceres.fixed_f0, 1.0);
}

TEST_F(RefineSettingsTest, NoFileLeavesTheDefaults) {
  StackFitOptions options;
  const StackFitOptions defaults;
  ASSERT_TRUE(ApplyRefineSettings(dir_ / "no-model", true, {}, options).ok());
  EXPECT_EQ(options.smoothing.weight, defaults.smoothing.weight);
  EXPECT_EQ(options.retry_poor_fits, defaults.retry_poor_fits);
}

TEST_F(RefineSettingsTest, ABadFileIsRefusedNamingTheFileAndKeyAndChangesNothing) {
  const std::string file = (dir_ / kRefineSettingsFile).string();
  for (const auto& [json, culprit] : {std::pair<std::string, std::string>{R"({"smoothing_weigth": 2})", ": smoothing_weigth"},
                                      {R"({"retries": "yes"})", ": retries"},
                                      {R"({"function_tolerance": 2})", ": function_tolerance"},
                                      {R"({"f0": 3})", ": f0"},
                                      {R"({"smoothing_weight": -1})", ": smoothing_weight"},
                                      {"[1, 2]", ""}}) {
    Write(json);
    StackFitOptions options;
    options.smoothing.weight = 7;
    const Status status = ApplyRefineSettings(dir_, true, {}, options);
    ASSERT_FALSE(status.ok()) << json;
    EXPECT_NE(status.ToString().find(file + culprit), std::string::npos) << status.ToString();
    EXPECT_EQ(options.smoothing.weight, 7) << json;
  }
}

}  // namespace
}  // namespace loom::fitting
