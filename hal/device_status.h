#pragma once
// One device at a time, as an operator checks the wiring of a scanner or moves it by hand
// (loom rig status | snap | move | leds): what a device reports now, in a line, moving whatever
// moves, lighting LEDs and taking one frame.

#include <ostream>
#include <string>
#include <vector>

#include "core/status.h"
#include "hal/device.h"
#include "hal/rig.h"
#include "scan/frame.h"
#include "scan/rig_state.h"

namespace loom::hal {

// Its identity and what it reports now (sensor and exposure range, LEDs lit and temperature,
// angle, carriage position, filter slot, projector size). The device must be open.
Result<std::string> DescribeDeviceState(Device& device);

// Moves a turntable (`to` in degrees), a linear light (mm) or a filter wheel (a whole slot) and
// returns where it ended, as the device reports it ("12.5 deg"); any other device is an error
// naming it. The device must be open and started.
Result<std::string> MoveDevice(Device& device, double to);

// The device of `rig` named `name`, or an error listing the rig's devices.
Result<Device*> FindNamedDevice(const Rig& rig, const std::string& name);

// One line per device of `rig`: kind, name, backend and address (loom rig list).
void ListRigDevices(const Rig& rig, std::ostream& out);

// Opens every device of `rig` and writes a line per device of what it reports, or why it failed;
// leaves the rig safe and closed. Returns how many devices failed (loom rig status).
int ReportRigStatus(Rig& rig, std::ostream& out);

// Opens, starts and drives the rig's LED array; an error naming the rig if it has none.
Status LightLeds(Rig& rig, const std::vector<scan::LedDrive>& leds);

// One software-triggered frame from the camera named `camera`, with the rig state its open
// devices report: `leds` lit first (empty: the LEDs left as they are), at `exposure_us` (≤ 0: the
// camera's configured exposure). Opens and starts what it uses; the caller holds a
// SafeStateGuard.
Result<scan::RawFrame> SnapFrame(Rig& rig, const std::string& camera, double exposure_us,
                                 const std::vector<scan::LedDrive>& leds);

// Lights `leds` and keeps them on for `hold_s` seconds or until an interruption (Ctrl-C); a
// SafeStateGuard of the caller switches them off.
Status HoldLeds(Rig& rig, const std::vector<scan::LedDrive>& leds, double hold_s, std::ostream& out);

}  // namespace loom::hal
