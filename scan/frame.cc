#include "scan/frame.h"

#include <algorithm>

#include "core/exr_io.h"

namespace loom::scan {

std::string_view PixelFormatName(PixelFormat format) {
  switch (format) {
    case PixelFormat::kMono8:
      return "Mono8";
    case PixelFormat::kMono12:
      return "Mono12";
    case PixelFormat::kMono16:
      return "Mono16";
  }
  return "unknown";
}

Result<PixelFormat> ParsePixelFormat(std::string_view name) {
  for (PixelFormat f : {PixelFormat::kMono8, PixelFormat::kMono12, PixelFormat::kMono16}) {
    if (PixelFormatName(f) == name) return f;
  }
  return InvalidArgumentError("pixel format '" + std::string(name) + "'", "unknown (expected Mono8, Mono12 or Mono16)");
}

int BitDepth(PixelFormat format) {
  switch (format) {
    case PixelFormat::kMono8:
      return 8;
    case PixelFormat::kMono12:
      return 12;
    case PixelFormat::kMono16:
      return 16;
  }
  return 16;
}

Status WriteFrameExr(const RawFrame& frame, const std::filesystem::path& path) {
  Image image(frame.width, frame.height, {"Y"});
  std::copy(frame.pixels.begin(), frame.pixels.end(), image.channel(0).begin());
  const FrameMetadata& meta = frame.metadata;
  return WriteExr(path, image,
                  {{"loom.camera", meta.camera},
                   {"loom.cameraSerial", meta.camera_serial},
                   {"loom.pixelFormat", std::string(PixelFormatName(meta.pixel_format))},
                   {"loom.exposure_us", meta.exposure_us},
                   {"loom.gain", meta.gain},
                   {"loom.frameId", static_cast<int>(meta.frame_id)},
                   {"loom.roi", std::to_string(meta.roi.x) + " " + std::to_string(meta.roi.y) + " " +
                                    std::to_string(meta.roi.width) + " " + std::to_string(meta.roi.height)},
                   {"loom.turntable_deg", meta.rig_state.turntable_deg},
                   {"loom.ledsOn", static_cast<int>(meta.rig_state.leds_on.size())},
                   {"loom.units", std::string("raw sensor counts (DN)")}});
}

}  // namespace loom::scan
