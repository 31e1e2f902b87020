#include "core/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "core/check.h"

namespace loom {
namespace {

TEST(ParallelForTest, RunsEveryIndexOnceAndReportsTheEnd) {
  std::vector<std::atomic<int>> runs(1000);
  int last_progress = -1;
  ParallelFor(
      1000, 3, [&](int i) { ++runs[i]; }, [&](int done) { last_progress = done; });
  for (const std::atomic<int>& r : runs) EXPECT_EQ(r.load(), 1);
  EXPECT_EQ(last_progress, 1000);
}

TEST(ParallelForTest, NothingToDoIsFine) {
  int calls = 0;
  ParallelFor(0, 2, [&](int) { ++calls; });
  EXPECT_EQ(calls, 0);
}

// A worker that throws (a failed check) must not take the process down with std::terminate:
// the exception reaches the caller, and no index starts after it. Every other index takes 1 ms,
// so that the second worker cannot finish the remaining second of work while the exception is
// being thrown and recorded (with instant indices it sometimes did, on a loaded machine).
TEST(ParallelForTest, AThrowInAWorkerIsRethrownOnTheCallingThread) {
  std::atomic<int> started{0};
  EXPECT_THROW(ParallelFor(1000, 2,
                           [&](int i) {
                             ++started;
                             if (i == 10) throw std::runtime_error("pixel 10");
                             std::this_thread::sleep_for(std::chrono::milliseconds(1));
                           }),
               std::runtime_error);
  EXPECT_LT(started.load(), 1000);
  try {
    ParallelFor(4, 1, [](int i) { LOOM_CHECK(i < 2) << "index " << i; });
    ADD_FAILURE() << "no exception";
  } catch (const CheckError& e) {
    EXPECT_NE(std::string(e.what()).find("index 2"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace loom
