#include "core/interrupt.h"

#include <gtest/gtest.h>

#include <csignal>

namespace loom {
namespace {

TEST(InterruptTest, SigintSetsTheFlagInsteadOfKilling) {
  InstallInterruptHandler();
  SetInterruptRequested(false);
  EXPECT_FALSE(InterruptRequested());
  std::raise(SIGINT);
  EXPECT_TRUE(InterruptRequested());  // still alive, flag set
  SetInterruptRequested(false);
  std::raise(SIGTERM);
  EXPECT_TRUE(InterruptRequested());
  SetInterruptRequested(false);
}

}  // namespace
}  // namespace loom
