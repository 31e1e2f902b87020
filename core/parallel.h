#pragma once
// ParallelFor: indices 0..count-1 handed out one at a time to `threads` workers (0 = one per
// core), so uneven work (pixels whose fits take longer) balances itself. `on_progress(done)` is
// called on the calling thread about every `progress_period_s` and once at the end. `body` must
// be safe to run concurrently for different indices. If it throws (a failed LOOM_CHECK, say), no
// further index is started and the first exception is rethrown on the calling thread once every
// worker has stopped — an error for the caller, not std::terminate.

#include <functional>

namespace loom {

int ThreadCount(int requested);  // 0 → one per core, at least 1

void ParallelFor(int count, int threads, const std::function<void(int index)>& body,
                 const std::function<void(int done)>& on_progress = {}, double progress_period_s = 0.25);

}  // namespace loom
