#pragma once
// What the rig's devices actually did when a frame was taken (read back from the devices, not
// what was asked): stored with every frame in the capture journal.

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.h"

namespace loom::scan {

struct LedDrive {
  int led = 0;            // index on the LED controller, 0-based
  double current_ma = 0;  // drive current, mA

  bool operator==(const LedDrive&) const = default;
};

// "LED:MILLIAMPS[,LED:MILLIAMPS...]" as an operator types it ("3:500,7:1000"): whole LED
// numbers from 0, finite currents from 0, each LED once. `what` names the text in errors ("--on").
Result<std::vector<LedDrive>> ParseLedDrives(std::string_view text, std::string_view what);

struct RigState {
  std::vector<LedDrive> leds_on;            // every LED that was lit, with its current
  std::map<std::string, int> filter_slots;  // filter wheel name → slot (0-based)
  double turntable_deg = 0;                 // turntable angle
  double linear_light_mm = 0;               // linear-light carriage position along its travel
  bool linear_light_on = false;
  double linear_light_intensity = 0;  // 0..1
  std::string projector_pattern;      // name of the pattern shown, empty when blank
  double settled_ms = 0;              // how long no device had changed when the frame was triggered

  bool operator==(const RigState&) const = default;
};

}  // namespace loom::scan
