// The batched refiner's kernel (refine_kernel.h). Compiled with -O3 -ffast-math (CMakeLists):
// fast-math lets GCC vectorise floor() and sqrt() in the lane loops, and exp() is the kernel's
// own (ExpOfNegative); the vectorisation report of this file (-fopt-info-vec,
// docs/benchmarks.md) confirms the loops over lanes are vectorised. EvaluateLanes is built three times (AVX-512, AVX2 + FMA,
// baseline SSE2) and the loader picks the best the processor has.
//
// Per light sample, with the notation of fitting/solve/pixel_cost.cc (its derivation holds here):
//   e = (h_t²/σx² + h_b²/σy²) / h_n²,  ward = exp(−e) / (4π σx σy c² h_n⁴),  spec = F · ward
//   L += E (w·a_d/π + w·a_s spec) (n·l)
// and the per-observation sums Σ E(n·l)/π, Σ E spec (n·l), Σ E (1−k) ward (n·l) give the
// albedo and F0 columns; σ, α and n accumulate per sample.
#include "fitting/solve/internal/refine_kernel.h"

#include <bit>
#include <cmath>
#include <cstdint>

#include "core/cpu_clones.h"

namespace loom::fitting::internal {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Below this h·n the lobe is nothing (exp(−e) underflows for any σ the fit allows); the floor
// only keeps masked-out terms finite, since fast-math multiplies them by 0 rather than branching.
constexpr float kMinHalfwayCosine = 1e-3f;
// pixel_cost.cc's threshold: exp(−60) times the largest normalisation is no measurable fraction of
// the diffuse term.
constexpr float kNegligibleLobeExponent = 60;
constexpr float kInversePi = static_cast<float>(1 / kPi);

// exp(−x) for x in [0, 80], inlined into the lane loops. libmvec's expf is a call, around which
// the loop's vectors are spilled, and it was 13 % of the main job's fit on its own (perf). Here
// x = n ln2 + r with |r| ≤ ln2/2 (Cody–Waite: ln2 split in two so that n ln2 is exact enough),
// exp(−r) by its Taylor polynomial of degree 6 (truncation ≤ 1.2e-7 relative), and 2^−n put
// into the exponent bits (n ≤ 116: a normal float). Relative error ~3e-7, within the kernel's
// stated rounding (kRadianceResolution); the kernel tests hold the cost to it.
[[gnu::always_inline]] inline float ExpOfNegative(float x) {
  const float n = std::floor(x * 1.44269504f + 0.5f);
  const float r = (x - n * 0.693145752f) - n * 1.42860677e-6f;
  const float y = -r;
  const float p = 1.0f + y * (1.0f + y * (0.5f + y * (1.0f / 6 + y * (1.0f / 24 + y * (1.0f / 120 + y * (1.0f / 720))))));
  const int32_t exponent = (127 - static_cast<int32_t>(n)) << 23;
  return p * std::bit_cast<float>(exponent);
}

// A light slot's parameter-free arrays as restrict pointers to its kLanes values, named as
// LaneData's members (locals, so that the vectoriser sees they do not alias).
#define SLOT_POINTERS(data, offset)                \
  const float* __restrict hx = &(data).hx[offset]; \
  const float* __restrict hy = &(data).hy[offset]; \
  const float* __restrict hz = &(data).hz[offset]; \
  const float* __restrict irradiance = &(data).irradiance[offset]

// A light sample's direction l, 1 / (l·h)² and Schlick's (1 − l·h)⁵, from its halfway vector h
// and the view v (unit vectors: l = 2 (v·h) h − v, and l·h = v·h). Computed here rather than
// stored, so that LaneData holds 4 floats a light slot instead of 9: loading a pixel into its
// lane writes a float into every 32-byte row of each array, through the whole batch, and that
// was a tenth of the main job's fit (perf). l·h > 0 for every real sample (l + v ≈ 0 is dropped
// when the lane is loaded); the floor keeps empty slots, whose h may be another pixel's, finite.
struct SlotGeometry {
  float lx, ly, lz, inv_c2, schlick;
};
[[gnu::always_inline]] inline SlotGeometry GeometryOf(float hx, float hy, float hz, float vx, float vy, float vz) {
  const float h_dot_v = hx * vx + hy * vy + hz * vz;
  const float c = h_dot_v > kMinHalfwayCosine ? h_dot_v : kMinHalfwayCosine;
  const float one_minus_c = 1 - c;
  const float squared = one_minus_c * one_minus_c;
  return {2 * h_dot_v * hx - vx, 2 * h_dot_v * hy - vy, 2 * h_dot_v * hz - vz, 1 / (c * c), squared * squared * one_minus_c};
}

#define LANES _Pragma("GCC ivdep") _Pragma("GCC unroll 1") for (int p = 0; p < kLanes; ++p)

// The lobe's parameter-dependent frame and constants, per lane: computed in double, kept in
// float for the sums over light samples. kSpan = 2 kLanes holds them twice, for two light slots
// side by side (SumLights).
template <int kSpan>
struct Lobe {
  alignas(64) float n[3][kSpan], t[3][kSpan], b[3][kSpan], t0[3][kSpan], dt[3][kSpan], db[3][kSpan];
  alignas(64) float t0_dot_n[kSpan], inv_t_prime[kSpan], inv_sx2[kSpan], inv_sy2[kSpan];
  alignas(64) float inv_sx[kSpan], inv_sy[kSpan], normalisation[kSpan], f0[kSpan];
};
using LaneLobe = Lobe<kLanes>;
constexpr int kSlotPair = 2 * kLanes;

// `lobe` twice over, lane p at p and p + kLanes.
Lobe<kSlotPair> Twice(const LaneLobe& lobe) {
  Lobe<kSlotPair> twice;
  const auto copy = [](const float* from, float* to) {
    for (int p = 0; p < kLanes; ++p) to[p] = to[p + kLanes] = from[p];
  };
  for (int c = 0; c < 3; ++c) {
    copy(lobe.n[c], twice.n[c]), copy(lobe.t[c], twice.t[c]), copy(lobe.b[c], twice.b[c]);
    copy(lobe.t0[c], twice.t0[c]), copy(lobe.dt[c], twice.dt[c]), copy(lobe.db[c], twice.db[c]);
  }
  copy(lobe.t0_dot_n, twice.t0_dot_n), copy(lobe.inv_t_prime, twice.inv_t_prime);
  copy(lobe.inv_sx2, twice.inv_sx2), copy(lobe.inv_sy2, twice.inv_sy2), copy(lobe.inv_sx, twice.inv_sx);
  copy(lobe.inv_sy, twice.inv_sy), copy(lobe.normalisation, twice.normalisation), copy(lobe.f0, twice.f0);
  return twice;
}

[[gnu::always_inline]] inline void PrepareLobe(const LaneInputs& in, LaneLobe& lobe) {
  const auto& x = in.params;
  LANES {
    const double n0 = x[0][p], n1 = x[1][p], n2 = x[2][p];
    const double inv_norm = 1 / std::sqrt(n0 * n0 + n1 * n1 + n2 * n2);
    const double nx = n0 * inv_norm, ny = n1 * inv_norm, nz = n2 * inv_norm;
    const double sx = x[9][p], sy = x[10][p], alpha = x[11][p];
    const double ca = std::cos(alpha), sa = std::sin(alpha);
    const double t0n = ca * nx + sa * ny;
    const double tpx = ca - t0n * nx, tpy = sa - t0n * ny, tpz = -t0n * nz;
    const double itp = 1 / std::sqrt(tpx * tpx + tpy * tpy + tpz * tpz);
    const double tx = tpx * itp, ty = tpy * itp, tz = tpz * itp;
    // ∂t/∂α from dt0 = (−sin α, cos α, 0).
    const double d0n = -sa * nx + ca * ny;
    const double dpx = -sa - d0n * nx, dpy = ca - d0n * ny, dpz = -d0n * nz;
    const double t_dot_dp = tx * dpx + ty * dpy + tz * dpz;
    const double dtx = (dpx - tx * t_dot_dp) * itp, dty = (dpy - ty * t_dot_dp) * itp, dtz = (dpz - tz * t_dot_dp) * itp;
    lobe.n[0][p] = nx, lobe.n[1][p] = ny, lobe.n[2][p] = nz;
    lobe.t[0][p] = tx, lobe.t[1][p] = ty, lobe.t[2][p] = tz;
    lobe.b[0][p] = ny * tz - nz * ty, lobe.b[1][p] = nz * tx - nx * tz, lobe.b[2][p] = nx * ty - ny * tx;
    lobe.t0[0][p] = ca, lobe.t0[1][p] = sa, lobe.t0[2][p] = 0;
    lobe.dt[0][p] = dtx, lobe.dt[1][p] = dty, lobe.dt[2][p] = dtz;
    lobe.db[0][p] = ny * dtz - nz * dty, lobe.db[1][p] = nz * dtx - nx * dtz, lobe.db[2][p] = nx * dty - ny * dtx;
    lobe.t0_dot_n[p] = t0n;
    lobe.inv_t_prime[p] = itp;
    lobe.inv_sx[p] = 1 / sx;
    lobe.inv_sy[p] = 1 / sy;
    lobe.inv_sx2[p] = 1 / (sx * sx);
    lobe.inv_sy2[p] = 1 / (sy * sy);
    lobe.normalisation[p] = 1 / (4 * kPi * sx * sy);
    lobe.f0[p] = x[12][p];
  }
}

// One observation's sums over its light samples, in single precision: one AVX2 register holds
// all 8 lanes (two in double), and exp() in float is cheaper than in double. An observation sums
// at most a strip's few dozen samples, so float's rounding (~1e-7 relative) stays well below the
// noise of any measured radiance; the residuals, the cost and the normal equations are in double.
template <int kSpan>
struct Sums {
  alignas(64) float radiance[kSpan], diffuse[kSpan], specular[kSpan], fresnel[kSpan];
  alignas(64) float sigma_x[kSpan], sigma_y[kSpan], alpha[kSpan], n[3][kSpan];
};
using ObservationSums = Sums<kLanes>;

// What an observation's light slots share, per lane: the colour-weighted albedos and the view.
template <int kSpan>
struct ObservationLanes {
  alignas(64) float diffuse_albedo[kSpan], specular_albedo[kSpan], v[3][kSpan];
};

// Adds the light slots from `slot` on (one for kSpan = kLanes, two for kSlotPair: they lie side
// by side in LaneData) to `s`, lane by lane.
template <int kSpan>
[[gnu::always_inline]] inline void AddSlots(const LaneData& d, const Lobe<kSpan>& lobe, const ObservationLanes<kSpan>& ob,
                                            int slot, Sums<kSpan>& s) {
  const int o = slot * kLanes;
  SLOT_POINTERS(d, o);
  const float* __restrict diffuse_albedo = ob.diffuse_albedo;
  const float* __restrict specular_albedo = ob.specular_albedo;
  _Pragma("GCC ivdep") _Pragma("GCC unroll 1") for (int p = 0; p < kSpan; ++p) {
    const auto [lx, ly, lz, inv_c2, schlick] = GeometryOf(hx[p], hy[p], hz[p], ob.v[0][p], ob.v[1][p], ob.v[2][p]);
    const float nx = lobe.n[0][p], ny = lobe.n[1][p], nz = lobe.n[2][p];
    const float n_dot_l = nx * lx + ny * ly + nz * lz;
    const float irradiance_p = irradiance[p];  // loaded unconditionally: a select vectorises, a branch not
    const float e = n_dot_l > 0 ? irradiance_p : 0.0f;
    const float h_t = hx[p] * lobe.t[0][p] + hy[p] * lobe.t[1][p] + hz[p] * lobe.t[2][p];
    const float h_b = hx[p] * lobe.b[0][p] + hy[p] * lobe.b[1][p] + hz[p] * lobe.b[2][p];
    const float h_n_raw = hx[p] * nx + hy[p] * ny + hz[p] * nz;
    const float h_n = h_n_raw > kMinHalfwayCosine ? h_n_raw : kMinHalfwayCosine;
    const float inv_h_n = 1 / h_n;
    const float inv_h_n2 = inv_h_n * inv_h_n;
    const float tx = h_t * lobe.inv_sx2[p], by = h_b * lobe.inv_sy2[p];
    const float exponent = (h_t * tx + h_b * by) * inv_h_n2;
    // Beyond kNegligibleLobeExponent the lobe is dropped, as the Ceres cost drops it; clamping
    // exp's argument keeps it within ExpOfNegative's range.
    const float negligible = exponent > kNegligibleLobeExponent ? 0.0f : 1.0f;
    const float clamped = exponent > kNegligibleLobeExponent ? kNegligibleLobeExponent : exponent;
    const float ward = negligible * ExpOfNegative(clamped) * lobe.normalisation[p] * inv_c2 * inv_h_n2 * inv_h_n2;
    const float fresnel = lobe.f0[p] + (1 - lobe.f0[p]) * schlick;
    const float specular = fresnel * ward;
    const float e_cos = e * n_dot_l;
    const float shading = e * (diffuse_albedo[p] * kInversePi + specular_albedo[p] * specular);
    s.radiance[p] += shading * n_dot_l;
    s.diffuse[p] += e_cos * kInversePi;
    s.specular[p] += e_cos * specular;
    s.fresnel[p] += e_cos * (1 - schlick) * ward;
    const float q = e_cos * specular_albedo[p] * specular;
    s.sigma_x[p] += q * lobe.inv_sx[p] * (2 * h_t * tx * inv_h_n2 - 1);
    s.sigma_y[p] += q * lobe.inv_sy[p] * (2 * h_b * by * inv_h_n2 - 1);
    const float h_dt = hx[p] * lobe.dt[0][p] + hy[p] * lobe.dt[1][p] + hz[p] * lobe.dt[2][p];
    const float h_db = hx[p] * lobe.db[0][p] + hy[p] * lobe.db[1][p] + hz[p] * lobe.db[2][p];
    s.alpha[p] -= q * 2 * (tx * h_dt + by * h_db) * inv_h_n2;
    // ∂h_t/∂n = −(t0 h_n + (t0·n)(h − t h_t)) / |t'|,  ∂h_b/∂n = t × h − (t0·n)(h × n − t h_b) / |t'|
    const float t0n_itp = lobe.t0_dot_n[p] * lobe.inv_t_prime[p];
    const float h_n_itp = h_n_raw * lobe.inv_t_prime[p];
    const float t0x = lobe.t0[0][p], t0y = lobe.t0[1][p];
    const float ttx = lobe.t[0][p], tty = lobe.t[1][p], ttz = lobe.t[2][p];
    const float dht_x = -(t0x * h_n_itp + t0n_itp * (hx[p] - ttx * h_t));
    const float dht_y = -(t0y * h_n_itp + t0n_itp * (hy[p] - tty * h_t));
    const float dht_z = -(t0n_itp * (hz[p] - ttz * h_t));
    const float hcn_x = hy[p] * nz - hz[p] * ny, hcn_y = hz[p] * nx - hx[p] * nz, hcn_z = hx[p] * ny - hy[p] * nx;
    const float dhb_x = (tty * hz[p] - ttz * hy[p]) - t0n_itp * (hcn_x - ttx * h_b);
    const float dhb_y = (ttz * hx[p] - ttx * hz[p]) - t0n_itp * (hcn_y - tty * h_b);
    const float dhb_z = (ttx * hy[p] - tty * hx[p]) - t0n_itp * (hcn_z - ttz * h_b);
    // ∂L/∂n = shading l + q (−4 h / h_n − ∂e/∂n),  ∂e/∂n = 2 (tx ∂h_t + by ∂h_b) / h_n² − 2 e h / h_n
    const float g2 = 2 * inv_h_n2;
    const float h_coeff = q * (2 * exponent - 4) * inv_h_n;
    s.n[0][p] += shading * lx + h_coeff * hx[p] - q * g2 * (tx * dht_x + by * dhb_x);
    s.n[1][p] += shading * ly + h_coeff * hy[p] - q * g2 * (tx * dht_y + by * dhb_y);
    s.n[2][p] += shading * lz + h_coeff * hz[p] - q * g2 * (tx * dht_z + by * dhb_z);
  }
}

template <int kSpan>
[[gnu::always_inline]] inline void Clear(Sums<kSpan>& s) {
  _Pragma("GCC ivdep") _Pragma("GCC unroll 1") for (int p = 0; p < kSpan; ++p) {
    s.radiance[p] = s.diffuse[p] = s.specular[p] = s.fresnel[p] = 0;
    s.sigma_x[p] = s.sigma_y[p] = s.alpha[p] = 0;
    s.n[0][p] = s.n[1][p] = s.n[2][p] = 0;
  }
}

// One observation's sums over its light slots [first, end), two slots at a time where it has
// them: each slot's chain (the lobe's exponent, exp()'s polynomial, the sums) is long and
// dependent, and two slots side by side fill an AVX-512 register (one slot's 8 floats fill half)
// or give AVX2's out-of-order core two chains at once. Every lane evaluates the whole model on
// every sample, so that a pixel's result does not depend on which pixels share its batch (the
// thread count, the order of work). A shortcut taken when no lane's lobe reaches a sample did:
// it rounded differently, and in float that changed where fits stopped; on this machine it saved
// nothing measurable.
[[gnu::always_inline]] inline void SumLights(const LaneData& d, const LaneLobe& lobe, const Lobe<kSlotPair>& lobe_twice,
                                             const ObservationLanes<kLanes>& ob, int first, int end, ObservationSums& s) {
  Clear(s);
  if (end - first < 2) {  // a point light: no pair to set up and fold (a point-lit fit took 8 % longer)
    if (first < end) AddSlots(d, lobe, ob, first, s);
    return;
  }
  ObservationLanes<kSlotPair> twice;
  LANES {
    twice.diffuse_albedo[p] = twice.diffuse_albedo[p + kLanes] = ob.diffuse_albedo[p];
    twice.specular_albedo[p] = twice.specular_albedo[p + kLanes] = ob.specular_albedo[p];
    for (int c = 0; c < 3; ++c) twice.v[c][p] = twice.v[c][p + kLanes] = ob.v[c][p];
  }
  Sums<kSlotPair> pair;
  Clear(pair);
  int slot = first;
  for (; slot + 2 <= end; slot += 2) AddSlots(d, lobe_twice, twice, slot, pair);
  if (slot < end) AddSlots(d, lobe, ob, slot, s);
  LANES {
    s.radiance[p] += pair.radiance[p] + pair.radiance[p + kLanes];
    s.diffuse[p] += pair.diffuse[p] + pair.diffuse[p + kLanes];
    s.specular[p] += pair.specular[p] + pair.specular[p + kLanes];
    s.fresnel[p] += pair.fresnel[p] + pair.fresnel[p + kLanes];
    s.sigma_x[p] += pair.sigma_x[p] + pair.sigma_x[p + kLanes];
    s.sigma_y[p] += pair.sigma_y[p] + pair.sigma_y[p + kLanes];
    s.alpha[p] += pair.alpha[p] + pair.alpha[p + kLanes];
    for (int c = 0; c < 3; ++c) s.n[c][p] += pair.n[c][p] + pair.n[c][p + kLanes];
  }
}

// Vectors of kWidth doubles: 8 is one zmm; 4 is one ymm. A vector wider than the target's
// registers is split by GCC, and on AVX2 an 8-wide one was split through general registers with
// its accumulators spilled: the Gram below took 57 % of the kernel there (perf).
// (A member typedef: GCC drops vector_size from an alias template, leaving a plain double.)
template <int kWidth>
struct Wide {
  typedef double Vector __attribute__((vector_size(kWidth * sizeof(double))));
};
template <int kWidth>
using WideVector = typename Wide<kWidth>::Vector;
static_assert(sizeof(WideVector<4>) == 4 * sizeof(double));

template <int kWidth>
[[gnu::always_inline]] inline WideVector<kWidth> Load(const double* p) {
  WideVector<kWidth> v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}

template <int kWidth>
[[gnu::always_inline]] inline void AddTo(double* p, WideVector<kWidth> v) {
  v += Load<kWidth>(p);
  __builtin_memcpy(p, &v, sizeof v);
}

// out[NormalIndex(i, j)] += Σ_k w_k g_ki g_kj (i ≤ j), per lane, kWidth lanes at a time, in
// kRows × kCols tiles whose accumulators stay in registers over a chunk's observations:
// accumulating into memory per observation (a load and a store per entry) had been half the work
// on point-lit stacks. A tile wholly below the diagonal is skipped.
template <int kWidth, int kRows, int kCols>
[[gnu::always_inline]] inline void Gram(const double* g, const double* w, int observations, double (*out)[kLanes]) {
  using Vector = WideVector<kWidth>;
  for (int lane = 0; lane < kLanes; lane += kWidth) {
    for (int bi = 0; bi < kTangentParams; bi += kRows) {
      for (int bj = 0; bj < kTangentParams; bj += kCols) {
        if (bj + kCols - 1 < bi) continue;
        Vector acc[kRows][kCols] = {};
        for (int k = 0; k < observations; ++k) {
          const double* gk = g + static_cast<size_t>(k) * kTangentParams * kLanes + lane;
          const Vector wk = Load<kWidth>(w + static_cast<size_t>(k) * kLanes + lane);
          Vector left[kRows];
          for (int a = 0; a < kRows; ++a) left[a] = wk * Load<kWidth>(gk + (bi + a) * kLanes);
          for (int b = 0; b < kCols; ++b) {
            const Vector right = Load<kWidth>(gk + (bj + b) * kLanes);
            for (int a = 0; a < kRows; ++a) acc[a][b] += left[a] * right;
          }
        }
        for (int a = 0; a < kRows; ++a) {
          for (int b = 0; b < kCols; ++b) {
            if (bi + a > bj + b) continue;
            AddTo<kWidth>(&out[NormalIndex(bi + a, bj + b)][lane], acc[a][b]);
          }
        }
      }
    }
  }
}

// out[i] += Σ_k g_ki v_k, per lane, kWidth lanes at a time.
template <int kWidth>
[[gnu::always_inline]] inline void Project(const double* g, const double* v, int observations, double (*out)[kLanes]) {
  using Vector = WideVector<kWidth>;
  for (int lane = 0; lane < kLanes; lane += kWidth) {
    Vector acc[kTangentParams] = {};
    for (int k = 0; k < observations; ++k) {
      const double* gk = g + static_cast<size_t>(k) * kTangentParams * kLanes + lane;
      const Vector vk = Load<kWidth>(v + static_cast<size_t>(k) * kLanes + lane);
      for (int i = 0; i < kTangentParams; ++i) acc[i] += Load<kWidth>(gk + i * kLanes) * vk;
    }
    for (int i = 0; i < kTangentParams; ++i) AddTo<kWidth>(&out[i][lane], acc[i]);
  }
}

// A chunk's sums over observations, added to out, with the vector width and tiles that fit the
// registers of the instruction set EvaluateLanes runs with: 32 zmm on AVX-512, 16 ymm on AVX2.
[[gnu::always_inline]] inline void SumObservations(const LaneData& d, int n, bool normal_equations, bool any_leverage,
                                                   LaneEquations& out) {
  static const bool wide = __builtin_cpu_supports("avx512f");
  const double* g = d.gradients.data();
  if (wide) {
    if (normal_equations) {
      Gram<8, 4, 4>(g, d.weights.data(), n, out.jtj);
      Project<8>(g, d.weighted_residuals.data(), n, out.jtr);
    }
    if (any_leverage) {  // the uncertainty's matrices only when some lane is at its solution
      Gram<8, 4, 4>(g, d.inlier_weights.data(), n, out.bread);
      Gram<8, 4, 4>(g, d.meat_weights.data(), n, out.meat);
    }
    return;
  }
  if (normal_equations) {
    Gram<4, 2, 4>(g, d.weights.data(), n, out.jtj);
    Project<4>(g, d.weighted_residuals.data(), n, out.jtr);
  }
  if (any_leverage) {
    Gram<4, 2, 4>(g, d.inlier_weights.data(), n, out.bread);
    Gram<4, 2, 4>(g, d.meat_weights.data(), n, out.meat);
  }
}

// Observation k's colour-weighted albedos and view, per lane, at [offset, offset + kLanes) of `ob`.
template <int kSpan>
[[gnu::always_inline]] inline void SetObservation(const LaneData& d, const LaneInputs& in, int k, int offset,
                                                  ObservationLanes<kSpan>& ob) {
  const int o = k * kLanes;
  LANES {
    ob.diffuse_albedo[offset + p] = d.wr[o + p] * in.params[3][p] + d.wg[o + p] * in.params[4][p] + d.wb[o + p] * in.params[5][p];
    ob.specular_albedo[offset + p] =
        d.wr[o + p] * in.params[6][p] + d.wg[o + p] * in.params[7][p] + d.wb[o + p] * in.params[8][p];
    ob.v[0][offset + p] = d.vx[o + p], ob.v[1][offset + p] = d.vy[o + p], ob.v[2][offset + p] = d.vz[o + p];
  }
}

// Observation k's residual, robust weights and gradient from its sums over light samples (at
// [offset, offset + kLanes) of `s` and `ob`), added to the cost and written into the chunk's
// scratch; the chunk's sums over observations once it is full.
template <int kSpan>
[[gnu::always_inline]] inline void AddObservation(const LaneData& d, const LaneInputs& in, const LaneLobe& lobe,
                                                  const ObservationLanes<kSpan>& ob, const Sums<kSpan>& s, int offset, int k,
                                                  bool any_leverage, LaneEquations& out) {
  const int o = k * kLanes;
  const int c = (k % kChunkObservations) * kLanes;  // in the chunk's scratch
  // The gradient, written where the chunk's sums over observations (Gram) will read it.
  double(*__restrict g)[kLanes] = reinterpret_cast<double(*)[kLanes]>(&d.gradients[static_cast<size_t>(c) * kTangentParams]);
  const double a = in.huber_scale;
  alignas(64) double weighted_r[kLanes], weight[kLanes], inlier_weight[kLanes];
  LANES {
    const int q = offset + p;
    // The model is 0 when the camera is below the shading normal's horizon.
    const double n_dot_v = lobe.n[0][p] * d.vx[o + p] + lobe.n[1][p] * d.vy[o + p] + lobe.n[2][p] * d.vz[o + p];
    const double inverse_scale = in.inverse_scale[p];
    const double seen = n_dot_v > 0 ? inverse_scale : 0.0;
    const double r = s.radiance[q] * seen - d.radiance[o + p] * inverse_scale;
    const double abs_r = std::fabs(r);
    const bool inlier = abs_r <= a;
    const double rho = inlier ? r * r : 2 * a * abs_r - a * a;
    const double w = d.weight[o + p] * (inlier ? 1.0 : a / (abs_r > 0 ? abs_r : 1.0));
    out.cost[p] += 0.5 * d.weight[o + p] * rho;
    out.squares[p] += d.weight[o + p] * r * r;
    // The cost's sensitivity to the radiance's rounding: ψ(r) L, ψ(r) = min(|r|, a) Huber's.
    const double sensitivity = (inlier ? abs_r : a) * s.radiance[q] * seen;
    out.cost_resolution[p] += d.weight[o + p] * sensitivity * sensitivity;
    weight[p] = w;
    inlier_weight[p] = inlier ? d.weight[o + p] : 0.0;
    weighted_r[p] = w * r;
    const double gn_x = s.n[0][q] * seen, gn_y = s.n[1][q] * seen, gn_z = s.n[2][q] * seen;
    g[0][p] = gn_x * in.tangent[0][0][p] + gn_y * in.tangent[0][1][p] + gn_z * in.tangent[0][2][p];
    g[1][p] = gn_x * in.tangent[1][0][p] + gn_y * in.tangent[1][1][p] + gn_z * in.tangent[1][2][p];
    const double diffuse = s.diffuse[q] * seen, specular = s.specular[q] * seen;
    g[2][p] = d.wr[o + p] * diffuse, g[3][p] = d.wg[o + p] * diffuse, g[4][p] = d.wb[o + p] * diffuse;
    g[5][p] = d.wr[o + p] * specular, g[6][p] = d.wg[o + p] * specular, g[7][p] = d.wb[o + p] * specular;
    g[8][p] = s.sigma_x[q] * seen;
    g[9][p] = s.sigma_y[q] * seen;
    g[10][p] = s.alpha[q] * seen;
    g[11][p] = ob.specular_albedo[q] * s.fresnel[q] * seen;
  }
  LANES {
    d.weights[c + p] = weight[p];
    d.weighted_residuals[c + p] = weighted_r[p];
  }
  if (any_leverage) {  // the uncertainty's weights, each observation's leverage in its meat
    alignas(64) double h[kLanes];
    LANES { h[p] = 0; }
    for (int i = 0; i < kTangentParams; ++i) {
      for (int j = i; j < kTangentParams; ++j) {
        const int e = NormalIndex(i, j);
        const double both = i == j ? 1.0 : 2.0;
        LANES { h[p] += both * g[i][p] * in.bread_inverse[e][p] * g[j][p]; }
      }
    }
    LANES {
      const double leverage = in.leverage[p] * weight[p] * h[p];
      const double kept = 1 - (leverage < 0.99 ? leverage : 0.99);
      d.inlier_weights[c + p] = inlier_weight[p];
      d.meat_weights[c + p] = weighted_r[p] * weighted_r[p] / kept;
    }
  }
  const bool chunk_full = (k + 1) % kChunkObservations == 0 || k + 1 == d.observations;
  if (chunk_full) SumObservations(d, k % kChunkObservations + 1, in.normal_equations, any_leverage, out);
}

}  // namespace

