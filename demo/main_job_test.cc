// The main job's stages in order, the scans asked of the caller's function, and a failure named
// by its stage. A whole run scans on a rig's sim backends, which only apps/ picks: loom demo's
// test (apps/demo_command_test.cc) runs it end to end.
#include "demo/main_job.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

#include "core/testing/build_tree.h"
#include "reconstruction/scan_reconstruction.h"

namespace loom::demo {
namespace {

namespace fs = std::filesystem;

class MainJobTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("main_job_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    request_.rig = fs::path(testing::SourceDir()) / "configs/rig/tac7-mini.yaml";
    request_.preset_file = fs::path(testing::SourceDir()) / "configs/plans/low.yaml";
    request_.models_dir = fs::path(testing::SourceDir()) / "configs/models";
    request_.out = dir_ / "demo";
    request_.quiet = true;
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Records each scan asked for; fails the material scan, or, with `scans_succeed`, writes nothing.
  ScanOnRig RecordingScans(bool scans_succeed) {
    return [this, scans_succeed](const scan::ScanRequest& scan) -> Status {
      scans_.push_back(scan);
      if (scans_succeed || scan.calibration) return Status::Ok();
      return FailedPreconditionError("sim rig", "the turntable is stuck");
    };
  }

  fs::path dir_;
  MainJobRequest request_;
  std::vector<scan::ScanRequest> scans_;
  std::ostringstream report_, notes_;
};

TEST_F(MainJobTest, AsksForTheCalibrationScanThenTheMaterialScanAndNamesTheStageThatFailed) {
  request_.object = "fabric:7";
  request_.crop_mm = 2.4;
  const Result<nlohmann::ordered_json> summary = RunMainJob(request_, RecordingScans(false), report_, notes_);
  ASSERT_FALSE(summary.ok());
  EXPECT_NE(summary.status().ToString().find("demo stage 'material scan'"), std::string::npos) << summary.status().ToString();
  EXPECT_NE(summary.status().ToString().find("the turntable is stuck"), std::string::npos) << summary.status().ToString();
  ASSERT_EQ(scans_.size(), 2U);
  EXPECT_TRUE(scans_[0].calibration);
  EXPECT_TRUE(scans_[0].object_windows);  // a crop's rig reads calibration objects through windows
  EXPECT_EQ(scans_[0].out, request_.out / "calibration-scan");
  EXPECT_FALSE(scans_[1].calibration);
  EXPECT_EQ(scans_[1].object, "fabric:7");
  EXPECT_EQ(scans_[1].preset, "low");
  EXPECT_DOUBLE_EQ(scans_[1].crop_mm, 2.4);
  EXPECT_EQ(scans_[1].out, request_.out / "scan");
  // Each stage prints the command that does it by hand.
  EXPECT_NE(report_.str().find("== material scan: loom scan --rig " + request_.rig.string() + " --preset low --object fabric:7"),
            std::string::npos)
      << report_.str();
  EXPECT_FALSE(fs::exists(request_.out / "summary.json"));
}

TEST_F(MainJobTest, ASizeWithoutACropScansOnlyTheCropItReconstructs) {
  request_.size_px = 24;
  const Result<nlohmann::ordered_json> summary = RunMainJob(request_, RecordingScans(false), report_, notes_);
  ASSERT_FALSE(summary.ok());
  ASSERT_EQ(scans_.size(), 2U);
  const double pixel_mm = reconstruction::ReconstructOptions{}.pixel_mm;
  EXPECT_TRUE(scans_[0].object_windows);
  EXPECT_DOUBLE_EQ(scans_[1].crop_mm, 24 * pixel_mm);
}

TEST_F(MainJobTest, WithoutCalibratingReconstructsTheMaterialScanAloneAndNamesWhatIsMissing) {
  request_.calibrate = false;
  const Result<nlohmann::ordered_json> summary = RunMainJob(request_, RecordingScans(true), report_, notes_);
  ASSERT_FALSE(summary.ok());
  ASSERT_EQ(scans_.size(), 1U);
  EXPECT_FALSE(scans_[0].calibration);
  EXPECT_NE(summary.status().ToString().find("demo stage 'reconstruct'"), std::string::npos) << summary.status().ToString();
  EXPECT_NE(summary.status().ToString().find((request_.out / "scan").string()), std::string::npos) << summary.status().ToString();
  EXPECT_EQ(report_.str().find("calibrate"), std::string::npos) << report_.str();
}

TEST_F(MainJobTest, NeverWritesOverAnEarlierRun) {
  fs::create_directories(request_.out);
  std::ofstream(request_.out / "summary.json") << "{}";
  const Result<nlohmann::ordered_json> summary = RunMainJob(request_, RecordingScans(true), report_, notes_);
  ASSERT_FALSE(summary.ok());
  EXPECT_NE(summary.status().ToString().find(request_.out.string() + ": is not empty"), std::string::npos)
      << summary.status().ToString();
  EXPECT_TRUE(scans_.empty());
}

}  // namespace
}  // namespace loom::demo
