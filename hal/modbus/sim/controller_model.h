#pragma once
// The behaviour of loom's Modbus controllers (turntable, LED controller, linear light) on their
// register maps: what loom-modbus-sim serves. Motion runs at the configured speed in real time,
// homing, busy / in-position / fault status, LED currents with a limit and an over-temperature
// fault, the camera trigger output (pulses counted), the heartbeat watchdog, and fault injection through the simulator-only
// register 90. Time passes only as Advance says: the watchdog trips when the time since the last heartbeat, measured at the next
// request, exceeds its timeout — which no client can tell from tripping on time. The model works directly on the server's
// register array. Not thread-safe.

#include <cstdint>
#include <span>
#include <string>

namespace loom::hal::sim {

enum class ControllerKind { kTurntable, kLeds, kLinearLight };

struct ControllerSpec {
  ControllerKind kind = ControllerKind::kTurntable;
  uint32_t serial = 1;
  int led_count = 29;         // LEDs
  int max_current_ma = 1000;  // LEDs
  double max_speed = 60;      // turntable: °/s; linear light: mm/s
  double travel_mm = 400;     // linear light
};

class ControllerModel {
 public:
  // `registers` must hold modbus_map::kRegisterCount values and outlive the model.
  ControllerModel(const ControllerSpec& spec, uint16_t* registers);

  // Advances motion by `seconds` of real time.
  void Advance(double seconds);
  // 0 if a write of `values` at `address` may be applied, else the Modbus exception code.
  int CheckWrite(int address, std::span<const uint16_t> values) const;
  // Reacts to registers [address, address + count) just written (commands, currents, ...).
  void OnWritten(int address, int count);

 private:
  uint16_t& reg(int address) { return registers_[address]; }
  uint16_t reg(int address) const { return registers_[address]; }
  int32_t Read32(int address) const;
  void Write32(int address, int32_t value);
  void SetStatus(uint16_t bit, bool on);
  void Fault(uint16_t code);
  void Command(uint16_t command);
  void StartMove(double target);
  double CountsPerSecond() const;  // current speed in position counts per second
  void InjectFault(uint16_t what);
  void UpdateTemperature();
  void GoSafe();  // motion stopped, outputs off and disabled

  ControllerSpec spec_;
  uint16_t* registers_;
  double position_ = 0;  // counts: millidegrees or µm
  double target_ = 0;
  bool moving_ = false;
  bool homing_ = false;
  bool stall_next_move_ = false;
  double since_heartbeat_s_ = 0;
};

}  // namespace loom::hal::sim
