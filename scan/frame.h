#pragma once
// A camera frame as loom keeps it, apart from any device: 16-bit pixels and what the camera and
// the rig reported doing when it was taken. hal's cameras produce it, the capture store keeps it,
// calibration and reconstruction read it.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.h"
#include "scan/rig_state.h"

namespace loom::scan {

enum class PixelFormat { kMono8, kMono12, kMono16 };
std::string_view PixelFormatName(PixelFormat format);
Result<PixelFormat> ParsePixelFormat(std::string_view name);
int BitDepth(PixelFormat format);

struct Roi {
  int x = 0;
  int y = 0;
  int width = 0;   // 0 = full sensor width
  int height = 0;  // 0 = full sensor height
  bool operator==(const Roi&) const = default;
};

struct FrameMetadata {
  std::string camera;  // rig name of the camera
  std::string camera_serial;
  PixelFormat pixel_format = PixelFormat::kMono16;
  Roi roi;                 // as applied (full-sensor ROI spelled out)
  double exposure_us = 0;  // as the camera reports it applied
  double gain = 0;
  uint64_t frame_id = 0;  // the camera's frame counter
  uint64_t device_timestamp_ns = 0;
  int64_t host_timestamp_ns = 0;  // system clock, ns since the Unix epoch, when received
  RigState rig_state;             // filled by the Rig
};

struct RawFrame {
  int width = 0;
  int height = 0;
  std::vector<uint16_t> pixels;  // row-major, width * height
  FrameMetadata metadata;

  uint16_t at(int y, int x) const { return pixels[static_cast<size_t>(y) * width + x]; }
};

// A frame as an OpenEXR image for a person to look at (loom rig snap): its DN as floats in
// channel "Y", its metadata (camera, serial, format, exposure, gain, frame id, turntable angle,
// LEDs lit) as attributes. The capture store keeps frames its own way (capture_store.h).
Status WriteFrameExr(const RawFrame& frame, const std::filesystem::path& path);

}  // namespace loom::scan
