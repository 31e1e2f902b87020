#pragma once
// Camera: a monochrome machine-vision camera (the rig has 4 GigE ones).
//
// | setting          | unit / values                      | notes                                  |
// |------------------|------------------------------------|----------------------------------------|
// | pixel_format     | Mono8, Mono12, Mono16              | Mono12 only where the camera offers it |
// | roi              | pixels (x, y, width, height)       | width/height 0 = full sensor           |
// | exposure_us      | µs                                 | adjusted to the sensor's range/step    |
// | gain             | the camera's gain unit (dB or raw) | adjusted to its range                  |
// | trigger          | free-run, software, hardware       | hardware = the camera's Line0 input,   |
// |                  |                                    | pulsed by the rig's `trigger:` (rig.h) |
// | buffer_count     | frames in the acquisition pool     | ≥ 2                                    |
// | frame_timeout_ms | ms to wait for one frame           | then a Timeout error naming the camera |
//
// Frames are 16-bit containers whatever the format (Mono8 and Mono12 values are not scaled), and
// carry what the camera reported it did. A camera that drops out mid-acquisition gives an
// Unavailable error naming it (after the backend's reconnect attempts), never a hang.

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "hal/device.h"
#include "scan/frame.h"

namespace loom::hal {

enum class TriggerMode { kFreeRun, kSoftware, kHardware };
std::string_view TriggerModeName(TriggerMode mode);

struct CameraSettings {
  scan::PixelFormat pixel_format = scan::PixelFormat::kMono16;
  scan::Roi roi;
  double exposure_us = 10000.0;
  double gain = 0.0;
  TriggerMode trigger = TriggerMode::kSoftware;
  int buffer_count = 4;
  int frame_timeout_ms = 2000;
  // GigE Vision stream (other cameras ignore both). Packet size in bytes: 0 negotiates the
  // largest the path carries (the camera keeps its own when it cannot test), else this, within
  // the camera's bounds. Inter-packet delay (GevSCPD) in ns: spaces a frame's packets so that
  // several cameras on one link do not overrun the switch or the host's buffers.
  int packet_size_bytes = 0;
  int packet_delay_ns = 0;
};

// What the camera can do, known after Open().
struct CameraCapabilities {
  int sensor_width = 0;
  int sensor_height = 0;
  std::vector<scan::PixelFormat> pixel_formats;
  double exposure_min_us = 0;
  double exposure_max_us = 0;
  double gain_min = 0;
  double gain_max = 0;
};

class Camera : public Device {
 public:
  Camera(std::string name, std::string backend, std::string address)
      : Device("camera", std::move(name), std::move(backend), std::move(address)) {}

  // After Open().
  const CameraCapabilities& capabilities() const { return capabilities_; }
  // As applied by the last successful Configure().
  const CameraSettings& settings() const { return settings_; }

  // Open or configured. Negotiates, then applies unless invalid.
  Result<ConfigureReport> Configure(const CameraSettings& requested);
  // Running, software trigger: asks for one frame.
  Status TriggerSoftware();
  // Running: the next frame, or Timeout / Unavailable naming the camera.
  Result<scan::RawFrame> WaitFrame();
  // Running, software trigger: TriggerSoftware() then WaitFrame().
  Result<scan::RawFrame> Snap();
  // Running: drops every frame already received and not yet taken (a hardware-triggered camera
  // may hold frames of pulses meant for others, or of a free-running pulse generator).
  Status DiscardFrames();

 protected:
  void set_capabilities(CameraCapabilities capabilities) { capabilities_ = std::move(capabilities); }
  // Validates `requested` against capabilities() (shared by all backends).
  ConfigureReport Negotiate(const CameraSettings& requested, CameraSettings* applied) const;

  // Applies validated settings; may refine *applied with what the device reports back.
  virtual Status DoConfigure(CameraSettings* applied) = 0;
  virtual Status DoTriggerSoftware() = 0;
  virtual Result<scan::RawFrame> DoWaitFrame(std::chrono::milliseconds timeout) = 0;
  virtual Status DoDiscardFrames() = 0;

 private:
  CameraCapabilities capabilities_;
  CameraSettings settings_;
};

}  // namespace loom::hal
