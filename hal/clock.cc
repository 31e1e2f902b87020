#include "hal/clock.h"

#include <algorithm>
#include <chrono>
#include <thread>

#include "core/interrupt.h"

namespace loom::hal {

double SteadyClock::NowS() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

Status SteadyClock::SleepFor(double seconds) {
  // In slices, so that Ctrl-C during a long settle stops the scan within 50 ms.
  constexpr double kSliceS = 0.05;
  const double until = NowS() + seconds;
  for (double left = seconds; left > 0; left = until - NowS()) {
    if (InterruptRequested()) return CancelledError("rig", "interrupted while waiting for the devices to settle");
    std::this_thread::sleep_for(std::chrono::duration<double>(std::min(left, kSliceS)));
  }
  return Status::Ok();
}

Status SimClock::SleepFor(double seconds) {
  if (InterruptRequested()) return CancelledError("rig", "interrupted while waiting for the devices to settle");
  now_s_ += std::max(seconds, 0.0);
  return Status::Ok();
}

}  // namespace loom::hal
