// `loom fit`'s files as one call: a stack file fitted into a new directory by the recommended
// method (refine without a model), the method said and written in fit.json; an output directory
// that holds something, start maps of another grid, an unknown method and a GPU this LibTorch
// cannot see refused with nothing written.
#include "fitting/fit_directory.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

#include "core/file_io.h"
#include "core/observation_stack.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/report/export.h"
#include "fitting/testing/tac7_mini.h"
#include "sim/fabric.h"
#include "sim/stack.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

class FitDirectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("fit_directory_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "models");
    const sim::Scene scene(testing::TacMiniGeometry(), sim::GenerateFabric(4, {.width_px = 6, .height_px = 6, .pixel_mm = 0.2}));
    ASSERT_TRUE(WriteObservationStack(stack(), sim::RenderStack(scene, testing::TacMiniObservations(scene.rig(), 4), {})).ok());
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path stack() const { return dir_ / "stack.exr"; }
  FitRequest Request(const std::string& out) const {
    FitRequest request;
    request.stack = stack();
    request.out = dir_ / out;
    request.models_dir = dir_ / "models";
    request.options.threads = 1;
    return request;
  }

  fs::path dir_;
};

TEST_F(FitDirectoryTest, TheRecommendedMethodFitsTheStackIntoANewDirectoryAndSaysWhichItWas) {
  std::ostringstream notes;
  const Result<FitDirectory> fit = FitToDirectory(Request("fit"), notes);
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  EXPECT_EQ(fit->method, "refine");  // no model for the stack's rig in models_dir
  EXPECT_NE(notes.str().find("method refine (the recommended one"), std::string::npos) << notes.str();
  EXPECT_TRUE(fs::is_regular_file(dir_ / "fit" / "svbrdf.exr"));
  const Result<std::string> json = ReadFile(dir_ / "fit" / "fit.json");
  ASSERT_TRUE(json.ok());
  const nlohmann::json written = nlohmann::json::parse(*json);
  EXPECT_EQ(written["method"], "refine");
  EXPECT_EQ(written["pixels"], 36);
  EXPECT_EQ(written["stack"], stack().string());
  std::ostringstream report;
  fit->Report(report);
  EXPECT_NE(report.str().find("wrote " + (dir_ / "fit" / "svbrdf.exr").string()), std::string::npos) << report.str();
}

TEST_F(FitDirectoryTest, AnOccupiedOutputAnUnknownMethodAndStartMapsOfAnotherGridAreRefusedWithNothingWritten) {
  std::ostringstream notes;
  fs::create_directories(dir_ / "kept");
  std::ofstream(dir_ / "kept" / "notes.txt") << "mine";
  const Result<FitDirectory> occupied = FitToDirectory(Request("kept"), notes);
  ASSERT_FALSE(occupied.ok());
  EXPECT_NE(occupied.status().ToString().find("--out"), std::string::npos) << occupied.status().ToString();
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "kept"), fs::directory_iterator()), 1);

  FitRequest magic = Request("magic");
  magic.method = "magic";
  const Result<FitDirectory> unknown = FitToDirectory(magic, notes);
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.status().subject(), "--method magic");
  EXPECT_FALSE(fs::exists(dir_ / "magic"));

  Image small = MakeSvbrdfImage(4, 4, /*with_height=*/false);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 4; ++x) SetParams(small, x, y, WardParams<double>());
  }
  ASSERT_TRUE(WriteSvbrdf(dir_ / "small", small, {"test", "", "tac7-mini", 0.2}).ok());
  FitRequest started = Request("started");
  started.method = "ceres";
  started.start = dir_ / "small" / "svbrdf.exr";
  const Result<FitDirectory> other_grid = FitToDirectory(started, notes);
  ASSERT_FALSE(other_grid.ok());
  EXPECT_NE(other_grid.status().ToString().find("--start"), std::string::npos) << other_grid.status().ToString();
  EXPECT_FALSE(fs::exists(dir_ / "started"));

  // Debian's LibTorch is CPU-only: the GPU asked for is refused, not replaced by the CPU.
  FitRequest on_gpu = Request("on-gpu");
  on_gpu.cnn_device = CnnDevice::kCuda;
  const Result<FitDirectory> no_gpu = FitToDirectory(on_gpu, notes);
  ASSERT_FALSE(no_gpu.ok());
  EXPECT_EQ(no_gpu.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(no_gpu.status().ToString().find("--device cuda"), std::string::npos) << no_gpu.status().ToString();
  EXPECT_FALSE(fs::exists(dir_ / "on-gpu"));
}

}  // namespace
}  // namespace loom::fitting
