#include "core/parallel.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace loom {

int ThreadCount(int requested) {
  return requested > 0 ? requested : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

void ParallelFor(int count, int threads, const std::function<void(int)>& body, const std::function<void(int)>& on_progress,
                 double progress_period_s) {
  std::atomic<int> next{0};
  std::atomic<int> done{0};
  std::atomic<bool> failed{false};
  std::exception_ptr first_failure;  // guarded by `mutex`
  std::mutex mutex;
  std::condition_variable finished;
  const int workers_wanted = std::min(ThreadCount(threads), std::max(count, 1));
  std::vector<std::thread> workers;
  for (int t = 0; t < workers_wanted; ++t) {
    workers.emplace_back([&] {
      for (int i = next++; i < count && !failed; i = next++) {
        try {
          body(i);
        } catch (...) {
          std::lock_guard lock(mutex);
          if (!first_failure) first_failure = std::current_exception();
          failed = true;
          finished.notify_all();
          return;
        }
        if (++done == count) {
          std::lock_guard lock(mutex);
          finished.notify_all();
        }
      }
    });
  }
  {
    std::unique_lock lock(mutex);
    const auto period = std::chrono::duration<double>(progress_period_s);
    while (!finished.wait_for(lock, period, [&] { return done.load() >= count || failed.load(); })) {
      if (on_progress) on_progress(done.load());
    }
  }
  for (std::thread& worker : workers) worker.join();
  if (first_failure) std::rethrow_exception(first_failure);
  if (on_progress) on_progress(count);
}

}  // namespace loom
