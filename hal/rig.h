#pragma once
// Rig: every device of a scanner, created from the `devices:` section of a rig YAML through the
// BackendRegistry, with the settings the YAML gives each device.
//
//   devices:
//     cameras:
//       - {name: cam0, backend: aravis, address: 127.0.0.1,
//          settings: {pixel_format: Mono16, exposure_us: 8000, trigger: software}}
//     leds: {name: leds, backend: modbus, endpoint: "tcp://127.0.0.1:1502"}
//     filter_wheels: [{name: wheel0, backend: usb, ...}]
//     turntable: {...}
//     linear_light: {...}
//     projector: {...}
//
// Every device but a camera may say how long the rig waits after changing it before a frame is
// taken (`settle_ms`: LEDs switched, a wheel turned, the turntable or strip moved, a pattern
// shown) and, for the LEDs and the linear light, how long they warm up the first time a scan
// switches them on (`warm_up_ms`). The sequencer waits the longest settle of what a step changed
// (devices settle together) on the rig's clock (hal/clock.h).
//
// Cameras set to `trigger: hardware` expose on a pulse of their trigger input (Line0), and
// `devices: trigger: {source: ...}` says what pulses it:
//   leds       the LED controller's camera trigger output (led_array.h), wired to every camera:
//              one pulse per capture exposes all of them together, under one light state;
//   generator  an external pulse generator running freely: before a capture each camera drops
//              what it holds and the frame that may have begun before, and keeps the next.
// Without `trigger:` every camera must be software-triggered (one command each).
//
// Every section is optional (a rig without a projector cannot run structured light; the plan
// says so). Device names are unique. SafeStateGuard puts the rig in its safe state — LEDs off,
// motion stopped, projector blank, acquisition stopped — when it goes out of scope, on every
// exit path: return, exception, and Ctrl-C (it installs the interrupt handler; long waits notice
// the flag and return Cancelled, unwinding to the guard).
// Thread-safety: one thread drives a rig.

#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/config.h"
#include "core/interrupt.h"
#include "core/rig_file.h"
#include "hal/clock.h"
#include "hal/registry.h"
#include "scan/rig_state.h"

namespace loom::hal {

enum class TriggerSource { kNone, kLedController, kGenerator };

// The waits a rig YAML gives a device (0: none).
struct DeviceTiming {
  double settle_s = 0;
  double warm_up_s = 0;
};

class Rig {
 public:
  // Reads `devices` (the mapping under the `devices:` key) and creates every device. Problems
  // in the YAML are recorded in the document (call its Finish()); a backend that cannot create
  // its device is returned as an error naming the device.
  static Result<std::unique_ptr<Rig>> Create(const ConfigNode& devices, const BackendRegistry& registry, std::string name = "");
  // Loads a rig YAML (core/rig_file.h) and creates the devices of its `devices:`.
  static Result<std::unique_ptr<Rig>> Load(const std::filesystem::path& path, const BackendRegistry& registry);
  // The same for a rig file already open, whose other sections their owners have read; Finish()es it.
  static Result<std::unique_ptr<Rig>> Load(const RigFile& file, const BackendRegistry& registry);

  const std::string& name() const { return name_; }

  const std::vector<std::unique_ptr<Camera>>& cameras() const { return cameras_; }
  const std::vector<std::unique_ptr<FilterWheel>>& filter_wheels() const { return filter_wheels_; }
  LedArray* leds() const { return leds_.get(); }
  Turntable* turntable() const { return turntable_.get(); }
  LinearLight* linear_light() const { return linear_light_.get(); }
  Projector* projector() const { return projector_.get(); }
  // Every device, cameras first.
  std::vector<Device*> devices() const;
  Device* FindDevice(const std::string& name) const;
  // `device`'s settle and warm-up times from the rig YAML.
  DeviceTiming Timing(const Device& device) const;
  // What the rig waits on: virtual time when every device is simulated, wall time otherwise.
  Clock& clock() const { return *clock_; }
  TriggerSource trigger_source() const { return trigger_source_; }

  // Makes `camera` read only `roi` from its next configuration on (a scan of a crop of the
  // sample: acquisition/crop_windows.h). An unknown camera is an error naming it.
  Status SetCameraRegion(const std::string& camera, const scan::Roi& roi);
  // Opens every device and configures it with its rig settings. Stops at the first failure,
  // which names the device (an adjusted setting is logged, an invalid one is an error).
  Status OpenAndConfigure();
  // The same for one device of this rig.
  Status OpenAndConfigure(Device* device);
  Status StartAll();
  // Stops every running device; returns the first error.
  Status StopAll();
  // Every device's MakeSafe(), whatever fails; returns the first error.
  Status MakeSafe();
  Status CloseAll();
  // What the devices report now (turntable angle, LEDs lit, wheel slots, ...).
  Result<scan::RigState> ReadState();
  // Exposes `cameras` (running) together: each software-triggered one by its own command, the
  // hardware-triggered ones (after dropping frames they hold) by one pulse of the rig's trigger
  // source. Per camera, whether it was triggered; its frame then comes from WaitFrame().
  std::vector<Status> Trigger(std::span<Camera* const> cameras);
  // One frame from `camera` (running; software or hardware trigger), stamped with ReadState()
  // taken just before the trigger: what the rig really did for this frame.
  Result<scan::RawFrame> Snap(Camera& camera);

 private:
  Rig() = default;
  Status Configure(Device* device);
  // Every hardware-triggered camera has a trigger source, and the source its device.
  Status CheckTriggerWiring(const ConfigNode& devices) const;

  std::string name_;
  std::vector<std::unique_ptr<Camera>> cameras_;
  std::vector<CameraSettings> camera_settings_;
  std::vector<std::unique_ptr<FilterWheel>> filter_wheels_;
  std::vector<FilterWheelSettings> filter_wheel_settings_;
  std::unique_ptr<LedArray> leds_;
  LedArraySettings led_settings_;
  std::unique_ptr<Turntable> turntable_;
  TurntableSettings turntable_settings_;
  std::unique_ptr<LinearLight> linear_light_;
  LinearLightSettings linear_light_settings_;
  std::unique_ptr<Projector> projector_;
  ProjectorSettings projector_settings_;
  std::map<std::string, DeviceTiming> timing_;  // by device name
  TriggerSource trigger_source_ = TriggerSource::kNone;
  std::unique_ptr<Clock> clock_;
};

// Puts the rig in its safe state when it goes out of scope (failures are logged: a destructor
// has nobody to return them to). Holds an InterruptScope (core/interrupt.h): while it lives,
// SIGINT and SIGTERM ask the rig's operations to stop instead of killing the process.
class SafeStateGuard {
 public:
  explicit SafeStateGuard(Rig& rig);
  ~SafeStateGuard();
  SafeStateGuard(const SafeStateGuard&) = delete;
  SafeStateGuard& operator=(const SafeStateGuard&) = delete;

 private:
  Rig& rig_;
  InterruptScope interrupt_scope_;  // ends after the destructor has made the rig safe
};

}  // namespace loom::hal
