// The main job end to end at its smallest settings: loom demo on the simulated tac7-mini —
// calibration scan, calibrate geometry and radiometry, scan of fabric:1, reconstruct with the
// calibration, the shipped CNN refined by Ceres on a 24 × 24 px stack, evaluation against the
// ground truth — scored on what a user of the maps would look at. One test: the two scans take most of its minutes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "core/testing/build_tree.h"
#include "core/testing/subprocess.h"

namespace {

namespace fs = std::filesystem;
using loom::testing::RunCommand;

std::string Loom(const std::string& arguments) { return loom::testing::LoomBinary() + " " + arguments; }

TEST(DemoCommandTest, RecoversTheFabricFromScanToFit) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("demo_command_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string rig = loom::testing::SourceDir() + "/configs/rig/tac7-mini.yaml";
  const auto demo = RunCommand(Loom("demo --rig " + rig + " --size 24 --methods cnn+refine --quiet --out " + dir.string()));
  ASSERT_EQ(demo.exit_code, 0) << demo.output;
  std::cout << demo.output.substr(demo.output.find("== summary"));

  std::ifstream file(dir / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(file);
  const nlohmann::json& fit = summary["methods"]["cnn+refine"];
  // Measured (2 cores, an early shipped CNN): camera calibration 0.30 px;
  // normal error median 4.1° (4.7° with the CNN before it), a_d NRMSE 0.066 (0.080), a_s·F0
  // 0.287, re-render relative L1 0.120 (0.126) over all observations. The bounds leave room for
  // the scan's noise seeds and threading, not for a broken stage: a reconstruction on a
  // misplaced camera or a CNN that fails to start the fits lands far beyond.
  EXPECT_LT(summary["calibration_rms_px"].get<double>(), 0.5) << summary.dump(2);
  EXPECT_LT(fit["normal_error_deg"]["median"].get<double>(), 6.0) << fit.dump(2);
  EXPECT_LT(fit["parameter_nrmse"]["a_d"].get<double>(), 0.10) << fit.dump(2);
  EXPECT_LT(fit["rerender_l1"]["fit"]["all"]["relative_l1"].get<double>(), 0.16) << fit.dump(2);
  for (const char* stage : {"calibration scan", "calibrate geometry", "calibrate radiometry", "material scan", "reconstruct",
                            "ground truth", "fit cnn+refine", "evaluate cnn+refine", "export"}) {
    EXPECT_TRUE(summary["stage_seconds"].contains(stage)) << stage;
  }
  // Calibrating runs during the material scan, so the stages' sum overstates the demo's time;
  // its wall clock still covers the calibration scan, then calibrating, then reconstruction.
  const double wall = summary["wall_seconds"].get<double>();
  EXPECT_GT(wall, summary["stage_seconds"]["calibration scan"].get<double>() +
                      summary["stage_seconds"]["calibrate radiometry"].get<double>() +
                      summary["stage_seconds"]["reconstruct"].get<double>());
  EXPECT_TRUE(fs::exists(dir / "report-cnn+refine" / "index.html"));
  EXPECT_TRUE(fs::exists(dir / "gltf" / "material.gltf"));
  EXPECT_TRUE(fs::exists(dir / "material.axf"));

  // The demo never writes over a previous run.
  const auto again = RunCommand(Loom("demo --rig " + rig + " --out " + dir.string()));
  EXPECT_EQ(again.exit_code, 1) << again.output;
  EXPECT_NE(again.output.find(dir.string() + ": is not empty"), std::string::npos) << again.output;
  fs::remove_all(dir);
}

}  // namespace
