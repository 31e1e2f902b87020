// A scan that fills its disk: the frame that does not fit is a clear error naming its file, and
// everything stored before it is intact and readable. Runs inside run_in_small_tmpfs.sh.
#include <gtest/gtest.h>

#include <cstdlib>

#include "scan/capture_store.h"

namespace loom::scan {
namespace {

// Appends noise frames to a new scan in `dir` until the disk is full: the error, with `stored`
// the frames that made it. The writer, and its lock, end with the function, as a scan's
// process does.
Status FillUntilFull(const std::filesystem::path& dir, int& stored) {
  // One step with a long bracket: 64 frames of 8 KiB do not fit in 256 KiB.
  Step step;
  step.cameras = {"cam0"};
  step.exposure.max_exposures = 64;
  const Plan plan{"r", "low", PlanPurpose::kMaterial, {step}};
  Result<CaptureStore> store = CaptureStore::Create(dir, {"name: r\n", "sample", plan});
  if (!store.ok()) return store.status();
  RawFrame frame;
  frame.width = frame.height = 64;
  uint32_t state = 1;
  for (int i = 0; i < 64 * 64; ++i) {
    state = state * 1664525u + 1013904223u;  // noise: does not compress
    frame.pixels.push_back(static_cast<uint16_t>(state >> 20));
  }
  for (int exposure = 0; exposure < 64; ++exposure) {
    if (Status appended = store->Append({0, "cam0", exposure}, frame); !appended.ok()) return appended;
    ++stored;
  }
  return Status::Ok();
}

TEST(FullDiskTest, TheFrameThatDoesNotFitIsAnErrorAndNothingIsCorrupted) {
  const char* tmpfs = std::getenv("LOOM_SMALL_TMPFS");
  if (tmpfs == nullptr) GTEST_SKIP() << "needs run_in_small_tmpfs.sh";
  const std::filesystem::path dir = std::filesystem::path(tmpfs) / "scan";
  int stored = 0;
  const Status failed = FillUntilFull(dir, stored);
  ASSERT_FALSE(failed.ok()) << "the 256 KiB disk never filled";
  EXPECT_EQ(failed.code(), StatusCode::kIoError) << failed.ToString();
  EXPECT_NE(failed.subject().find("/frames/s"), std::string::npos) << failed.ToString();  // names the frame file
  EXPECT_GT(stored, 0);
  const Result<CaptureStore> reopened = CaptureStore::Open(dir, /*repair=*/true);
  ASSERT_TRUE(reopened.ok()) << reopened.status().ToString();
  EXPECT_EQ(static_cast<int>(reopened->records().size()), stored);
  for (const FrameRecord& record : reopened->records()) {
    ASSERT_TRUE(reopened->ReadFrame(record).ok()) << record.file;
  }
}

}  // namespace
}  // namespace loom::scan
