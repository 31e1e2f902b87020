#pragma once
// Cooperative interruption (Ctrl-C, SIGTERM) while a rig is driven. While an InterruptScope
// exists, SIGINT and SIGTERM set a flag instead of killing the process; long operations (device
// waits, scans, simulated frames) poll InterruptRequested() and return a Cancelled status, so
// every exit path runs its cleanup — in particular the rig's safe-state guard, which holds a
// scope. A second SIGINT while the flag is set terminates at once (default action), for a
// process stuck outside any polling loop. When the last scope ends, both signals get back the
// actions they had before: what runs after the rig is safe (a demo's fit and evaluation, say)
// has no cleanup a signal could skip, and a SIGTERM then ends it at once.
// Thread-safety: all functions are safe from any thread; the handler is async-signal-safe.

namespace loom {

class InterruptScope {
 public:
  InterruptScope();
  ~InterruptScope();
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;
};

bool InterruptRequested();
// Sets or clears the flag (tests; and a caller that has handled an interruption).
void SetInterruptRequested(bool requested);

}  // namespace loom
