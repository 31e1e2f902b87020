// BRDF evaluations per second: the GD10 Ward model in double and float, evaluated the naive way
// (one call per (l, v), preparing the anisotropy frame every time) and batched (one parameter
// set prepared once for many directions; many pixels × their observations).
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "bench/bench_report.h"
#include "fitting/model/ward_gd10.h"

namespace {

using loom::Vec3;
using loom::fitting::WardParams;

constexpr size_t kDirections = 4096;  // per parameter set
constexpr size_t kPixels = 64;        // SVBRDF batch
constexpr size_t kObservationsPerPixel = 934;
// Arithmetic of one valid f_r·cos evaluation in WardLobe::Terms + EvaluateCos, counted by hand:
// 72 adds/multiplies/divides, 1 sqrt, 1 exp (each counted as one). Preparing the lobe (the
// naive path does it per evaluation) is overhead, not counted as useful work.
constexpr double kFlopsPerEvaluation = 74;

template <typename T>
struct Workload {
  std::vector<WardParams<T>> params;
  std::vector<Vec3<T>> l, v, out;
};

template <typename T>
Workload<T> MakeWorkload(size_t num_params, size_t per_param) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Workload<T> w;
  for (size_t p = 0; p < num_params; ++p) {
    WardParams<double> params;
    params.n_s = loom::DirectionFromSpherical(0.3 * unit(rng), 6.28 * unit(rng));
    params.a_d = {0.3, 0.2, 0.1};
    params.a_s = {0.1, 0.1, 0.1};
    params.sigma_x = 0.05 + 0.3 * unit(rng);
    params.sigma_y = 0.05 + 0.3 * unit(rng);
    params.alpha = unit(rng) - 0.5;
    params.f0 = 0.04;
    w.params.push_back(params.Cast<T>());
  }
  for (size_t i = 0; i < num_params * per_param; ++i) {
    // Upper-hemisphere directions as a rig produces them (light down to ~70° inclination).
    w.l.push_back(loom::DirectionFromSpherical(1.2 * unit(rng), 6.28 * unit(rng)).cast<T>());
    w.v.push_back(loom::DirectionFromSpherical(1.0 * unit(rng), 6.28 * unit(rng)).cast<T>());
  }
  w.out.resize(w.l.size());
  return w;
}

void SetWork(benchmark::State& state, size_t evaluations_per_iteration) {
  const double evaluations = static_cast<double>(state.iterations()) * evaluations_per_iteration;
  state.SetItemsProcessed(static_cast<int64_t>(evaluations));
  state.counters["flops_per_second"] = benchmark::Counter(evaluations * kFlopsPerEvaluation, benchmark::Counter::kIsRate);
}

template <typename T>
void BM_WardNaive(benchmark::State& state) {
  Workload<T> w = MakeWorkload<T>(1, kDirections);
  for (auto _ : state) {
    for (size_t i = 0; i < kDirections; ++i) {
      w.out[i] = loom::fitting::EvaluateWardCos(w.params[0], w.l[i], w.v[i]);
    }
    benchmark::DoNotOptimize(w.out.data());
    benchmark::ClobberMemory();
  }
  SetWork(state, kDirections);
}

template <typename T>
void BM_WardBatched(benchmark::State& state) {
  Workload<T> w = MakeWorkload<T>(1, kDirections);
  for (auto _ : state) {
    loom::fitting::EvaluateWardCosBatch<T>(w.params[0], w.l, w.v, w.out);
    benchmark::DoNotOptimize(w.out.data());
    benchmark::ClobberMemory();
  }
  SetWork(state, kDirections);
}

template <typename T>
void BM_SvbrdfBatched(benchmark::State& state) {
  Workload<T> w = MakeWorkload<T>(kPixels, kObservationsPerPixel);
  for (auto _ : state) {
    loom::fitting::EvaluateSvbrdfCosBatch<T>(w.params, kObservationsPerPixel, w.l, w.v, w.out);
    benchmark::DoNotOptimize(w.out.data());
    benchmark::ClobberMemory();
  }
  SetWork(state, kPixels * kObservationsPerPixel);
}

BENCHMARK(BM_WardNaive<double>);
BENCHMARK(BM_WardBatched<double>);
BENCHMARK(BM_SvbrdfBatched<double>);
BENCHMARK(BM_WardNaive<float>);
BENCHMARK(BM_WardBatched<float>);
BENCHMARK(BM_SvbrdfBatched<float>);

}  // namespace

int main(int argc, char** argv) {
  return loom::bench::RunBenchmarks(argc, argv, "bench_brdf",
                                    "GD10 Ward BRDF f_r*cos evaluations per second (items = evaluations, RGB), one thread",
                                    {{"batched_vs_naive_double", "BM_WardBatched<double>", "BM_WardNaive<double>"},
                                     {"batched_vs_naive_float", "BM_WardBatched<float>", "BM_WardNaive<float>"},
                                     {"float_vs_double_batched", "BM_WardBatched<float>", "BM_WardBatched<double>"},
                                     {"svbrdf_vs_naive_float", "BM_SvbrdfBatched<float>", "BM_WardNaive<float>"}});
}
