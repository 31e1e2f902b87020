// Filter-wheel round trips through libusb against the umockdev device model: status requests
// per second, and a one-slot move (MOVE + busy polling until in position). Run under
// `umockdev-wrapper build/bench/bench_usb_wheel`.
#include <benchmark/benchmark.h>
#include <umockdev.h>

#include "bench/bench_report.h"
#include "hal/usb/emulated_filter_wheel.h"
#include "hal/usb/usb_backend.h"

namespace {

struct Wheel {
  UMockdevTestbed* testbed = nullptr;
  std::unique_ptr<loom::hal::testing::EmulatedFilterWheel> model;
  std::unique_ptr<loom::hal::FilterWheel> wheel;
  std::string error;
};

Wheel& TheWheel() {
  static Wheel w = [] {
    Wheel wheel;
    wheel.testbed = umockdev_testbed_new();
    if (!umockdev_in_mock_environment()) {
      wheel.error = "run under umockdev-wrapper";
      return wheel;
    }
    wheel.model = std::make_unique<loom::hal::testing::EmulatedFilterWheel>(wheel.testbed, 2, "BENCH", 10, 0);
    loom::hal::BackendRegistry registry;
    loom::hal::RegisterUsbBackend(registry);
    auto doc = loom::ConfigDocument::LoadString("schema_version: 1\nw: {name: w, backend: usb}\n", "bench", 1);
    const loom::ConfigNode node = doc->root().Child("w");
    wheel.wheel = std::move(*registry.Create<loom::hal::FilterWheel>({"w", "usb", node}));
    if (!wheel.wheel->Open().ok() || !wheel.wheel->Configure({}).ok() || !wheel.wheel->Start().ok()) {
      wheel.error = "cannot open the emulated wheel";
    }
    return wheel;
  }();
  return w;
}

void BM_WheelStatus(benchmark::State& state) {
  Wheel& w = TheWheel();
  if (!w.error.empty()) {
    state.SkipWithError(w.error.c_str());
    return;
  }
  for (auto _ : state) {
    if (!w.wheel->Position().ok()) state.SkipWithError("status failed");
  }
  state.SetItemsProcessed(state.iterations());  // control round trips
}
BENCHMARK(BM_WheelStatus)->UseRealTime();

void BM_WheelMove(benchmark::State& state) {
  Wheel& w = TheWheel();
  if (!w.error.empty()) {
    state.SkipWithError(w.error.c_str());
    return;
  }
  int slot = 0;
  for (auto _ : state) {
    slot = (slot + 1) % 10;
    if (!w.wheel->MoveTo(slot).ok()) state.SkipWithError("move failed");
  }
  state.SetItemsProcessed(state.iterations());  // moves (the model turns instantly)
}
BENCHMARK(BM_WheelMove)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  return loom::bench::RunBenchmarks(argc, argv, "bench_usb_wheel",
                                    "Filter wheel over libusb against the umockdev model (items = round trips / moves)",
                                    {{"move_vs_status", "BM_WheelMove/real_time", "BM_WheelStatus/real_time"}});
}
