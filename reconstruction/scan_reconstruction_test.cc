// A scan directory opened for reconstruction: what is not a scan is refused naming it, before
// anything is written; reconstruction.json says what was calibrated. The whole path on a simulated
// scan (loom scan → loom reconstruct) is apps/reconstruct_command_test.cc's: a scan is written by
// the acquisition module, which this module's tests may not use.
#include "reconstruction/scan_reconstruction.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace loom::reconstruction {
namespace {

namespace fs = std::filesystem;

fs::path FreshDirectory(const std::string& name) {
  const fs::path directory = fs::path(::testing::TempDir()) / ("scan_reconstruction_test-" + name);
  fs::remove_all(directory);
  fs::create_directories(directory);
  return directory;
}

TEST(ScanReconstructionTest, AMissingScanIsRefusedNamingIt) {
  const fs::path missing = FreshDirectory("missing") / "no-such-scan";
  const Result<ScanToReconstruct> opened = OpenScanToReconstruct(missing, {}, {});
  ASSERT_FALSE(opened.ok());
  EXPECT_NE(opened.status().ToString().find(missing.string()), std::string::npos) << opened.status().ToString();
}

TEST(ScanReconstructionTest, AFolderWithoutScanYamlIsRefusedNamingItAndLeftAsItWas) {
  const fs::path folder = FreshDirectory("not-a-scan");
  std::ofstream(folder / "notes.txt") << "not a scan\n";
  const Result<ScanToReconstruct> opened = OpenScanToReconstruct(folder, {}, {});
  ASSERT_FALSE(opened.ok());
  EXPECT_NE(opened.status().ToString().find(folder.string()), std::string::npos) << opened.status().ToString();
  EXPECT_EQ(std::distance(fs::directory_iterator(folder), fs::directory_iterator()), 1);
}

TEST(ScanReconstructionTest, ReconstructingAMissingScanToADirectoryWritesNoDirectory) {
  const fs::path parent = FreshDirectory("to-directory");
  const Result<ReconstructedDirectory> written =
      ReconstructToDirectory(parent / "no-such-scan", {}, {}, parent / "reconstruction", nullptr);
  ASSERT_FALSE(written.ok());
  EXPECT_NE(written.status().ToString().find("no-such-scan"), std::string::npos) << written.status().ToString();
  EXPECT_TRUE(fs::is_empty(parent));
}

TEST(ScanReconstructionTest, ReconstructionJsonSaysWhatWasCalibrated) {
  ScanReconstruction nominal;
  nominal.scan = "scans/fabric";
  const nlohmann::json json = nominal.ToJson(12.5);
  EXPECT_EQ(json["scan"], "scans/fabric");
  EXPECT_EQ(json["calibration"], "nominal (the scan's rig YAML)");
  EXPECT_EQ(json["seconds"], 12.5);
  EXPECT_TRUE(json.contains("loom_version"));
  ScanReconstruction calibrated = nominal;
  calibrated.calibration_directory = "calib";
  calibrated.calibration.led_positions = true;
  const nlohmann::json with_calibration = calibrated.ToJson(1);
  EXPECT_EQ(with_calibration["calibration"], "calib");
  EXPECT_NE(with_calibration.dump(), json.dump());  // the LED positions' part says calibrated
}

}  // namespace
}  // namespace loom::reconstruction
