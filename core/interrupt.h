#pragma once
// Cooperative interruption (Ctrl-C). InstallInterruptHandler() makes SIGINT and SIGTERM set a
// flag instead of killing the process; long operations (device waits, scans, fits) poll
// InterruptRequested() and return a Cancelled status, so every exit path runs its cleanup — in
// particular the rig's safe-state guard. A second SIGINT while the flag is set terminates at once
// (default action), for a process stuck outside any polling loop.
// Thread-safety: all functions are safe from any thread; the handler is async-signal-safe.

namespace loom {

void InstallInterruptHandler();
bool InterruptRequested();
// Sets or clears the flag (tests; and a caller that has handled an interruption).
void SetInterruptRequested(bool requested);

}  // namespace loom
