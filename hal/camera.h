#pragma once
// Camera: a monochrome machine-vision camera (the rig has 4 GigE ones).
//
// | setting          | unit / values                      | notes                                  |
// |------------------|------------------------------------|----------------------------------------|
// | pixel_format     | Mono8, Mono12, Mono16              | Mono12 only where the camera offers it |
// | roi              | pixels (x, y, width, height)       | width/height 0 = full sensor           |
// | exposure_us      | µs                                 | adjusted to the sensor's range/step    |
// | gain             | the camera's gain unit (dB or raw) | adjusted to its range                  |
// | trigger          | free-run, software, hardware       | hardware = the camera's Line0 input    |
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
#include "hal/rig_state.h"

namespace loom::hal {

enum class PixelFormat { kMono8, kMono12, kMono16 };
std::string_view PixelFormatName(PixelFormat format);
Result<PixelFormat> ParsePixelFormat(std::string_view name);
int BitDepth(PixelFormat format);

enum class TriggerMode { kFreeRun, kSoftware, kHardware };
std::string_view TriggerModeName(TriggerMode mode);

struct Roi {
  int x = 0;
  int y = 0;
  int width = 0;   // 0 = full sensor width
  int height = 0;  // 0 = full sensor height
  bool operator==(const Roi&) const = default;
};

struct CameraSettings {
  PixelFormat pixel_format = PixelFormat::kMono16;
  Roi roi;
  double exposure_us = 10000.0;
  double gain = 0.0;
  TriggerMode trigger = TriggerMode::kSoftware;
  int buffer_count = 4;
  int frame_timeout_ms = 2000;
};

// What the camera can do, known after Open().
struct CameraCapabilities {
  int sensor_width = 0;
  int sensor_height = 0;
  std::vector<PixelFormat> pixel_formats;
  double exposure_min_us = 0;
  double exposure_max_us = 0;
  double gain_min = 0;
  double gain_max = 0;
};

struct FrameMetadata {
  std::string camera;          // rig name of the camera
  std::string camera_serial;
  PixelFormat pixel_format = PixelFormat::kMono16;
  Roi roi;                     // as applied (full-sensor ROI spelled out)
  double exposure_us = 0;      // as the camera reports it applied
  double gain = 0;
  uint64_t frame_id = 0;       // the camera's frame counter
  uint64_t device_timestamp_ns = 0;
  int64_t host_timestamp_ns = 0;  // system clock, ns since the Unix epoch, when received
  RigState rig_state;          // filled by the Rig
};

struct RawFrame {
  int width = 0;
  int height = 0;
  std::vector<uint16_t> pixels;  // row-major, width * height
  FrameMetadata metadata;

  uint16_t at(int y, int x) const { return pixels[static_cast<size_t>(y) * width + x]; }
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
  Result<RawFrame> WaitFrame();
  // Running, software trigger: TriggerSoftware() then WaitFrame().
  Result<RawFrame> Snap();

 protected:
  void set_capabilities(CameraCapabilities capabilities) { capabilities_ = std::move(capabilities); }
  // Validates `requested` against capabilities() (shared by all backends).
  ConfigureReport Negotiate(const CameraSettings& requested, CameraSettings* applied) const;

  // Applies validated settings; may refine *applied with what the device reports back.
  virtual Status DoConfigure(CameraSettings* applied) = 0;
  virtual Status DoTriggerSoftware() = 0;
  virtual Result<RawFrame> DoWaitFrame(std::chrono::milliseconds timeout) = 0;

 private:
  CameraCapabilities capabilities_;
  CameraSettings settings_;
};

}  // namespace loom::hal