LOOM_CPU_CLONES void EvaluateLanes(const LaneData& d, const LaneInputs& in, LaneEquations& out) {
  LaneLobe lobe;
  PrepareLobe(in, lobe);
  const Lobe<kSlotPair> lobe_twice = Twice(lobe);
  LANES { out.cost[p] = out.squares[p] = out.cost_resolution[p] = 0; }
  for (int i = 0; i < kTangentParams; ++i) LANES {
      out.jtr[i][p] = 0;
    }
  for (int i = 0; i < kNormalEntries; ++i) LANES {
      out.jtj[i][p] = out.bread[i][p] = out.meat[i][p] = 0;
    }
  bool any_leverage = false;
  for (int p = 0; p < kLanes; ++p) any_leverage = any_leverage || in.leverage[p] != 0;
  const auto single_slot = [&d](int k) { return d.first_slot[k + 1] - d.first_slot[k] == 1; };
  for (int k = 0; k < d.observations;) {
    // Two point-lit observations side by side (their slots are adjacent), as SumLights pairs a
    // strip's samples: one observation's 8 floats fill half an AVX-512 register.
    if (k + 1 < d.observations && single_slot(k) && single_slot(k + 1)) {
      ObservationLanes<kSlotPair> both;
      SetObservation(d, in, k, 0, both);
      SetObservation(d, in, k + 1, kLanes, both);
      Sums<kSlotPair> pair;
      Clear(pair);
      AddSlots(d, lobe_twice, both, d.first_slot[k], pair);
      AddObservation(d, in, lobe, both, pair, 0, k, any_leverage, out);
      AddObservation(d, in, lobe, both, pair, kLanes, k + 1, any_leverage, out);
      k += 2;
      continue;
    }
    ObservationLanes<kLanes> ob;
    SetObservation(d, in, k, 0, ob);
    ObservationSums s;
    SumLights(d, lobe, lobe_twice, ob, d.first_slot[k], d.first_slot[k + 1], s);
    AddObservation(d, in, lobe, ob, s, 0, k, any_leverage, out);
    ++k;
  }
  // Roundings independent across observations add in quadrature.
  LANES { out.cost_resolution[p] = kRadianceResolution * std::sqrt(out.cost_resolution[p]); }
}

