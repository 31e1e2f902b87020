#pragma once
// Wall time as loom reports it: measured on the steady clock, shown as "1 h 2 min 5 s".

#include <chrono>
#include <string>

namespace loom {

inline double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// "0 min 41 s"; hours only when there are any.
std::string FormatDuration(double seconds);

}  // namespace loom
