#include "fitting/model/internal/light_samples.h"

#include <cmath>

#include "core/cpu_clones.h"
#include "core/geometry.h"

namespace loom::fitting::internal {

EmitterArrays::EmitterArrays(const std::vector<PointEmitter>& emitters) {
  for (const PointEmitter& e : emitters) {
    x.push_back(e.position_mm.x()), y.push_back(e.position_mm.y()), z.push_back(e.position_mm.z());
    ax.push_back(e.axis.x()), ay.push_back(e.axis.y()), az.push_back(e.axis.z());
    intensity.push_back(e.intensity);
    falloff_exponent.push_back(e.falloff_exponent);
  }
}

// LOOM_CPU_CLONES: the loop runs 8 (AVX-512) or 4 (AVX2) emitters per instruction where the
// processor has them. fitting/CMakeLists.txt keeps this file's floating point exact (no
// contraction into FMAs, no -ffast-math), so every clone gives the scalar code's numbers.
LOOM_CPU_CLONES void LightGeometryAt(const EmitterArrays& e, const Eigen::Vector3d& p, const Eigen::Matrix3d& local_from_sample,
                                     LightGeometry& out) {
  const int n = e.size();
  out.lx.resize(n), out.ly.resize(n), out.lz.resize(n), out.irradiance.resize(n), out.cosine.resize(n);
  const double px = p.x(), py = p.y(), pz = p.z();
  const Eigen::Matrix3d& r = local_from_sample;
  const double r00 = r(0, 0), r01 = r(0, 1), r02 = r(0, 2), r10 = r(1, 0), r11 = r(1, 1), r12 = r(1, 2);
  const double r20 = r(2, 0), r21 = r(2, 1), r22 = r(2, 2);
  const double* ex = e.x.data();
  const double* ey = e.y.data();
  const double* ez = e.z.data();
  const double* ax = e.ax.data();
  const double* ay = e.ay.data();
  const double* az = e.az.data();
  const double* intensity = e.intensity.data();
  double* lx = out.lx.data();
  double* ly = out.ly.data();
  double* lz = out.lz.data();
  double* irradiance = out.irradiance.data();
  double* cosine = out.cosine.data();
  // A falloff exponent of 1 (every emitter of loom's rigs) here, branch-free; others below.
  // (ivdep: the arrays are distinct vectors; GCC does not take __restrict on locals, and
  // checking the 12 pointers against each other at run time is more than it will version for.)
#pragma GCC ivdep
  for (int i = 0; i < n; ++i) {
    const double tx = ex[i] - px, ty = ey[i] - py, tz = ez[i] - pz;
    const double distance2 = tx * tx + ty * ty + tz * tz;
    // One division for the four quotients: a 512-bit division takes as long as 16 multiplies.
    const double inverse = 1 / std::sqrt(distance2);
    const double ux = tx * inverse, uy = ty * inverse, uz = tz * inverse;
    const double c = ax[i] * -ux + ay[i] * -uy + az[i] * -uz;  // the axis against −l
    cosine[i] = c;
    irradiance[i] = intensity[i] * (c > 0 ? c : 0.0) * (inverse * inverse);
    lx[i] = r00 * ux + r01 * uy + r02 * uz;
    ly[i] = r10 * ux + r11 * uy + r12 * uz;
    lz[i] = r20 * ux + r21 * uy + r22 * uz;
  }
  // Other falloffs: the linear one's irradiance turned into theirs (std::pow does not vectorise).
  for (int i = 0; i < n; ++i) {
    const double exponent = e.falloff_exponent[i];
    if (exponent != 1 && irradiance[i] > 0) irradiance[i] *= CosinePower(cosine[i], exponent) / cosine[i];
  }
}

}  // namespace loom::fitting::internal
