// Calibrating from a scan directory into a calibration directory: what is not a calibration scan
// is refused naming it, and the calibration directory is then not created. The whole path on a
// simulated calibration scan is apps/calibrate_command_test.cc's: a scan is written by the
// acquisition module, which this module's tests may not use.
#include "calibration/scan_calibration.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

namespace loom::calibration {
namespace {

namespace fs = std::filesystem;

TEST(ScanCalibrationTest, AMissingScanIsRefusedNamingItAndNoCalibrationDirectoryIsWritten) {
  const fs::path parent = fs::path(::testing::TempDir()) / ("scan_calibration_" + std::to_string(::getpid()));
  fs::remove_all(parent);
  fs::create_directories(parent);
  const Result<GeometryCalibration> geometry = CalibrateGeometryToDirectory(parent / "no-such-scan", parent / "calib");
  ASSERT_FALSE(geometry.ok());
  EXPECT_NE(geometry.status().ToString().find("no-such-scan"), std::string::npos) << geometry.status().ToString();
  EXPECT_TRUE(fs::is_empty(parent));
  fs::remove_all(parent);
}

}  // namespace
}  // namespace loom::calibration
