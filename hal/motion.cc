#include "hal/motion.h"

#include <cmath>

#include "hal/internal/format.h"

namespace loom::hal {
namespace {

using internal::FormatNumber;

constexpr std::initializer_list<DeviceState> kAnyOpenState = {DeviceState::kOpen, DeviceState::kConfigured,
                                                              DeviceState::kRunning};

// Speeds and timeouts are negotiated the same way for every motion device.
template <typename Settings>
void NegotiateMotion(const Settings& requested, double requested_speed, double max_speed, const char* speed_name,
                     const char* unit, ConfigureReport* report, double* applied_speed) {
  *applied_speed = requested_speed;
  if (requested_speed <= 0) {
    report->Reject(std::string(speed_name) + " must be > 0, got " + FormatNumber(requested_speed));
  } else if (requested_speed > max_speed) {
    *applied_speed = max_speed;
    report->Adjust(speed_name, FormatNumber(requested_speed), FormatNumber(max_speed),
                   std::string("the device's maximum in ") + unit);
  }
  if (requested.move_timeout_ms <= 0) {
    report->Reject("move_timeout_ms must be > 0, got " + std::to_string(requested.move_timeout_ms));
  }
}

}  // namespace

Result<ConfigureReport> Turntable::Configure(const TurntableSettings& requested) {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kOpen, DeviceState::kConfigured}, "Configure"));
  ConfigureReport report;
  TurntableSettings applied = requested;
  NegotiateMotion(requested, requested.speed_deg_s, max_speed_deg_s_, "speed_deg_s", "°/s", &report, &applied.speed_deg_s);
  if (report.outcome == Negotiation::kInvalid) return report;
  LOOM_RETURN_IF_ERROR(DoConfigure(applied));
  settings_ = applied;
  MarkConfigured();
  return report;
}

Status Turntable::Home() {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kRunning}, "Home"));
  return DoHome();
}

Status Turntable::MoveTo(double angle_deg) {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kRunning}, "MoveTo"));
  if (!std::isfinite(angle_deg)) {
    return Error(StatusCode::kInvalidArgument, "angle " + FormatNumber(angle_deg) + " is not finite");
  }
  double reduced = std::fmod(angle_deg, 360.0);
  if (reduced < 0) reduced += 360.0;
  return DoMoveTo(reduced);
}

Result<double> Turntable::Angle() {
  LOOM_RETURN_IF_ERROR(ExpectState(kAnyOpenState, "Angle"));
  return DoAngle();
}

Result<ConfigureReport> LinearLight::Configure(const LinearLightSettings& requested) {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kOpen, DeviceState::kConfigured}, "Configure"));
  ConfigureReport report;
  LinearLightSettings applied = requested;
  NegotiateMotion(requested, requested.speed_mm_s, max_speed_mm_s_, "speed_mm_s", "mm/s", &report, &applied.speed_mm_s);
  if (report.outcome == Negotiation::kInvalid) return report;
  LOOM_RETURN_IF_ERROR(DoConfigure(applied));
  settings_ = applied;
  MarkConfigured();
  return report;
}

Status LinearLight::Home() {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kRunning}, "Home"));
  return DoHome();
}

Status LinearLight::MoveTo(double position_mm) {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kRunning}, "MoveTo"));
  if (!(position_mm >= 0 && position_mm <= travel_mm_)) {
    return Error(StatusCode::kOutOfRange,
                 "position " + FormatNumber(position_mm) + " mm is outside the travel [0, " + FormatNumber(travel_mm_) + "] mm");
  }
  return DoMoveTo(position_mm);
}

Status LinearLight::SetStrip(bool on, double intensity) {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kRunning}, "SetStrip"));
  if (!(intensity >= 0 && intensity <= 1)) {
    return Error(StatusCode::kInvalidArgument, "intensity " + FormatNumber(intensity) + " is outside [0, 1]");
  }
  return DoSetStrip(on, intensity);
}

Result<LinearLightReadback> LinearLight::Read() {
  LOOM_RETURN_IF_ERROR(ExpectState(kAnyOpenState, "Read"));
  return DoRead();
}

Result<ConfigureReport> FilterWheel::Configure(const FilterWheelSettings& requested) {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kOpen, DeviceState::kConfigured}, "Configure"));
  ConfigureReport report;
  if (requested.move_timeout_ms <= 0) {
    report.Reject("move_timeout_ms must be > 0, got " + std::to_string(requested.move_timeout_ms));
    return report;
  }
  LOOM_RETURN_IF_ERROR(DoConfigure(requested));
  settings_ = requested;
  MarkConfigured();
  return report;
}

Status FilterWheel::MoveTo(int slot) {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kRunning}, "MoveTo"));
  if (slot < 0 || slot >= slot_count_) {
    return Error(StatusCode::kOutOfRange,
                 "slot " + std::to_string(slot) + " does not exist (0.." + std::to_string(slot_count_ - 1) + ")");
  }
  return DoMoveTo(slot);
}

Result<int> FilterWheel::Position() {
  LOOM_RETURN_IF_ERROR(ExpectState(kAnyOpenState, "Position"));
  return DoPosition();
}

}  // namespace loom::hal
