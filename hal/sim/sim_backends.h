#pragma once
// The `sim` backend: every device kind on the virtual rig (sim/), registered like the real
// backends, so acquisition cannot tell the simulated scanner from a real one. All sim devices
// of a rig share one SimWorld: LEDs, wheels and the turntable change its state; triggering a
// camera renders that state (sim::Scene) through the camera's sensor model. The world's trigger
// line is the LED controller's camera trigger output: a pulse (SimLedArray's FireTrigger)
// exposes every camera running with `trigger: hardware`, each once.
//
// Device names match the rig's `geometry:` (cameras and filter wheels by name; `model:` picks
// another). Moves are instantaneous. A frame's noise is seeded by the world seed and what the
// frame shows (camera, lights, slots, angle, exposure), so the same capture twice — e.g. after
// a resumed scan — gives the same frame.
// The linear light's travel and the projector's resolution come from the geometry when it has
// them (else from the backend keys travel_mm, native_width, native_height).
// LEDs that drift: the LED array's keys `output_drift_percent: P, output_drift_frames: N` make
// every LED's output 1 + P/100 · (1 − exp(−n/N)) for the n-th LED-lit frame rendered, as LEDs
// warming through a scan do (0: no drift, the default); the same keys on the linear light make
// its output drift so over the frames it alone lights. Such frames depend on when they are
// taken: a resumed scan's no longer equal an uninterrupted one's.

#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "hal/registry.h"
#include "scan/plan.h"
#include "sim/renderer.h"

namespace loom::hal {

struct SimWorld {
  SimWorld(std::shared_ptr<const sim::Scene> scene, uint64_t seed) : scene_(std::move(scene)), seed(seed) {}

  // What lies on the turntable can change between steps (a calibration scan's target, tile and
  // chart); the rig stays the same. `object` is what a plan calls it (the sample at first).
  std::shared_ptr<const sim::Scene> scene() const {
    std::lock_guard lock(mutex);
    return scene_;
  }
  scan::ScanObject object() const {
    std::lock_guard lock(mutex);
    return object_;
  }
  void set_scene(std::shared_ptr<const sim::Scene> scene, scan::ScanObject object) {
    std::lock_guard lock(mutex);
    scene_ = std::move(scene);
    object_ = object;
  }

  // The trigger line. A camera armed for hardware trigger is called on every pulse until it
  // disarms (with the handle ArmTrigger gave it).
  int ArmTrigger(std::function<void()> on_pulse);
  void DisarmTrigger(int handle);
  // One pulse: every armed camera exposes, outside the lock (it reads the state to render).
  void FireTrigger();
  int trigger_pulses() const {
    std::lock_guard lock(mutex);
    return pulses_;
  }
  // The LEDs' output for the next LED-lit frame (1 without drift), counting the frame; the
  // linear light's likewise for the next frame it alone lights.
  double NextLedOutput();
  double NextStripOutput();
  // Output that settles exponentially to 1 + percent / 100 over `frames` lit frames.
  void set_led_drift(double percent, double frames) {
    std::lock_guard lock(mutex);
    led_drift_ = {percent, frames, 0};
  }
  void set_strip_drift(double percent, double frames) {
    std::lock_guard lock(mutex);
    strip_drift_ = {percent, frames, 0};
  }

 private:
  std::shared_ptr<const sim::Scene> scene_;
  scan::ScanObject object_ = scan::ScanObject::kSample;
  std::map<int, std::function<void()>> armed_;
  int next_handle_ = 0;
  int pulses_ = 0;
  struct Drift {
    double percent = 0, frames = 1;
    int lit_frames = 0;
    double Next() { return 1 + percent / 100 * (1 - std::exp(-(lit_frames++) / frames)); }
  };
  Drift led_drift_, strip_drift_;

 public:
  uint64_t seed;
  mutable std::mutex mutex;  // guards the scene and everything below; sim devices may run on different threads
  sim::SceneState state;
  // Fault injection for tests of what uses the rig: camera name → frames that fail as if the
  // camera had dropped out (−1: all of them from now on).
  std::map<std::string, int> camera_failures;
  // Device name → commands (LED drives, moves, the strip switched, patterns shown) that fail as if
  // the device had not answered (−1: all of them from now on). Making a device safe never fails.
  std::map<std::string, int> device_failures;
  // Device name → reads of its state (the LEDs' read-back) that fail as if it had not answered.
  std::map<std::string, int> read_failures;
  // Whether `device`'s next frame (camera_failures), command (device_failures) or read
  // (read_failures) fails; counts it off `failures`.
  bool TakeInjectedFault(std::map<std::string, int>& failures, const std::string& device) {
    std::lock_guard lock(mutex);
    const auto it = failures.find(device);
    if (it == failures.end() || it->second == 0) return false;
    if (it->second > 0) --it->second;
    return true;
  }
  bool InjectedDeviceFault(const std::string& device) { return TakeInjectedFault(device_failures, device); }
};

void RegisterSimBackends(BackendRegistry& registry, std::shared_ptr<SimWorld> world);

}  // namespace loom::hal
