#include "core/interrupt.h"

#include <atomic>
#include <csignal>
#include <mutex>

namespace loom {
namespace {

std::atomic<bool> g_interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free, "needed in a signal handler");

// The scopes alive, and the actions SIGINT and SIGTERM had before the first of them.
std::mutex g_scopes_mutex;
int g_scopes = 0;
struct sigaction g_previous_sigint {};
struct sigaction g_previous_sigterm {};

extern "C" void OnInterruptSignal(int signal_number) {
  if (g_interrupted.exchange(true) && signal_number == SIGINT) {
    std::signal(SIGINT, SIG_DFL);
    std::raise(SIGINT);
  }
}

}  // namespace

InterruptScope::InterruptScope() {
  std::lock_guard lock(g_scopes_mutex);
  if (g_scopes++ > 0) return;
  struct sigaction action {};
  action.sa_handler = OnInterruptSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;  // no SA_RESTART: blocking waits return EINTR and notice the flag sooner
  sigaction(SIGINT, &action, &g_previous_sigint);
  sigaction(SIGTERM, &action, &g_previous_sigterm);
}

InterruptScope::~InterruptScope() {
  std::lock_guard lock(g_scopes_mutex);
  if (--g_scopes > 0) return;
  sigaction(SIGINT, &g_previous_sigint, nullptr);
  sigaction(SIGTERM, &g_previous_sigterm, nullptr);
}

bool InterruptRequested() { return g_interrupted.load(); }

void SetInterruptRequested(bool requested) { g_interrupted.store(requested); }

}  // namespace loom
