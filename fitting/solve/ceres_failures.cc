#include "fitting/solve/ceres_failures.h"

#include <glog/logging.h>
#include <unistd.h>

#include <cstring>

namespace loom::fitting {
namespace {

constexpr int kExitFailure = 1;

// glog takes a pointer to a function whose type is noreturn: the GNU attribute, unlike [[noreturn]],
// is part of the type for clang as well as GCC.
__attribute__((noreturn)) void ExitOnFailedCheck() {
  // Only async-signal-safe calls: glog calls this with its own locks held, possibly mid-solve.
  static constexpr char kMessage[] =
      "\nerror: internal: a check inside Ceres failed (the line above names it); nothing of this run was kept. "
      "This is a bug in loom or Ceres: please report it with the command that led to it.\n";
  if (::write(STDERR_FILENO, kMessage, std::strlen(kMessage)) < 0) {
    // Nothing more can be said.
  }
  ::_exit(kExitFailure);
}

}  // namespace

void StartCeresLogging(const char* program) {
  google::InitGoogleLogging(program);
  FLAGS_minloglevel = google::GLOG_ERROR;
  FLAGS_logtostderr = true;
  google::InstallFailureFunction(&ExitOnFailedCheck);
}

}  // namespace loom::fitting