LOOM_CPU_CLONES void SumTermsLanes(const LaneData& d, const LaneInputs& in, double* diffuse, double* specular) {
  LaneLobe lobe;
  PrepareLobe(in, lobe);
  for (int k = 0; k < d.observations; ++k) {
    const int o = k * kLanes;
    alignas(32) float diffuse_sum[kLanes], specular_sum[kLanes], vx[kLanes], vy[kLanes], vz[kLanes];
    LANES {
      diffuse_sum[p] = specular_sum[p] = 0;
      vx[p] = d.vx[o + p], vy[p] = d.vy[o + p], vz[p] = d.vz[o + p];
    }
    for (int slot = d.first_slot[k]; slot < d.first_slot[k + 1]; ++slot) {
      const int i = slot * kLanes;
      SLOT_POINTERS(d, i);
      LANES {
        const auto [lx, ly, lz, inv_c2, schlick] = GeometryOf(hx[p], hy[p], hz[p], vx[p], vy[p], vz[p]);
        const float nx = lobe.n[0][p], ny = lobe.n[1][p], nz = lobe.n[2][p];
        const float n_dot_l = nx * lx + ny * ly + nz * lz;
        const float lit = irradiance[p] * n_dot_l;
        const float e_cos = n_dot_l > 0 ? lit : 0.0f;
        const float h_t = hx[p] * lobe.t[0][p] + hy[p] * lobe.t[1][p] + hz[p] * lobe.t[2][p];
        const float h_b = hx[p] * lobe.b[0][p] + hy[p] * lobe.b[1][p] + hz[p] * lobe.b[2][p];
        const float h_n_raw = hx[p] * nx + hy[p] * ny + hz[p] * nz;
        const float h_n = h_n_raw > kMinHalfwayCosine ? h_n_raw : kMinHalfwayCosine;
        const float inv_h_n2 = 1 / (h_n * h_n);
        const float exponent = (h_t * h_t * lobe.inv_sx2[p] + h_b * h_b * lobe.inv_sy2[p]) * inv_h_n2;
        // Clamped, not dropped: exp(−80) is nothing, and a select around exp() would turn it
        // into a branch that stops the loop from vectorising (it did here). 80, not more: the
        // range of ExpOfNegative.
        const float clamped = exponent > 80.0f ? 80.0f : exponent;
        const float ward = ExpOfNegative(clamped) * lobe.normalisation[p] * inv_c2 * inv_h_n2 * inv_h_n2;
        const float fresnel = lobe.f0[p] + (1 - lobe.f0[p]) * schlick;
        diffuse_sum[p] += e_cos * kInversePi;
        specular_sum[p] += e_cos * fresnel * ward;
      }
    }
    LANES {
      const double n_dot_v = lobe.n[0][p] * d.vx[o + p] + lobe.n[1][p] * d.vy[o + p] + lobe.n[2][p] * d.vz[o + p];
      const double seen = n_dot_v > 0 ? 1.0 : 0.0;
      diffuse[o + p] = diffuse_sum[p] * seen;
      specular[o + p] = specular_sum[p] * seen;
    }
  }
}

