// A scan on the simulated tac7-mini from its rig file: no backend but the rig's `sim` ones, the
// objects placed by the simulated world (never by hand), a crop's windows, and a resume that
// ends the plan the scan started with.
#include "acquisition/rig_scan.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <sstream>

#include "core/testing/build_tree.h"

namespace loom::acquisition {
namespace {

namespace fs = std::filesystem;

class RigScanTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("rig_scan_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    request_.rig_path = loom::testing::SourceDir() + "/configs/rig/tac7-mini.yaml";
    request_.out = dir_ / "scan";
  }
  void TearDown() override { fs::remove_all(dir_); }

  Status Scan() { return NewScan(request_, preset_, hal::BackendRegistry(), ByHand(), {report_, notes_, true}); }
  PlaceObjectByHand ByHand() {
    return [this](scan::ScanObject, bool) {
      ++placed_by_hand_;
      return Status::Ok();
    };
  }

  fs::path dir_;
  fs::path preset_ = loom::testing::SourceDir() + "/acquisition/testdata/tiny-preset.yaml";
  scan::ScanRequest request_;
  std::ostringstream report_, notes_;
  int placed_by_hand_ = 0;
};

TEST_F(RigScanTest, ASimulatedRigScansACropIntoAnIntactStoreAndAResumeFindsNothingLeft) {
  request_.crop_mm = 3.2;
  request_.object = "fabric:3";
  ASSERT_TRUE(Scan().ok()) << notes_.str();
  const Result<scan::ScanIntegrity> integrity = scan::VerifyScan(request_.out);
  ASSERT_TRUE(integrity.ok()) << integrity.status().ToString();
  EXPECT_TRUE(integrity->intact());
  EXPECT_NE(report_.str().find("scan complete"), std::string::npos) << report_.str();
  EXPECT_EQ(placed_by_hand_, 0);  // the simulated world puts its objects on the turntable
  const Result<scan::CaptureStore> store = scan::CaptureStore::Open(request_.out, /*repair=*/false);
  ASSERT_TRUE(store.ok());
  EXPECT_EQ(store->info().object, "fabric:3");
  EXPECT_DOUBLE_EQ(store->info().crop_mm, 3.2);
  const size_t frames = store->records().size();

  std::ostringstream resumed;
  ASSERT_TRUE(ResumeScan(request_.out, hal::BackendRegistry(), ByHand(), {resumed, notes_, false}).ok()) << notes_.str();
  EXPECT_NE(notes_.str().find("for the 3.2 mm crop"), std::string::npos) << notes_.str();  // the crop's windows again
  EXPECT_NE(resumed.str().find("scan complete: " + std::to_string(frames) + " frames"), std::string::npos) << resumed.str();
}

// Only the caller's backends drive real devices: with none, a real rig's first device is named
// and no scan directory is made.
TEST_F(RigScanTest, ABackendTheCallerDoesNotHoldIsNamedAndLeavesNoScan) {
  request_.rig_path = loom::testing::SourceDir() + "/configs/rig/peer.yaml";
  const Status scanned = Scan();
  ASSERT_FALSE(scanned.ok());
  EXPECT_NE(scanned.ToString().find("aravis"), std::string::npos) << scanned.ToString();
  EXPECT_FALSE(fs::exists(request_.out));
}

}  // namespace
}  // namespace loom::acquisition
