#include "core/memory.h"

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>

namespace loom {

uint64_t AvailableMemoryBytes() {
  std::ifstream meminfo("/proc/meminfo");
  for (std::string line; std::getline(meminfo, line);) {
    uint64_t kib = 0;
    if (std::sscanf(line.c_str(), "MemAvailable: %lu kB", &kib) == 1) return kib * 1024;
  }
  return static_cast<uint64_t>(::sysconf(_SC_PHYS_PAGES)) * static_cast<uint64_t>(::sysconf(_SC_PAGESIZE));
}

std::string ReadableBytes(uint64_t bytes) {
  std::ostringstream text;
  text.precision(bytes >= 10'000'000'000ull || bytes < 1'000'000'000ull ? 0 : 1);
  text << std::fixed;
  if (bytes >= 1'000'000'000ull) {
    text << static_cast<double>(bytes) / 1e9 << " GB";
  } else {
    text << static_cast<double>(bytes) / 1e6 << " MB";
  }
  return text.str();
}

Status CheckFitsInMemory(uint64_t bytes, const std::string& what) {
  const uint64_t available = AvailableMemoryBytes();
  if (bytes <= available) return Status::Ok();
  return OutOfRangeError(what, "needs about " + ReadableBytes(bytes) + " of memory and this machine has " +
                                   ReadableBytes(available) + " available: make it smaller");
}

}  // namespace loom
