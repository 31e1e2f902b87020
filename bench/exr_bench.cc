// OpenEXR write/read of a calibrated HDR stack at the paper's size: 630 × 630 pixels × 934 float
// channels (1.48 GB), uncompressed and ZIP, in loom's temporary directory ($TMPDIR or /tmp).
// The naive way for comparison: one EXR file per channel (how a stack is often kept as a
// folder of images) — same pixels, 934 files.
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <random>

#include "bench/bench_report.h"
#include "core/exr_io.h"

namespace {

namespace fs = std::filesystem;

constexpr int kWidth = 630;
constexpr int kHeight = 630;
constexpr int kChannels = 934;

const loom::Image& Stack() {
  static const loom::Image stack = [] {
    std::vector<std::string> names;
    for (int i = 0; i < kChannels; ++i) names.push_back("obs" + std::to_string(10000 + i).substr(1));
    loom::Image image(kWidth, kHeight, names);
    std::mt19937 rng(1);
    std::normal_distribution<float> noise(0.0f, 0.01f);
    for (int c = 0; c < kChannels; ++c) {
      // Smooth shading with sensor noise, like a radiance image of a fabric under one light.
      float* plane = image.channel(c).data();
      for (int y = 0; y < kHeight; ++y) {
        for (int x = 0; x < kWidth; ++x) {
          plane[y * kWidth + x] = 0.5f + 0.4f * std::sin(0.05f * x + 0.01f * c) * std::cos(0.07f * y) + noise(rng);
        }
      }
    }
    return image;
  }();
  return stack;
}

fs::path BenchDir() {
  const char* tmp = std::getenv("TMPDIR");
  fs::path dir = fs::path(tmp ? tmp : "/tmp") / "loom_bench_exr";
  fs::create_directories(dir);
  return dir;
}

void SetBytes(benchmark::State& state) {
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * kWidth * kHeight * kChannels *
                          static_cast<int64_t>(sizeof(float)));
}

void BM_WriteStack(benchmark::State& state, loom::ExrCompression compression) {
  const loom::Image& stack = Stack();
  const fs::path path = BenchDir() / "stack.exr";
  for (auto _ : state) {
    const loom::Status status = loom::WriteExr(path, stack, {}, {.compression = compression});
    if (!status.ok()) state.SkipWithError(status.ToString().c_str());
  }
  state.counters["file_bytes"] = static_cast<double>(fs::file_size(path));
  SetBytes(state);
}

void BM_ReadStack(benchmark::State& state, loom::ExrCompression compression) {
  const fs::path path = BenchDir() / "stack.exr";
  if (!loom::WriteExr(path, Stack(), {}, {.compression = compression}).ok()) {
    state.SkipWithError("cannot write the stack to read");
    return;
  }
  for (auto _ : state) {
    const loom::Result<loom::ExrImage> read = loom::ReadExr(path);
    if (!read.ok()) state.SkipWithError(read.status().ToString().c_str());
    benchmark::DoNotOptimize(read);
  }
  SetBytes(state);
}

void BM_WriteFilePerChannel(benchmark::State& state) {
  const loom::Image& stack = Stack();
  const fs::path dir = BenchDir() / "per_channel";
  fs::create_directories(dir);
  for (auto _ : state) {
    for (int c = 0; c < kChannels; ++c) {
      loom::Image one(kWidth, kHeight, {"Y"});
      std::copy(stack.channel(c).begin(), stack.channel(c).end(), one.channel(0).begin());
      const loom::Status status =
          loom::WriteExr(dir / (stack.channel_name(c) + ".exr"), one, {}, {.compression = loom::ExrCompression::kNone});
      if (!status.ok()) state.SkipWithError(status.ToString().c_str());
    }
  }
  SetBytes(state);
  fs::remove_all(dir);
}

BENCHMARK_CAPTURE(BM_WriteStack, none, loom::ExrCompression::kNone)->Iterations(2)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_ReadStack, none, loom::ExrCompression::kNone)->Iterations(2)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_WriteStack, zip, loom::ExrCompression::kZip)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_ReadStack, zip, loom::ExrCompression::kZip)->Iterations(2)->Unit(benchmark::kSecond)->UseRealTime();
BENCHMARK(BM_WriteFilePerChannel)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  const int code = loom::bench::RunBenchmarks(
      argc, argv, "bench_exr", "OpenEXR write/read of a 630x630x934 float stack (bytes = float payload, 1.48 GB)",
      {{"one_file_vs_file_per_channel_write", "BM_WriteStack/none/iterations:2/real_time",
        "BM_WriteFilePerChannel/iterations:1/real_time"},
       {"zip_vs_none_write", "BM_WriteStack/zip/iterations:1/real_time", "BM_WriteStack/none/iterations:2/real_time"},
       {"zip_vs_none_read", "BM_ReadStack/zip/iterations:2/real_time", "BM_ReadStack/none/iterations:2/real_time"}});
  fs::remove_all(BenchDir());
  return code;
}
