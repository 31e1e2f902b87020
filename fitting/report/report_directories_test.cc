// `loom eval` and `loom export` as one call each: the simulator's truth evaluated against its own
// stack (re-rendered exactly, no parameter error) into a report directory, and exported as glTF
// and AxF; an export whose AxF path is a FIFO is refused before the glTF is written.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <sstream>

#include "core/observation_stack.h"
#include "core/testing/shipped_rig.h"
#include "fitting/report/evaluate_directory.h"
#include "fitting/report/export.h"
#include "fitting/report/export_maps.h"
#include "sim/fabric.h"
#include "sim/rig_scene.h"
#include "sim/stack.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

class ReportDirectoriesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("report_directories_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const sim::Scene scene(loom::testing::ShippedRigModel("tac7-mini"),
                           sim::GenerateFabric(2, {.width_px = 8, .height_px = 8, .pixel_mm = 0.2}));
    const ObservationStack stack = sim::RenderStack(scene, sim::DefaultObservations(scene.rig(), {0, 90}), {});
    ASSERT_TRUE(WriteObservationStack(dir_ / "stack.exr", stack).ok());
    const sim::Material truth = sim::TruthOnStackGrid(scene, {});
    ASSERT_TRUE(WriteSvbrdf(dir_ / "truth", truth.maps, {"truth", "", stack.rig, stack.pixel_mm}).ok());
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(ReportDirectoriesTest, TheTruthEvaluatedAgainstItsOwnStackHasNoErrorAndItsReportIsWritten) {
  const fs::path truth = dir_ / "truth" / "svbrdf.exr";
  EvaluateRequest request;
  request.maps = truth;
  request.stack = dir_ / "stack.exr";
  request.reference = truth;
  request.out = dir_ / "report";
  request.renderer_views = 0;
  const Result<EvaluatedDirectory> evaluated = EvaluateToDirectory(request);
  ASSERT_TRUE(evaluated.ok()) << evaluated.status().ToString();
  EXPECT_LT(evaluated->evaluation.FitL1(), 1e-3);
  ASSERT_FALSE(evaluated->evaluation.parameters.empty());
  for (const ParameterError& error : evaluated->evaluation.parameters) EXPECT_LT(error.nrmse, 1e-6) << error.name;
  EXPECT_TRUE(fs::is_regular_file(dir_ / "report" / "index.html"));
  EXPECT_TRUE(fs::is_regular_file(dir_ / "report" / "summary.json"));

  request.reference.clear();
  const Result<EvaluatedDirectory> again = EvaluateToDirectory(request);
  ASSERT_FALSE(again.ok());  // the report is there: an output never replaces earlier results
  EXPECT_NE(again.status().ToString().find("--out"), std::string::npos) << again.status().ToString();
}

TEST_F(ReportDirectoriesTest, ExportWritesEveryFormatAskedForOrNothingWhenOneOutputIsRefused) {
  const fs::path maps = dir_ / "truth" / "svbrdf.exr";
  std::ostringstream report;
  ExportRequest request;
  request.maps = maps;
  request.gltf = dir_ / "gltf";
  request.axf = dir_ / "material.axf";
  ASSERT_TRUE(ExportMaps(request, report).ok()) << report.str();
  EXPECT_TRUE(fs::is_regular_file(dir_ / "gltf" / "material.gltf"));
  EXPECT_TRUE(fs::is_regular_file(dir_ / "material.axf"));
  EXPECT_NE(report.str().find("wrote " + (dir_ / "material.axf").string()), std::string::npos) << report.str();

  ASSERT_EQ(::mkfifo((dir_ / "fifo").c_str(), 0600), 0);
  request.gltf = dir_ / "gltf-2";
  request.axf = dir_ / "fifo";
  const Status refused = ExportMaps(request, report);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.ToString().find("FIFO"), std::string::npos) << refused.ToString();
  EXPECT_FALSE(fs::exists(dir_ / "gltf-2"));
}

}  // namespace
}  // namespace loom::fitting
