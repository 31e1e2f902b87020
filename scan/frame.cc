#include "scan/frame.h"

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

}  // namespace loom::scan
