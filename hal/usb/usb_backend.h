#pragma once
// The `usb` backend: FilterWheel over libusb-1.0, speaking docs/hardware/filter-wheel-usb.md.
//
// Rig YAML keys of a usb filter wheel (besides name, backend, settings):
//   serial: "W0-1234"          # which wheel; optional when exactly one is connected
//   vendor_id: 0x1209          # optional, default pid.codes 0x1209
//   product_id: 0x4C57         # optional
//   request_timeout_ms: 500    # optional, per control request

#include "hal/registry.h"

namespace loom::hal {

void RegisterUsbBackend(BackendRegistry& registry);

}  // namespace loom::hal
