#include "hal/device_status.h"

#include <chrono>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <thread>

#include "core/interrupt.h"

#include "hal/camera.h"
#include "hal/led_array.h"
#include "hal/motion.h"
#include "hal/projector.h"

namespace loom::hal {

Result<std::string> DescribeDeviceState(Device& device) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(3);
  const DeviceIdentity& id = device.identity();
  out << id.vendor << (id.model.empty() ? "" : " " + id.model) << (id.serial.empty() ? "" : " serial " + id.serial);
  if (auto* camera = dynamic_cast<Camera*>(&device)) {
    const CameraCapabilities& caps = camera->capabilities();
    out << "; sensor " << caps.sensor_width << "x" << caps.sensor_height << ", exposure " << caps.exposure_min_us << ".."
        << caps.exposure_max_us << " us";
  } else if (auto* leds = dynamic_cast<LedArray*>(&device)) {
    LOOM_ASSIGN_OR_RETURN(const LedArrayReadback read, leds->Read());
    int lit = 0;
    for (double current : read.current_ma) lit += current > 0;
    out << "; " << leds->led_count() << " LEDs, " << lit << " lit, " << read.temperature_c << " C"
        << (read.over_temperature ? ", OVER TEMPERATURE" : "");
  } else if (auto* turntable = dynamic_cast<Turntable*>(&device)) {
    LOOM_ASSIGN_OR_RETURN(const double angle, turntable->Angle());
    out << "; at " << angle << " deg";
  } else if (auto* light = dynamic_cast<LinearLight*>(&device)) {
    LOOM_ASSIGN_OR_RETURN(const LinearLightReadback read, light->Read());
    out << "; at " << read.position_mm << " of " << light->travel_mm() << " mm, strip " << (read.on ? "on" : "off");
  } else if (auto* wheel = dynamic_cast<FilterWheel*>(&device)) {
    LOOM_ASSIGN_OR_RETURN(const int slot, wheel->Position());
    out << "; slot " << slot << " of " << wheel->slot_count();
  } else if (auto* projector = dynamic_cast<Projector*>(&device)) {
    out << "; " << projector->native_width() << "x" << projector->native_height();
  }
  return out.str();
}

Result<std::string> MoveDevice(Device& device, double to) {
  if (!std::isfinite(to)) return InvalidArgumentError(device.name(), "cannot move to " + std::to_string(to));
  std::ostringstream where;
  if (auto* turntable = dynamic_cast<Turntable*>(&device)) {
    LOOM_RETURN_IF_ERROR(turntable->MoveTo(to));
    LOOM_ASSIGN_OR_RETURN(const double angle, turntable->Angle());
    where << angle << " deg";
  } else if (auto* light = dynamic_cast<LinearLight*>(&device)) {
    LOOM_RETURN_IF_ERROR(light->MoveTo(to));
    LOOM_ASSIGN_OR_RETURN(const LinearLightReadback read, light->Read());
    where << read.position_mm << " mm";
  } else if (auto* wheel = dynamic_cast<FilterWheel*>(&device)) {
    if (to != std::floor(to) || to < 0 || to >= wheel->slot_count()) {
      return InvalidArgumentError(
          device.name(), "a filter wheel slot is a whole number in [0, " + std::to_string(wheel->slot_count() - 1) + "]");
    }
    LOOM_RETURN_IF_ERROR(wheel->MoveTo(static_cast<int>(to)));
    LOOM_ASSIGN_OR_RETURN(const int slot, wheel->Position());
    where << "slot " << slot;
  } else {
    return InvalidArgumentError(device.name(), "is a " + device.kind() + ", which does not move");
  }
  return where.str();
}

Result<Device*> FindNamedDevice(const Rig& rig, const std::string& name) {
  if (Device* device = rig.FindDevice(name)) return device;
  std::string names;
  for (Device* device : rig.devices()) names += (names.empty() ? "" : ", ") + device->name();
  return NotFoundError("device '" + name + "'", "not in rig '" + rig.name() + "' (devices: " + names + ")");
}

Status LightLeds(Rig& rig, const std::vector<scan::LedDrive>& leds) {
  if (rig.leds() == nullptr) return FailedPreconditionError("rig '" + rig.name() + "'", "has no LED array");
  LOOM_RETURN_IF_ERROR(rig.OpenAndConfigure(rig.leds()));
  LOOM_RETURN_IF_ERROR(rig.leds()->Start());
  return rig.leds()->Drive(leds);
}

Result<scan::RawFrame> SnapFrame(Rig& rig, const std::string& camera_name, double exposure_us,
                                 const std::vector<scan::LedDrive>& leds) {
  LOOM_ASSIGN_OR_RETURN(Device* const device, FindNamedDevice(rig, camera_name));
  auto* camera = dynamic_cast<Camera*>(device);
  if (camera == nullptr) return InvalidArgumentError("camera '" + camera_name + "'", "is a " + device->kind() + ", not a camera");
  if (!leds.empty()) LOOM_RETURN_IF_ERROR(LightLeds(rig, leds));
  LOOM_RETURN_IF_ERROR(rig.OpenAndConfigure(camera));
  if (exposure_us > 0 || camera->settings().trigger != TriggerMode::kSoftware) {
    CameraSettings settings = camera->settings();
    if (exposure_us > 0) settings.exposure_us = exposure_us;
    settings.trigger = TriggerMode::kSoftware;
    LOOM_ASSIGN_OR_RETURN(const ConfigureReport report, camera->Configure(settings));
    LOOM_RETURN_IF_ERROR(report.ToStatus(camera->description()));
  }
  LOOM_RETURN_IF_ERROR(camera->Start());
  // The other devices are read for the frame's rig state only where they are open: a snap moves
  // nothing, so the state recorded is what the open devices report.
  return rig.Snap(*camera);
}

namespace {

std::string Pad(const std::string& text, size_t width) {
  return text.size() >= width ? text + " " : text + std::string(width - text.size(), ' ');
}

}  // namespace

void ListRigDevices(const Rig& rig, std::ostream& out) {
  for (Device* device : rig.devices()) {
    out << "  " << Pad(device->kind(), 14) << Pad(device->name(), 14) << Pad(device->backend(), 11) << device->address() << "\n";
  }
}

int ReportRigStatus(Rig& rig, std::ostream& out) {
  SafeStateGuard guard(rig);
  int failures = 0;
  for (Device* device : rig.devices()) {
    const Status opened = device->Open();
    const Result<std::string> line = opened.ok() ? DescribeDeviceState(*device) : Result<std::string>(opened);
    out << "  " << Pad(device->name(), 14) << (line.ok() ? "ok      " + *line : "FAILED  " + line.status().ToString()) << "\n";
    failures += line.ok() ? 0 : 1;
  }
  rig.MakeSafe().ok();  // a device that failed to open reports it above; the rest are made safe
  rig.CloseAll().ok();
  return failures;
}

Status HoldLeds(Rig& rig, const std::vector<scan::LedDrive>& leds, double hold_s, std::ostream& out) {
  LOOM_RETURN_IF_ERROR(LightLeds(rig, leds));
  out << leds.size() << " LEDs on for " << hold_s << " s (Ctrl-C ends it)" << std::endl;
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(hold_s);
  while (std::chrono::steady_clock::now() < until && !InterruptRequested()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  out << "LEDs off\n";
  return Status::Ok();
}

}  // namespace loom::hal
