#include "hal/device_status.h"

#include <cmath>
#include <iomanip>
#include <sstream>

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

}  // namespace loom::hal
