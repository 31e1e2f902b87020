#pragma once
// Ceres checks its own invariants with glog's CHECK, whose failure ends the process with a stack
// trace and SIGABRT. loom refuses what is known to reach such a check before Ceres runs (a
// non-finite start: pixel_fitter.h); for any other, StartCeresLogging makes a failed check an
// error: glog's line naming the check, then "error: …" and exit status 1, no backtrace and no
// core dump. A command's output directory is then left partial, which its next run removes
// (core/output_directory.h), as after a kill.

namespace loom::fitting {

// Once, before any Ceres solve: glog initialised for `program`, only errors and worse shown (a
// rejected Levenberg-Marquardt step is a warning, thousands of them over a material's pixels, and
// loom reports what went wrong in its own summaries), and a failed check an error exit.
void StartCeresLogging(const char* program);

}  // namespace loom::fitting
