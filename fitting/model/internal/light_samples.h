#pragma once
// The light samples of one stack observation's emitters at one pixel, worked out for all its
// emitters at once: a strip's 32 emitters, thousands per pixel, were a tenth of a tac7-mini fit
// one at a time (perf, docs/benchmarks.md). The emitters are kept as arrays (one per
// coordinate) so that the compiler vectorises the loop across them.

#include <vector>

#include <Eigen/Core>

#include "core/observation_stack.h"

namespace loom::fitting::internal {

struct EmitterArrays {
  std::vector<double> x, y, z;     // position, sample frame (mm)
  std::vector<double> ax, ay, az;  // unit axis, where it emits most
  std::vector<double> intensity;   // along the axis
  std::vector<double> falloff_exponent;

  explicit EmitterArrays(const std::vector<PointEmitter>& emitters);
  int size() const { return static_cast<int>(x.size()); }
};

// Per emitter, its unit direction from the pixel in the pixel's local frame and the irradiance
// it sends the pixel (I(−l) / d², PointEmitter::IntensityAlong; 0 where it faces away).
struct LightGeometry {
  std::vector<double> lx, ly, lz, irradiance;
  std::vector<double> cosine;  // of the angle off the emitter's axis (negative: facing away)
};

// LightGeometry of `emitters` at `p` (sample frame), `local_from_sample` the pixel's frame: what
// PointEmitter gives one at a time, to rounding (one reciprocal instead of four divisions).
void LightGeometryAt(const EmitterArrays& emitters, const Eigen::Vector3d& p, const Eigen::Matrix3d& local_from_sample,
                     LightGeometry& out);

}  // namespace loom::fitting::internal
