// The simulator's speed: frames per second of tac7-mini and tac7 cameras (one LED lit, 2×2
// supersampling, shadows), BRDF evaluations per second inside the renderer, and fast-path stack
// throughput (pixel-observations per second), and the heightfield marches (shadow tests and
// camera rays per second) skipping 8-pixel blocks against one block, the plain march that only
// stops above the highest point. Ratios against the naive way: one thread, one block.
#include <benchmark/benchmark.h>

#include <map>

#include "bench/bench_report.h"
#include "core/heightmap.h"
#include "core/rig_file.h"
#include "core/rig_model.h"
#include "core/testing/build_tree.h"
#include "fitting/model/svbrdf_maps.h"
#include "sim/sample.h"
#include "sim/stack.h"
#include "sim/test_materials.h"

namespace {

using loom::sim::Scene;

std::unique_ptr<Scene> LoadScene(const std::string& rig) {
  const std::string path = loom::testing::SourceDir() + "/configs/rig/" + rig + ".yaml";
  auto file = loom::RigFile::Load(path);
  if (!file.ok()) return nullptr;
  auto model = file->Model();
  const std::optional<loom::ConfigNode> sample = file->Section("sample");
  if (!model.ok() || !sample) return nullptr;
  auto material = loom::sim::MakeSample(loom::sim::ReadSampleSpec(*sample));
  if (!material.ok()) return nullptr;
  return std::make_unique<Scene>(std::move(*model), std::move(*material));
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

// The same frame from its camera's hits traced once (Scene::TraceCamera), as a scan's steps at
// one turntable angle render theirs: against BM_RenderFrame, what the rays' marches cost.
void BM_RenderFrameFromHits(benchmark::State& state) {
  const Scene& scene = Scenes(static_cast<int>(state.range(0)));
  const loom::sim::SceneState lights{.leds = {{3, 1000}}};
  const loom::sim::RenderOptions options{.supersampling = 2, .threads = static_cast<int>(state.range(1))};
  const loom::sim::CameraHits hits = scene.TraceCamera(1, lights.turntable_deg, options);
  for (auto _ : state) {
    const loom::Image radiance = scene.RenderRadiance(hits, lights, options);
    benchmark::DoNotOptimize(radiance.data());
  }
  state.SetItemsProcessed(state.iterations());  // frames
}
BENCHMARK(BM_RenderFrameFromHits)->Args({0, 1})->Args({0, 2})->Unit(benchmark::kMillisecond)->UseRealTime();

// A tac7 calibration scan's frames (cam1, 2 × 2 supersampling, 2 threads), by range(0): 0 the
// wedge target under all 29 LEDs, 1 the target under the projector's white pattern, 2 the chrome
// sphere under one LED, 3 the white tile under one LED.
const Scene& CalibrationScene(int which) {
  static std::map<int, std::unique_ptr<Scene>> scenes;
  std::unique_ptr<Scene>& scene = scenes[which];
  if (scene) return *scene;
  const Scene& full = Scenes(1);
  const loom::RigModel& rig = full.rig();
  loom::sim::SampleSpec spec;
  spec.kind = which <= 1 ? "target" : which == 2 ? "chrome-sphere" : "white-tile";
  spec.size_px = full.material().width();
  spec.pixel_mm = full.material().pixel_mm;
  spec.target = rig.calibration_target;
  if (rig.light_probe) spec.probe = *rig.light_probe;
  scene = std::make_unique<Scene>(rig, *loom::sim::MakeSample(spec));
  return *scene;
}

loom::sim::SceneState CalibrationLights(int which) {
  static const auto white = std::make_shared<const loom::sim::ProjectedImage>(
      loom::sim::ProjectedImage{1280, 800, std::vector<uint8_t>(1280 * 800, 255)});
  loom::sim::SceneState state;
  if (which == 0) {
    for (int led = 0; led < 29; ++led) state.leds.push_back({led, 250});
  } else if (which == 1) {
    state.projector_image = white;
  } else {
    state.leds = {{3, 1000}};
  }
  return state;
}

void BM_CalibrationFrame(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const Scene& scene = CalibrationScene(which);
  const loom::sim::SceneState lights = CalibrationLights(which);
  for (auto _ : state) {
    const loom::Image radiance = scene.RenderRadiance(1, lights, {.supersampling = 2, .threads = 2});
    benchmark::DoNotOptimize(radiance.data());
  }
  state.SetItemsProcessed(state.iterations());  // frames
}
BENCHMARK(BM_CalibrationFrame)->DenseRange(0, 3)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

void BM_FastPathStack(benchmark::State& state) {
  const Scene& scene = Scenes(0);
  const auto observations = loom::sim::DefaultObservations(scene.rig(), {0, 120, 240});
  int64_t values = 0;
  for (auto _ : state) {
    const loom::ObservationStack stack =
        loom::sim::RenderStack(scene, observations, {.threads = static_cast<int>(state.range(0))});
    benchmark::DoNotOptimize(stack.image.data());
    values += static_cast<int64_t>(stack.image.pixel_count() * observations.size());
  }
  state.SetItemsProcessed(values);  // pixel-observations
}
BENCHMARK(BM_FastPathStack)->Arg(1)->Arg(2)->Unit(benchmark::kSecond)->UseRealTime();

// range(1): 0 tac7-mini's fabric (0.2 mm of relief), 1 its chrome sphere (a calibration scan's
// tallest object), as a heightmap of range(0) pixel blocks (0: one block, the whole grid).
const loom::sim::Material& MarchedMaterial(int which) {
  if (which == 0) return Scenes(0).material();
  static const loom::sim::Material sphere = loom::sim::ChromeSphere(*Scenes(0).rig().light_probe);
  return sphere;
}

loom::Heightmap MarchedHeightmap(const benchmark::State& state) {
  const loom::sim::Material& material = MarchedMaterial(static_cast<int>(state.range(1)));
  const int block_px = static_cast<int>(state.range(0));
  const auto plane = material.maps.channel(*material.maps.FindChannel(loom::fitting::kHeightChannel));
  const int block = block_px > 0 ? block_px : std::max(material.width(), material.height()) + 1;
  return loom::Heightmap(std::vector<float>(plane.begin(), plane.end()), material.width(), material.height(), material.pixel_mm,
                         block);
}

// Shadow tests from a 32 × 32 grid of surface points towards every LED of tac7-mini (sample
// frame, turntable at 0).
void BM_Shadowed(benchmark::State& state) {
  const loom::Heightmap map = MarchedHeightmap(state);
  const loom::sim::Material& material = MarchedMaterial(static_cast<int>(state.range(1)));
  const Scene& scene = Scenes(0);
  const double half = 0.5 * material.width() * material.pixel_mm, step = 2 * half / 32;
  int64_t tests = 0, shadowed = 0;
  for (auto _ : state) {
    for (double y = -half; y < half; y += step) {
      for (double x = -half; x < half; x += step) {
        const Eigen::Vector3d p(x, y, map.HeightAt(x, y));
        for (const loom::LedModel& led : scene.rig().leds) {
          shadowed += map.Shadowed(p, led.position_mm);
          ++tests;
        }
      }
    }
  }
  benchmark::DoNotOptimize(shadowed);
  state.SetItemsProcessed(tests);
  state.counters["shadowed_fraction"] = static_cast<double>(shadowed) / static_cast<double>(tests);
}
BENCHMARK(BM_Shadowed)->ArgsProduct({{8, 0}, {0, 1}})->Unit(benchmark::kMillisecond)->UseRealTime();

// Camera rays from every camera of tac7-mini to a 64 × 64 grid over the material: the
// renderer's first hit.
void BM_FirstHit(benchmark::State& state) {
  const loom::Heightmap map = MarchedHeightmap(state);
  const loom::sim::Material& material = MarchedMaterial(static_cast<int>(state.range(1)));
  const Scene& scene = Scenes(0);
  const double half = 0.5 * material.width() * material.pixel_mm, step = 2 * half / 64;
  int64_t rays = 0;
  double checksum = 0;
  for (auto _ : state) {
    for (const loom::CameraModel& camera : scene.rig().cameras) {
      const Eigen::Vector3d eye = camera.CentreInRig();
      for (double y = -half; y < half; y += step) {
        for (double x = -half; x < half; x += step) {
          checksum += map.FirstHit(eye, (Eigen::Vector3d(x, y, 0) - eye).normalized()).z();
          ++rays;
        }
      }
    }
  }
  benchmark::DoNotOptimize(checksum);
  state.SetItemsProcessed(rays);
}
BENCHMARK(BM_FirstHit)->ArgsProduct({{8, 0}, {0, 1}})->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  return loom::bench::RunBenchmarks(
      argc, argv, "bench_sim",
      "Simulator: camera frames/s (items = frames, cam1 45°, one LED), fast-path stack pixel-observations/s",
      {{"frame_two_threads_vs_one_tac7_mini", "BM_RenderFrame/0/2/real_time", "BM_RenderFrame/0/1/real_time"},
       {"stack_two_threads_vs_one", "BM_FastPathStack/2/real_time", "BM_FastPathStack/1/real_time"},
       {"shadow_tests_blocks_vs_plain_march_fabric", "BM_Shadowed/8/0/real_time", "BM_Shadowed/0/0/real_time"},
       {"shadow_tests_blocks_vs_plain_march_sphere", "BM_Shadowed/8/1/real_time", "BM_Shadowed/0/1/real_time"},
       {"camera_rays_blocks_vs_plain_march_fabric", "BM_FirstHit/8/0/real_time", "BM_FirstHit/0/0/real_time"},
       {"camera_rays_blocks_vs_plain_march_sphere", "BM_FirstHit/8/1/real_time", "BM_FirstHit/0/1/real_time"}});
}
