#include "hal/led_array.h"

#include "hal/internal/format.h"

namespace loom::hal {

using internal::FormatNumber;

Result<ConfigureReport> LedArray::Configure(const LedArraySettings& requested) {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kOpen, DeviceState::kConfigured}, "Configure"));
  ConfigureReport report;
  LedArraySettings applied = requested;
  if (requested.current_limit_ma <= 0) {
    report.Reject("current_limit_ma must be > 0, got " + FormatNumber(requested.current_limit_ma));
    return report;
  }
  if (requested.current_limit_ma > max_current_ma_) {
    applied.current_limit_ma = max_current_ma_;
    report.Adjust("current_limit_ma", FormatNumber(requested.current_limit_ma), FormatNumber(max_current_ma_),
                  "the controller's maximum");
  }
  LOOM_RETURN_IF_ERROR(DoConfigure(applied));
  settings_ = applied;
  MarkConfigured();
  return report;
}

Status LedArray::Drive(std::span<const scan::LedDrive> leds) {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kRunning}, "Drive"));
  for (const scan::LedDrive& drive : leds) {
    if (drive.led < 0 || drive.led >= led_count_) {
      return Error(StatusCode::kInvalidArgument,
                   "LED " + std::to_string(drive.led) + " does not exist (0.." + std::to_string(led_count_ - 1) + ")");
    }
    if (drive.current_ma < 0 || drive.current_ma > settings_.current_limit_ma) {
      return Error(StatusCode::kInvalidArgument, "LED " + std::to_string(drive.led) + ": current " +
                                                     FormatNumber(drive.current_ma) + " mA is outside [0, " +
                                                     FormatNumber(settings_.current_limit_ma) + "] mA");
    }
  }
  return DoDrive(leds);
}

Status LedArray::AllOff() {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kOpen, DeviceState::kConfigured, DeviceState::kRunning}, "AllOff"));
  return DoAllOff();
}

Status LedArray::FireTrigger() {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kRunning}, "FireTrigger"));
  return DoFireTrigger();
}

Result<LedArrayReadback> LedArray::Read() {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kOpen, DeviceState::kConfigured, DeviceState::kRunning}, "Read"));
  return DoRead();
}

}  // namespace loom::hal
