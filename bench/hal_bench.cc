// Hardware-layer throughput against real protocol peers:
// - frames per second from 1 and from 4 fake GigE cameras (arv-fake-gv-camera-0.8 processes on
//   127.0.0.1-4, 640x480 Mono16, through loom's Camera), software-triggered (the fake polls its
//   trigger at 25 Hz: that caps it) and free-running (the transport's limit), the latter also
//   with larger GigE packets and an inter-packet delay (the stream tuning a rig YAML sets) — needs the
//   private network namespace: run as `hal/aravis/run_in_netns.sh build/bench/bench_hal`;
// - Modbus request latency over TCP and RTU (loom-modbus-sim), and reading 29 LED currents in
//   one block request vs 29 single-register requests (the naive way);
// - starting a capture of four cameras: four software trigger commands against one pulse of the
//   LED controller's trigger output (the hardware trigger), and the exposure skew of the former.
#include <benchmark/benchmark.h>

#include <chrono>

#include "bench/bench_report.h"
#include "bench/fake_camera_peers.h"
#include "core/testing/build_tree.h"
#include "core/testing/subprocess.h"
#include "hal/modbus/modbus_link.h"
#include "hal/modbus/register_map.h"

namespace {

using loom::testing::Subprocess;
using namespace std::chrono_literals;
namespace map = loom::hal::modbus_map;

using CameraPeers = loom::bench::FakeCameraPeers;

CameraPeers& Cameras() {
  static CameraPeers peers = [] {
    loom::hal::CameraSettings settings;
    settings.roi = {0, 0, 640, 480};
    settings.exposure_us = 100;
    settings.buffer_count = 8;
    return loom::bench::StartFakeCameraPeers("BENCH0", settings);
  }();
  return peers;
}

// Free-run frame rate asked of every camera: above what loopback GigE Vision carries for 4
// cameras of 640x480 Mono16 here, so the benchmark shows the transport's limit and its losses.
constexpr double kFreeRunFps = 100.0;

// Restarts every camera in the given trigger mode, with the given GigE packet size and delay.
bool Rearm(CameraPeers& peers, loom::hal::TriggerMode mode, int packet_size_bytes, int packet_delay_ns) {
  for (auto& camera : peers.cameras) {
    loom::hal::CameraSettings settings = camera->settings();
    settings.trigger = mode;
    settings.packet_size_bytes = packet_size_bytes;
    settings.packet_delay_ns = packet_delay_ns;
    if (camera->state() == loom::hal::DeviceState::kRunning && !camera->Stop().ok()) return false;
    if (!camera->Configure(settings).ok()) return false;
    if (mode == loom::hal::TriggerMode::kFreeRun) {
      arv_camera_set_frame_rate(camera->native_camera(), kFreeRunFps, nullptr);
    }
    if (!camera->Start().ok()) return false;
  }
  return true;
}

// range(0): cameras; range(1): 1 = software trigger (how a scan runs), 0 = free-run;
// range(2): GigE packet size in bytes (1400: the fake camera's own); range(3): inter-packet
// delay in ns.
void BM_CameraFrames(benchmark::State& state) {
  CameraPeers& peers = Cameras();
  const bool triggered = state.range(1) == 1;
  const auto mode = triggered ? loom::hal::TriggerMode::kSoftware : loom::hal::TriggerMode::kFreeRun;
  if (peers.error.empty() && !Rearm(peers, mode, static_cast<int>(state.range(2)), static_cast<int>(state.range(3)))) {
    peers.error = "cannot restart the cameras";
  }
  if (!peers.error.empty()) {
    state.SkipWithError(peers.error.c_str());
    return;
  }
  const int count = static_cast<int>(state.range(0));
  std::vector<uint64_t> dropped_before;
  for (int i = 0; i < count; ++i) {
    const auto s = peers.cameras[i]->stream_statistics();
    dropped_before.push_back(s.failures);
  }
  int64_t frames = 0;
  int64_t incomplete = 0;
  for (auto _ : state) {
    for (int i = 0; triggered && i < count; ++i) {
      if (!peers.cameras[i]->TriggerSoftware().ok()) state.SkipWithError("trigger failed");
    }
    for (int i = 0; i < count; ++i) {
      const auto frame = peers.cameras[i]->WaitFrame();
      if (!frame.ok() && frame.status().code() == loom::StatusCode::kDataLoss) {
        ++incomplete;  // counted below through the stream statistics
        continue;
      }
      if (!frame.ok()) {
        state.SkipWithError(frame.status().ToString().c_str());
        return;
      }
      ++frames;
    }
  }
  uint64_t dropped = 0;
  for (int i = 0; i < count; ++i) {
    const auto s = peers.cameras[i]->stream_statistics();
    dropped += s.failures - dropped_before[i];
  }
  state.SetItemsProcessed(frames);
  state.SetBytesProcessed(frames * 640 * 480 * 2);
  // Frames Aravis could not complete (lost packets); the ones this loop popped are a subset.
  state.counters["dropped_frames"] = static_cast<double>(dropped);
  state.counters["incomplete_frames_popped"] = static_cast<double>(incomplete);
}
BENCHMARK(BM_CameraFrames)
    ->ArgNames({"cameras", "triggered", "packet_bytes", "delay_ns"})
    ->Args({1, 1, 1400, 0})
    ->Args({4, 1, 1400, 0})
    ->Args({1, 0, 1400, 0})
    ->Args({4, 0, 1400, 0})
    ->Args({4, 0, 8192, 0})
    ->Args({4, 0, 1400, 20000})
    ->Args({4, 0, 8192, 20000})
    ->UseRealTime()
    ->MinTime(2.0);

struct ModbusPeer {
  Subprocess process;
  std::unique_ptr<loom::hal::ModbusLink> link;
};

ModbusPeer StartModbus(bool rtu) {
  std::vector<std::string> argv = {loom::testing::ModbusSimBinary(), "--device", "leds"};
  if (rtu) {
    argv.push_back("--rtu");
  } else {
    argv.insert(argv.end(), {"--tcp", "127.0.0.1:0"});
  }
  ModbusPeer peer{std::move(*Subprocess::Start(argv)), nullptr};
  const std::string line = *peer.process.ReadLine(5s);
  const std::string endpoint = (rtu ? "rtu://" : "tcp://") + line.substr(14);
  peer.link = std::make_unique<loom::hal::ModbusLink>("bench", *loom::hal::ParseModbusEndpoint(endpoint), 500ms);
  if (!peer.link->Connect().ok()) peer.link.reset();
  return peer;
}

void BM_ModbusRead(benchmark::State& state, bool rtu, bool block) {
  ModbusPeer peer = StartModbus(rtu);
  if (!peer.link) {
    state.SkipWithError("cannot connect to loom-modbus-sim");
    return;
  }
  int64_t values = 0;
  for (auto _ : state) {
    if (block) {
      if (!peer.link->Read(map::kLedCurrents, 29).ok()) state.SkipWithError("read failed");
    } else {
      for (int i = 0; i < 29; ++i) {
        if (!peer.link->Read(map::kLedCurrents + i).ok()) state.SkipWithError("read failed");
      }
    }
    values += 29;
  }
  state.SetItemsProcessed(values);  // register values read
  state.counters["requests_per_second"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * (block ? 1 : 29), benchmark::Counter::kIsRate);
}
BENCHMARK_CAPTURE(BM_ModbusRead, tcp_block, false, true)->UseRealTime();

// What it takes to start one capture of the four cameras. Software: a trigger command to each
// GigE fake in turn (how a rig without a trigger line captures); the cameras start exposing as
// their commands arrive, so the last starts `exposure_skew_us` after the first. Hardware: one
// write to the LED controller's trigger output (loom-modbus-sim over TCP), whose pulse starts
// all four at once. Commands only: frames are not waited for.
void BM_TriggerFourCameras_software(benchmark::State& state) {
  CameraPeers& cameras = Cameras();
  if (cameras.error.empty() && !Rearm(cameras, loom::hal::TriggerMode::kSoftware, 1400, 0)) {
    cameras.error = "cannot restart the cameras";
  }
  if (!cameras.error.empty()) {
    state.SkipWithError(cameras.error.c_str());
    return;
  }
  double skew_s = 0;
  for (auto _ : state) {
    const auto first = std::chrono::steady_clock::now();
    auto last = first;
    for (auto& camera : cameras.cameras) {
      last = std::chrono::steady_clock::now();
      if (!camera->TriggerSoftware().ok()) state.SkipWithError("trigger failed");
    }
    skew_s += std::chrono::duration<double>(last - first).count();
  }
  state.SetItemsProcessed(state.iterations());  // captures started
  state.counters["exposure_skew_us"] = 1e6 * skew_s / static_cast<double>(state.iterations());
}
BENCHMARK(BM_TriggerFourCameras_software)->UseRealTime();

void BM_TriggerFourCameras_pulse(benchmark::State& state) {
  ModbusPeer peer = StartModbus(false);
  if (!peer.link || !peer.link->Write(map::kCommand, map::kCommandEnable).ok()) {
    state.SkipWithError("cannot enable loom-modbus-sim's LED controller");
    return;
  }
  for (auto _ : state) {
    if (!peer.link->Write(map::kLedTriggerFire, 1).ok()) state.SkipWithError("trigger write failed");
  }
  state.SetItemsProcessed(state.iterations());  // captures started
  state.counters["exposure_skew_us"] = 0;       // one pulse on one line
}
BENCHMARK(BM_TriggerFourCameras_pulse)->UseRealTime();
BENCHMARK_CAPTURE(BM_ModbusRead, tcp_single, false, false)->UseRealTime();
BENCHMARK_CAPTURE(BM_ModbusRead, rtu_block, true, true)->UseRealTime();
BENCHMARK_CAPTURE(BM_ModbusRead, rtu_single, true, false)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  return loom::bench::RunBenchmarks(
      argc, argv, "bench_hal", "Hardware layer against peers: camera frames/s (items = frames), Modbus register reads/s",
      {{"four_vs_one_camera_frames_triggered", "BM_CameraFrames/4/1/min_time:2.000/real_time",
        "BM_CameraFrames/1/1/min_time:2.000/real_time"},
       {"four_vs_one_camera_frames_free_run", "BM_CameraFrames/4/0/min_time:2.000/real_time",
        "BM_CameraFrames/1/0/min_time:2.000/real_time"},
       {"modbus_tcp_block_vs_single", "BM_ModbusRead/tcp_block/real_time", "BM_ModbusRead/tcp_single/real_time"},
       {"one_pulse_vs_four_software_triggers", "BM_TriggerFourCameras_pulse/real_time",
        "BM_TriggerFourCameras_software/real_time"},
       {"modbus_rtu_block_vs_single", "BM_ModbusRead/rtu_block/real_time", "BM_ModbusRead/rtu_single/real_time"}});
}
