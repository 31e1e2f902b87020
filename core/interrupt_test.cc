#include "core/interrupt.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>

namespace loom {
namespace {

TEST(InterruptTest, WithinAScopeSigintAndSigtermSetTheFlagInsteadOfKilling) {
  InterruptScope scope;
  SetInterruptRequested(false);
  EXPECT_FALSE(InterruptRequested());
  std::raise(SIGINT);
  EXPECT_TRUE(InterruptRequested());  // still alive, flag set
  SetInterruptRequested(false);
  std::raise(SIGTERM);
  EXPECT_TRUE(InterruptRequested());
  SetInterruptRequested(false);
}

// Scopes nest (a demo's calibration scan beside its material scan); after the last, SIGTERM
// kills again. Checked in a child process, which the signal ends.
TEST(InterruptTest, AfterTheLastScopeSigtermEndsTheProcessAgain) {
  const pid_t child = fork();
  ASSERT_NE(child, -1);
  if (child == 0) {
    {
      InterruptScope outer;
      { InterruptScope inner; }
      std::raise(SIGTERM);  // the outer scope still holds: the flag, not the end
      if (!InterruptRequested()) _exit(3);
    }
    std::raise(SIGTERM);
    _exit(0);  // not reached if SIGTERM has its default action back
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status)) << "exited with " << WEXITSTATUS(status);
  EXPECT_EQ(WTERMSIG(status), SIGTERM);
}

}  // namespace
}  // namespace loom
