// The simulator's speed: frames per second of tac7-mini and tac7 cameras (one LED lit, 2×2
// supersampling, shadows), BRDF evaluations per second inside the renderer, and fast-path stack
// throughput (pixel-observations per second). Ratio against the naive way: one thread.
#include <benchmark/benchmark.h>

#include "bench/bench_report.h"
#include "core/config.h"
#include "core/rig_model.h"
#include "sim/sample.h"
#include "sim/stack.h"

namespace {

using loom::sim::Scene;

std::unique_ptr<Scene> LoadScene(const std::string& rig) {
  const std::string path = std::string(LOOM_SOURCE_DIR) + "/configs/rig/" + rig + ".yaml";
  auto doc = loom::ConfigDocument::LoadFile(path, 1);
  if (!doc.ok()) return nullptr;
  loom::RigModel model = loom::ReadRigModel(doc->root().Child("geometry"));
  auto material = loom::sim::MakeSample(loom::sim::ReadSampleSpec(doc->root().Child("sample")));
  if (!material.ok()) return nullptr;
  return std::make_unique<Scene>(std::move(model), std::move(*material));
}

const Scene& Scenes(int which) {
  if (which == 0) {
    static const std::unique_ptr<Scene> mini = LoadScene("tac7-mini");
    return *mini;
  }
  static const std::unique_ptr<Scene> full = LoadScene("tac7");
  return *full;
}

// range(0): 0 tac7-mini, 1 tac7; range(1): threads.
void BM_RenderFrame(benchmark::State& state) {
  const Scene& scene = Scenes(static_cast<int>(state.range(0)));
  const loom::sim::SceneState lights{.leds = {{3, 1000}}};
  const int threads = static_cast<int>(state.range(1));
  int64_t rays = 0;
  for (auto _ : state) {
    const loom::Image radiance = scene.RenderRadiance(1, lights, {.supersampling = 2, .threads = threads});
    benchmark::DoNotOptimize(radiance.data());
    rays += radiance.pixel_count() * 4;
  }
  state.SetItemsProcessed(state.iterations());  // frames
  // One lit LED: one BRDF evaluation per ray that hits the sample.
  state.counters["brdf_evaluations_per_second"] = benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RenderFrame)->Args({0, 1})->Args({0, 2})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RenderFrame)->Args({1, 2})->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

void BM_FastPathStack(benchmark::State& state) {
  const Scene& scene = Scenes(0);
  const auto observations = loom::sim::DefaultObservations(scene.rig(), {0, 120, 240});
  int64_t values = 0;
  for (auto _ : state) {
    const loom::ObservationStack stack = loom::sim::RenderStack(scene, observations, {.threads = static_cast<int>(state.range(0))});
    benchmark::DoNotOptimize(stack.image.data());
    values += static_cast<int64_t>(stack.image.pixel_count() * observations.size());
  }
  state.SetItemsProcessed(values);  // pixel-observations
}
BENCHMARK(BM_FastPathStack)->Arg(1)->Arg(2)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  return loom::bench::RunBenchmarks(
      argc, argv, "bench_sim",
      "Simulator: camera frames/s (items = frames, cam1 45°, one LED), fast-path stack pixel-observations/s",
      {{"frame_two_threads_vs_one_tac7_mini", "BM_RenderFrame/0/2/real_time", "BM_RenderFrame/0/1/real_time"},
       {"stack_two_threads_vs_one", "BM_FastPathStack/2/real_time", "BM_FastPathStack/1/real_time"}});
}
