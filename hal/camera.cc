#include "hal/camera.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "hal/internal/format.h"

namespace loom::hal {
namespace {

using internal::FormatNumber;

std::string Format(const scan::Roi& roi) {
  return std::to_string(roi.x) + "," + std::to_string(roi.y) + " " + std::to_string(roi.width) + "x" + std::to_string(roi.height);
}

bool Offers(const CameraCapabilities& caps, scan::PixelFormat format) {
  return std::find(caps.pixel_formats.begin(), caps.pixel_formats.end(), format) != caps.pixel_formats.end();
}

void NegotiateRoi(const CameraCapabilities& caps, const scan::Roi& requested, scan::Roi* applied, ConfigureReport* report) {
  scan::Roi roi = requested;
  if (roi.width == 0) roi.width = caps.sensor_width - roi.x;
  if (roi.height == 0) roi.height = caps.sensor_height - roi.y;
  if (roi.x < 0 || roi.y < 0 || roi.width <= 0 || roi.height <= 0 || roi.x >= caps.sensor_width || roi.y >= caps.sensor_height) {
    report->Reject("roi " + Format(requested) + " is outside the " + std::to_string(caps.sensor_width) + "x" +
                   std::to_string(caps.sensor_height) + " sensor");
    return;
  }
  scan::Roi clipped = roi;
  clipped.width = std::min(roi.width, caps.sensor_width - roi.x);
  clipped.height = std::min(roi.height, caps.sensor_height - roi.y);
  if (clipped != roi) {
    report->Adjust("roi", Format(roi), Format(clipped), "clipped to the sensor");
  }
  *applied = clipped;
}

double Clamp(const char* setting, double value, double low, double high, const char* unit, ConfigureReport* report) {
  const double clamped = std::clamp(value, low, high);
  if (clamped != value) {
    report->Adjust(setting, FormatNumber(value), FormatNumber(clamped),
                   "range is [" + FormatNumber(low) + ", " + FormatNumber(high) + "] " + unit);
  }
  return clamped;
}

bool Differs(double a, double b) { return std::abs(a - b) > 1e-9 * std::max(1.0, std::abs(b)); }

}  // namespace

std::string_view TriggerModeName(TriggerMode mode) {
  switch (mode) {
    case TriggerMode::kFreeRun:
      return "free-run";
    case TriggerMode::kSoftware:
      return "software";
    case TriggerMode::kHardware:
      return "hardware";
  }
  return "unknown";
}

ConfigureReport Camera::Negotiate(const CameraSettings& requested, CameraSettings* applied) const {
  const CameraCapabilities& caps = capabilities_;
  ConfigureReport report;
  *applied = requested;
  if (!Offers(caps, requested.pixel_format)) {
    if (requested.pixel_format == scan::PixelFormat::kMono12 && Offers(caps, scan::PixelFormat::kMono16)) {
      applied->pixel_format = scan::PixelFormat::kMono16;
      report.Adjust("pixel_format", "Mono12", "Mono16", "the camera does not offer Mono12");
    } else {
      report.Reject("pixel format " + std::string(scan::PixelFormatName(requested.pixel_format)) +
                    " is not offered by the camera");
    }
  }
  NegotiateRoi(caps, requested.roi, &applied->roi, &report);
  applied->exposure_us = Clamp("exposure_us", requested.exposure_us, caps.exposure_min_us, caps.exposure_max_us, "µs", &report);
  applied->gain = Clamp("gain", requested.gain, caps.gain_min, caps.gain_max, "", &report);
  if (requested.buffer_count < 2) {
    applied->buffer_count = 2;
    report.Adjust("buffer_count", std::to_string(requested.buffer_count), "2", "acquisition needs at least 2 buffers");
  }
  if (requested.frame_timeout_ms <= 0) {
    report.Reject("frame_timeout_ms must be > 0, got " + std::to_string(requested.frame_timeout_ms));
  }
  if (requested.packet_size_bytes < 0) {
    report.Reject("packet_size must be ≥ 0 (0 negotiates it), got " + std::to_string(requested.packet_size_bytes));
  }
  if (requested.packet_delay_ns < 0) {
    report.Reject("packet_delay_ns must be ≥ 0, got " + std::to_string(requested.packet_delay_ns));
  }
  return report;
}

Result<ConfigureReport> Camera::Configure(const CameraSettings& requested) {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kOpen, DeviceState::kConfigured}, "Configure"));
  CameraSettings applied;
  ConfigureReport report = Negotiate(requested, &applied);
  if (report.outcome == Negotiation::kInvalid) return report;
  const CameraSettings negotiated = applied;
  LOOM_RETURN_IF_ERROR(DoConfigure(&applied));
  // The camera may round further (exposure steps, gain steps): record what it really applied.
  if (Differs(applied.exposure_us, negotiated.exposure_us)) {
    report.Adjust("exposure_us", FormatNumber(negotiated.exposure_us), FormatNumber(applied.exposure_us), "set by the camera");
  }
  if (Differs(applied.gain, negotiated.gain)) {
    report.Adjust("gain", FormatNumber(negotiated.gain), FormatNumber(applied.gain), "set by the camera");
  }
  if (negotiated.packet_size_bytes != 0 && applied.packet_size_bytes != negotiated.packet_size_bytes) {
    report.Adjust("packet_size", std::to_string(negotiated.packet_size_bytes), std::to_string(applied.packet_size_bytes),
                  "within the camera's bounds");
  }
  settings_ = applied;
  MarkConfigured();
  return report;
}

Status Camera::TriggerSoftware() {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kRunning}, "TriggerSoftware"));
  if (settings_.trigger != TriggerMode::kSoftware) {
    return Error(StatusCode::kFailedPrecondition, "software trigger needs trigger mode 'software', it is '" +
                                                      std::string(TriggerModeName(settings_.trigger)) + "'");
  }
  return DoTriggerSoftware();
}

Result<scan::RawFrame> Camera::WaitFrame() {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kRunning}, "WaitFrame"));
  return DoWaitFrame(std::chrono::milliseconds(settings_.frame_timeout_ms));
}

Status Camera::DiscardFrames() {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kRunning}, "DiscardFrames"));
  return DoDiscardFrames();
}

Result<scan::RawFrame> Camera::Snap() {
  LOOM_RETURN_IF_ERROR(TriggerSoftware());
  return WaitFrame();
}

}  // namespace loom::hal
