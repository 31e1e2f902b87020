#pragma once
// The time a rig waits on. A real rig waits wall time (SteadyClock); a simulated one waits
// virtual time (SimClock), so that a simulated scan honours and records the rig's settle times
// exactly as a real one would without sleeping through them. Rig picks SimClock when every
// device's backend is simulated (BackendRegistry::MarkSimulated), SteadyClock otherwise.

#include "core/status.h"

namespace loom::hal {

class Clock {
 public:
  virtual ~Clock() = default;
  // Seconds since an arbitrary start.
  virtual double NowS() = 0;
  // Waits `seconds` (≤ 0: not at all); Cancelled when Ctrl-C arrives meanwhile (core/interrupt.h).
  virtual Status SleepFor(double seconds) = 0;
};

class SteadyClock final : public Clock {
 public:
  double NowS() override;
  Status SleepFor(double seconds) override;
};

// Virtual time: starts at 0, and SleepFor() advances it at once.
class SimClock final : public Clock {
 public:
  double NowS() override { return now_s_; }
  Status SleepFor(double seconds) override;

 private:
  double now_s_ = 0;
};

}  // namespace loom::hal
