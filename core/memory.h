#pragma once
// Sizes checked before they are allocated: a request that cannot fit in the machine's memory is
// a clear error naming what asked for it and how much it needs, not a std::bad_alloc (or minutes
// of swapping) halfway through a command.

#include <cstdint>
#include <string>

#include "core/status.h"

namespace loom {

// What the machine can give a process now without swapping: /proc/meminfo's MemAvailable, or the
// physical memory where that is not known.
uint64_t AvailableMemoryBytes();

// An error naming `what` (an option, a file) when `bytes` exceed AvailableMemoryBytes().
Status CheckFitsInMemory(uint64_t bytes, const std::string& what);

// `bytes` as people read it: "1.5 GB", "320 MB".
std::string ReadableBytes(uint64_t bytes);

}  // namespace loom
