#pragma once
// The `modbus` backend: Turntable, LedArray and LinearLight on controllers that speak loom's
// register maps (docs/hardware/modbus-register-maps.md), over TCP or RTU.
//
// Rig YAML keys of a modbus device (besides name, backend, settings):
//   endpoint: "tcp://192.168.10.20:502"     # or "rtu:///dev/ttyUSB0?baud=115200&unit=2"
//   response_timeout_ms: 500                # optional
//
// Open() checks the controller's device-type register, so a device wired to the wrong address
// is an error naming both, not a silent misbehaviour.

#include "hal/registry.h"

namespace loom::hal {

void RegisterModbusBackends(BackendRegistry& registry);

}  // namespace loom::hal