const char* RefineKernelIsa() {
#if defined(__clang__)
  return "x86-64 baseline (SSE2; clang builds no per-level clones: core/cpu_clones.h)";
#else
  __builtin_cpu_init();
  if (__builtin_cpu_supports("x86-64-v4")) return "x86-64-v4 (AVX-512)";
  if (__builtin_cpu_supports("x86-64-v3")) return "x86-64-v3 (AVX2, FMA)";
  return "x86-64 baseline (SSE2)";
#endif
}

LaneData::LaneData(const std::vector<int>& slots_per_observation) : observations(static_cast<int>(slots_per_observation.size())) {
  first_slot.push_back(0);
  for (int slots : slots_per_observation) first_slot.push_back(first_slot.back() + slots);
  const size_t per_observation = static_cast<size_t>(observations) * kLanes;
  const size_t per_slot = static_cast<size_t>(slots()) * kLanes;
  for (auto* v : {&radiance, &weight, &vx, &vy, &vz, &wr, &wg, &wb}) v->assign(per_observation, 0.0);
  const size_t per_chunk = static_cast<size_t>(kChunkObservations) * kLanes;
  for (auto* v : {&weights, &weighted_residuals, &inlier_weights, &meat_weights}) v->assign(per_chunk, 0.0);
  gradients.assign(per_chunk * kTangentParams, 0.0);
  for (auto* v : {&hx, &hy, &irradiance}) v->assign(per_slot, 0.0);
  hz.assign(per_slot, 1.0);
  vz.assign(per_observation, 1.0);
}

