#pragma once
// loom's Modbus register maps for the turntable, LED and linear-light controllers: the contract
// between hal/modbus's clients and a controller's firmware (and loom-modbus-sim, which models
// it). Documented for integrators in docs/hardware/modbus-register-maps.md; keep both in step.
// All values are holding registers (function codes 0x03 read, 0x06 / 0x10 write). 32-bit values
// take two registers, high word first, two's complement.

#include <cstdint>

namespace loom::hal::modbus_map {

// ---- Common block (every controller) ----
inline constexpr int kDeviceType = 0;       // R: kTypeTurntable / kTypeLeds / kTypeLinearLight
inline constexpr int kFirmwareVersion = 1;  // R: major * 256 + minor
inline constexpr int kStatus = 2;           // R: kStatus* bits
inline constexpr int kFaultCode = 3;        // R: kFault*
inline constexpr int kCommand = 4;          // W: kCommand*; reads back the last command
inline constexpr int kSerialHigh = 5;       // R: serial number, 32 bits
inline constexpr int kSerialLow = 6;
// The watchdog: with kWatchdogMs > 0, a controller that receives no write to kHeartbeat for that
// long goes safe by itself — motion stopped, LEDs and strip off, outputs disabled — sets
// kStatusWatchdogTripped and disarms (kWatchdogMs back to 0). A killed client leaves no light
// on. Enable, or arming again, clears the bit.
inline constexpr int kWatchdogMs = 7;  // RW: 0 off, else 1..kMaxWatchdogMs
inline constexpr int kHeartbeat = 8;   // W: any value feeds the watchdog
inline constexpr int kMaxWatchdogMs = 60000;
// Simulator only: writing here injects a fault (kInject*). Real firmware has no such register.
inline constexpr int kSimInjectFault = 90;
inline constexpr int kCommonBlockSize = 100;

inline constexpr uint16_t kTypeTurntable = 0x5454;    // "TT"
inline constexpr uint16_t kTypeLeds = 0x4C45;         // "LE"
inline constexpr uint16_t kTypeLinearLight = 0x4C4C;  // "LL"

inline constexpr uint16_t kStatusEnabled = 1 << 0;     // drives energised / outputs enabled
inline constexpr uint16_t kStatusBusy = 1 << 1;        // a move or homing is in progress
inline constexpr uint16_t kStatusInPosition = 1 << 2;  // at the target, settled
inline constexpr uint16_t kStatusHomed = 1 << 3;
inline constexpr uint16_t kStatusFault = 1 << 4;  // see kFaultCode; cleared by kCommandClearFault
inline constexpr uint16_t kStatusOverTemperature = 1 << 5;
inline constexpr uint16_t kStatusWatchdogTripped = 1 << 6;  // see kWatchdogMs

inline constexpr uint16_t kFaultNone = 0;
inline constexpr uint16_t kFaultMotorStall = 1;       // following error: the axis stopped moving
inline constexpr uint16_t kFaultOverTemperature = 2;  // LED driver too hot: every LED forced off
inline constexpr uint16_t kFaultLimitSwitch = 3;

inline constexpr uint16_t kCommandEnable = 1;
inline constexpr uint16_t kCommandDisable = 2;  // stop motion, outputs off, de-energise
inline constexpr uint16_t kCommandHome = 3;
inline constexpr uint16_t kCommandMove = 4;  // move to the target register's value
inline constexpr uint16_t kCommandStop = 5;  // stop motion where it is
inline constexpr uint16_t kCommandClearFault = 6;

inline constexpr uint16_t kInjectNone = 0;
inline constexpr uint16_t kInjectStall = 1;  // the axis stops moving (busy forever)
inline constexpr uint16_t kInjectOverTemperature = 2;
inline constexpr uint16_t kInjectMotorFault = 3;  // fault now, kFaultMotorStall

// ---- Turntable (kTypeTurntable) ----
inline constexpr int kTurntableTarget = 10;    // RW, 2 regs: millidegrees [0, 360000)
inline constexpr int kTurntablePosition = 12;  // R, 2 regs: millidegrees
inline constexpr int kTurntableSpeed = 14;     // RW: 0.01 °/s
inline constexpr int kTurntableMaxSpeed = 15;  // R: 0.01 °/s

// ---- Linear light (kTypeLinearLight) ----
inline constexpr int kLinearTarget = 10;          // RW, 2 regs: µm along the travel
inline constexpr int kLinearPosition = 12;        // R, 2 regs: µm
inline constexpr int kLinearSpeed = 14;           // RW: 0.1 mm/s
inline constexpr int kLinearMaxSpeed = 15;        // R: 0.1 mm/s
inline constexpr int kLinearTravel = 16;          // R, 2 regs: µm
inline constexpr int kLinearStripOn = 18;         // RW: 0 off, 1 on
inline constexpr int kLinearStripIntensity = 19;  // RW: per mille, 0..1000

// ---- LED controller (kTypeLeds) ----
inline constexpr int kLedCount = 10;         // R
inline constexpr int kLedMaxCurrent = 11;    // R: mA
inline constexpr int kLedTemperature = 12;   // R: 0.1 °C
inline constexpr int kLedCurrentLimit = 13;  // RW: mA, ≤ kLedMaxCurrent
// The camera trigger output (wired to every camera's Line0): writing 1 fires one pulse, which
// exposes every camera set to hardware trigger at once. Refused (exception 0x04) while the
// controller is not enabled. The count of pulses fired since power-up wraps at 65536.
inline constexpr int kLedTriggerFire = 14;   // W: 1 fires one pulse; reads 0
inline constexpr int kLedTriggerCount = 15;  // R
inline constexpr int kLedCurrents = 100;     // RW, one per LED: mA, 0 = off. A value above
                                             // the limit, or any non-zero value while over
                                             // temperature, is refused (exception 0x03 / 0x04).
inline constexpr int kMaxLeds = 64;

inline constexpr int kRegisterCount = kLedCurrents + kMaxLeds;

}  // namespace loom::hal::modbus_map
