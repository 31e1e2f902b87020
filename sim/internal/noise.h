#pragma once
// Deterministic randomness for the simulator: the same seed gives the same numbers on every
// platform (std::uniform_real_distribution does not promise that; these do).

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace loom::sim::internal {

// SplitMix64: a fast, well-mixed 64-bit hash.
inline uint64_t Mix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// A uniform double in [0, 1) from a 64-bit value.
inline double ToUnit(uint64_t x) { return static_cast<double>(x >> 11) * 0x1.0p-53; }

// Hash of (seed, a, b) to [0, 1).
inline double Hash01(uint64_t seed, uint64_t a, uint64_t b) {
  return ToUnit(Mix(Mix(Mix(seed) ^ a) ^ (b * 0x632BE59BD9B4E019ull)));
}

// Smooth value noise in [0, 1) on a unit grid.
inline double ValueNoise(uint64_t seed, double x, double y) {
  const double fx = std::floor(x);
  const double fy = std::floor(y);
  const auto corner = [&](double cx, double cy) {
    return Hash01(seed, static_cast<uint64_t>(static_cast<int64_t>(cx)), static_cast<uint64_t>(static_cast<int64_t>(cy)));
  };
  const double tx = x - fx;
  const double ty = y - fy;
  const double sx = tx * tx * (3 - 2 * tx);
  const double sy = ty * ty * (3 - 2 * ty);
  const double top = corner(fx, fy) + sx * (corner(fx + 1, fy) - corner(fx, fy));
  const double bottom = corner(fx, fy + 1) + sx * (corner(fx + 1, fy + 1) - corner(fx, fy + 1));
  return top + sy * (bottom - top);
}

// A seeded stream of uniform numbers.
class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(Mix(seed)) {}
  double Uniform() { return ToUnit(Mix(state_++)); }
  // Standard normal (Box-Muller).
  double Normal() {
    const double u1 = std::max(Uniform(), 1e-300);
    const double u2 = Uniform();
    return std::sqrt(-2 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }

 private:
  uint64_t state_;
};

}  // namespace loom::sim::internal
