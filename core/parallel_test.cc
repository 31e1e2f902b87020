#include "core/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <vector>

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

}  // namespace
}  // namespace loom
