#pragma once
// One device at a time, as an operator checks the wiring of a scanner or moves it by hand
// (loom rig status | move): what a device reports now, in a line, and moving whatever moves.

#include <string>

#include "core/status.h"
#include "hal/device.h"

namespace loom::hal {

// Its identity and what it reports now (sensor and exposure range, LEDs lit and temperature,
// angle, carriage position, filter slot, projector size). The device must be open.
Result<std::string> DescribeDeviceState(Device& device);

// Moves a turntable (`to` in degrees), a linear light (mm) or a filter wheel (a whole slot) and
// returns where it ended, as the device reports it ("12.5 deg"); any other device is an error
// naming it. The device must be open and started.
Result<std::string> MoveDevice(Device& device, double to);

}  // namespace loom::hal
