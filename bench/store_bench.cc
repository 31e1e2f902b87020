// Frames from 4 peer cameras into the capture store: arv-fake-gv-camera-0.8 processes on
// 127.0.0.1–4 (run as `hal/aravis/run_in_netns.sh build/bench/bench_store`), 640×480 Mono16,
// triggered together, each frame stored durably (lossless EXR, fsync, journal record).
// Frames/s and bytes/s into the store, dropped frames (must be 0), and the naive comparison:
// the same captures without storing — what durability costs.
#include <benchmark/benchmark.h>

#include <filesystem>

#include "bench/bench_report.h"
#include "bench/fake_camera_peers.h"
#include "scan/capture_store.h"

namespace {

namespace fs = std::filesystem;

using Peers = loom::bench::FakeCameraPeers;

Peers& Cameras() {
  static Peers peers = [] {
    loom::hal::CameraSettings settings;
    settings.roi = {0, 0, 640, 480};
    settings.exposure_us = 100;
    return loom::bench::StartFakeCameraPeers("STORE0", settings);
  }();
  return peers;
}

void BM_FourCameras(benchmark::State& state) {
  Peers& peers = Cameras();
  if (!peers.error.empty()) {
    state.SkipWithError(peers.error.c_str());
    return;
  }
  const bool store_frames = state.range(0) == 1;
  const fs::path dir = fs::temp_directory_path() / "loom_bench_store";
  fs::remove_all(dir);
  auto store = loom::scan::CaptureStore::Create(dir, {"bench", "fake", {}});
  if (!store.ok()) {
    state.SkipWithError(store.status().ToString().c_str());
    return;
  }
  int64_t frames = 0, bytes = 0, dropped = 0, step = 0;
  for (auto _ : state) {
    for (auto& camera : peers.cameras) {
      if (!camera->TriggerSoftware().ok()) ++dropped;
    }
    for (auto& camera : peers.cameras) {
      auto frame = camera->WaitFrame();
      if (!frame.ok()) {
        ++dropped;
        continue;
      }
      if (store_frames && !store->Append({static_cast<int>(step), camera->name(), 0}, *frame).ok()) {
        state.SkipWithError("store append failed");
        return;
      }
      ++frames;
      bytes += static_cast<int64_t>(frame->pixels.size() * 2);
    }
    ++step;
  }
  state.SetItemsProcessed(frames);
  state.SetBytesProcessed(bytes);
  state.counters["dropped_frames"] = static_cast<double>(dropped);
  fs::remove_all(dir);
}
BENCHMARK(BM_FourCameras)->Arg(1)->Arg(0)->UseRealTime()->MinTime(3.0);

}  // namespace

int main(int argc, char** argv) {
  return loom::bench::RunBenchmarks(
      argc, argv, "bench_store",
      "4 fake GigE cameras (640x480 Mono16, triggered together) into the capture store; "
      "items = frames, bytes = raw pixel payload",
      {{"stored_vs_not_stored", "BM_FourCameras/1/min_time:3.000/real_time", "BM_FourCameras/0/min_time:3.000/real_time"}});
}