void LaneData::CopyLane(int lane, LaneData& to, int to_lane) const {
  const auto copy = [&]<typename Value>(const std::vector<Value>& from, std::vector<Value>& into, int count) {
    const Value* __restrict source = from.data() + lane;
    Value* __restrict target = into.data() + to_lane;
    for (int i = 0; i < count; ++i) target[i * kLanes] = source[i * kLanes];
  };
  for (auto member : {&LaneData::radiance, &LaneData::weight, &LaneData::vx, &LaneData::vy, &LaneData::vz, &LaneData::wr,
                      &LaneData::wg, &LaneData::wb}) {
    copy(this->*member, to.*member, observations);
  }
  for (auto member : {&LaneData::hx, &LaneData::hy, &LaneData::hz, &LaneData::irradiance}) {
    copy(this->*member, to.*member, slots());
  }
}

void LaneData::ClearLane(int lane) {
  // Weight and irradiance 0 silence a slot; the directions keep whatever finite values they had.
  for (int k = 0; k < observations; ++k) {
    const size_t i = static_cast<size_t>(k) * kLanes + lane;
    radiance[i] = weight[i] = 0;
  }
  for (int s = 0; s < slots(); ++s) irradiance[static_cast<size_t>(s) * kLanes + lane] = 0;
}

}  // namespace loom::fitting::internal
