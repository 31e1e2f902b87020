// The paper's CNN (fitting/cnn/cnn.h) on this CPU, random weights, fp32:
//  - inference of a paper-size material (630 × 630 px × 934 channels; --benchmark_filter=/126
//    for a quicker 126 × 126) dense and fully convolutional, in equal tiles of at most 256² + halo (3 × 3 of 210² at 630);
//  - the sliding window, one 15 × 15 patch per pixel as the paper infers, on 512 pixels of the
//    same input (a whole 630² would take half an hour): the dense_vs_sliding ratio compares
//    pixels per second of the two;
//  - training throughput (patch samples per second) on dense tiles, for the paper's widths and
//    for the 1/8-width model shipped for tac7-mini (232 input channels).
// Counters: pixels or samples per second, FLOPs per pixel (the architecture's multiply-adds × 2;
// training counts forward + backward as 3 × forward), achieved GFLOP/s, and the process's peak
// resident memory after the benchmark (getrusage; it only grows, so benchmarks run small first).
// Rates are per second of wall time (UseRealTime): the work runs on loom's and torch's threads,
// whose CPU time the main thread's does not count (per second of the main thread's CPU time, the
// rates are overstated: 281 GFLOP/s on 2 cores).
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <random>
#include <thread>

#include "bench/bench_report.h"
#include "fitting/cnn/cnn.h"
#include "fitting/cnn/cnn_training.h"
#include "fitting/model/label.h"

namespace {

using loom::fitting::Cnn;
using loom::fitting::CnnModelInfo;
using loom::fitting::CnnTensor;

const int kThreads = std::max(1u, std::thread::hardware_concurrency());

double PeakResidentGiB() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / (1024.0 * 1024.0);  // ru_maxrss is in KiB
}

Cnn MakeCnn(int channels, int width_divisor) {
  CnnModelInfo info;
  info.architecture = {.input_channels = channels, .width_divisor = width_divisor};
  info.observation_groups.assign(channels - loom::fitting::kCnnGeometryChannels, loom::ObservationGroup::kMonochrome);
  return std::move(*Cnn::Create(info, 1));
}

CnnTensor RandomInput(int channels, int size) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  CnnTensor input{channels, size, size, std::vector<float>(static_cast<size_t>(channels) * size * size)};
  for (float& v : input.values) v = unit(rng);
  return input;
}

void SetCounters(benchmark::State& state, double items, double flops_per_item) {
  state.SetItemsProcessed(static_cast<int64_t>(items));
  state.counters["flops_per_pixel"] = flops_per_item;
  state.counters["gflops_per_second"] = benchmark::Counter(items * flops_per_item * 1e-9, benchmark::Counter::kIsRate);
  state.counters["peak_resident_gib"] = PeakResidentGiB();
}

void BM_PaperDense(benchmark::State& state) {
  const int size = static_cast<int>(state.range(0));
  const Cnn cnn = MakeCnn(934, 1);
  const CnnTensor input = RandomInput(934, size);
  for (auto _ : state) benchmark::DoNotOptimize(cnn.PredictDense(input, loom::fitting::kDenseTile, kThreads));
  SetCounters(state, static_cast<double>(state.iterations()) * size * size, cnn.info().architecture.DenseFlopsPerPixel());
}

void BM_PaperSliding(benchmark::State& state) {
  const int size = static_cast<int>(state.range(0));
  const int pixels = 512;
  const Cnn cnn = MakeCnn(934, 1);
  const CnnTensor input = RandomInput(934, size);
  for (auto _ : state) benchmark::DoNotOptimize(cnn.PredictSliding(input, size * size / 2, pixels, 256, kThreads));
  SetCounters(state, static_cast<double>(state.iterations()) * pixels, cnn.info().architecture.SlidingFlopsPerPixel());
}

// One epoch of `steps` Adam steps of 4 tiles of 32² outputs on a random 64² material.
void BM_Training(benchmark::State& state) {
  const int channels = static_cast<int>(state.range(0)), divisor = static_cast<int>(state.range(1));
  Cnn cnn = MakeCnn(channels, divisor);
  loom::fitting::CnnExample example{"random", RandomInput(channels, 64), {}, nullptr};
  example.labels.labels = {loom::fitting::kLabelSize, 64, 64, std::vector<float>(loom::fitting::kLabelSize * 64 * 64, 0.5f)};
  example.labels.valid.assign(64 * 64, 1);
  loom::fitting::CnnTrainingOptions options;
  options.epochs = 1;
  options.steps_per_epoch = divisor == 1 ? 2 : 20;
  options.threads = kThreads;
  double samples_per_second = 0;
  for (auto _ : state) {
    const auto history = loom::fitting::TrainCnn(cnn, {example}, {example}, options);
    if (!history.ok()) {
      state.SkipWithError(history.status().ToString().c_str());
      return;
    }
    samples_per_second = history->back().samples_per_second;
  }
  // The epoch includes a validation pass: report the training steps' own rate.
  state.counters["samples_per_second"] = samples_per_second;
  state.counters["gflops_per_second"] = samples_per_second * 3 * cnn.info().architecture.DenseFlopsPerPixel() * 1e-9;
  state.counters["peak_resident_gib"] = PeakResidentGiB();
}

BENCHMARK(BM_Training)->Args({232, 8})->Args({934, 1})->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_PaperSliding)->Arg(126)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_PaperDense)->Arg(126)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_PaperDense)->Arg(630)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  return loom::bench::RunBenchmarks(
      argc, argv, "cnn", "The paper's CNN on the CPU: dense vs sliding-window inference, training throughput",
      {{"dense_vs_sliding_126", "BM_PaperDense/126/iterations:1", "BM_PaperSliding/126/iterations:1"},
       {"dense_630_vs_sliding", "BM_PaperDense/630/iterations:1", "BM_PaperSliding/126/iterations:1"}});
}
