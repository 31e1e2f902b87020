#include "hal/modbus/sim/controller_model.h"

#include <modbus.h>

#include <algorithm>
#include <cmath>

#include "hal/modbus/register_map.h"

namespace loom::hal::sim {
namespace {

namespace map = modbus_map;

bool Overlaps(int address, int count, int reg) { return reg >= address && reg < address + count; }

}  // namespace

ControllerModel::ControllerModel(const ControllerSpec& spec, uint16_t* registers) : spec_(spec), registers_(registers) {
  std::fill(registers_, registers_ + map::kRegisterCount, 0);
  reg(map::kFirmwareVersion) = 0x0102;
  reg(map::kSerialHigh) = static_cast<uint16_t>(spec.serial >> 16);
  reg(map::kSerialLow) = static_cast<uint16_t>(spec.serial & 0xFFFF);
  switch (spec.kind) {
    case ControllerKind::kTurntable:
      reg(map::kDeviceType) = map::kTypeTurntable;
      reg(map::kTurntableMaxSpeed) = static_cast<uint16_t>(std::lround(spec.max_speed * 100));
      reg(map::kTurntableSpeed) = reg(map::kTurntableMaxSpeed);
      break;
    case ControllerKind::kLinearLight:
      reg(map::kDeviceType) = map::kTypeLinearLight;
      reg(map::kLinearMaxSpeed) = static_cast<uint16_t>(std::lround(spec.max_speed * 10));
      reg(map::kLinearSpeed) = reg(map::kLinearMaxSpeed);
      Write32(map::kLinearTravel, static_cast<int32_t>(std::lround(spec.travel_mm * 1000)));
      break;
    case ControllerKind::kLeds:
      reg(map::kDeviceType) = map::kTypeLeds;
      reg(map::kLedCount) = static_cast<uint16_t>(std::min(spec.led_count, map::kMaxLeds));
      reg(map::kLedMaxCurrent) = static_cast<uint16_t>(spec.max_current_ma);
      reg(map::kLedCurrentLimit) = static_cast<uint16_t>(spec.max_current_ma);
      UpdateTemperature();
      break;
  }
  SetStatus(map::kStatusInPosition, spec.kind != ControllerKind::kLeds);
}

int32_t ControllerModel::Read32(int address) const {
  return static_cast<int32_t>((static_cast<uint32_t>(reg(address)) << 16) | reg(address + 1));
}

void ControllerModel::Write32(int address, int32_t value) {
  const uint32_t bits = static_cast<uint32_t>(value);
  reg(address) = static_cast<uint16_t>(bits >> 16);
  reg(address + 1) = static_cast<uint16_t>(bits & 0xFFFF);
}

void ControllerModel::SetStatus(uint16_t bit, bool on) {
  reg(map::kStatus) = on ? (reg(map::kStatus) | bit) : (reg(map::kStatus) & ~bit);
}

void ControllerModel::Fault(uint16_t code) {
  moving_ = homing_ = false;
  SetStatus(map::kStatusBusy, false);
  SetStatus(map::kStatusFault, true);
  reg(map::kFaultCode) = code;
}

double ControllerModel::CountsPerSecond() const {
  // Turntable: 0.01 °/s → millidegrees/s ×10; linear light: 0.1 mm/s → µm/s ×100.
  return spec_.kind == ControllerKind::kTurntable ? reg(map::kTurntableSpeed) * 10.0 : reg(map::kLinearSpeed) * 100.0;
}

void ControllerModel::GoSafe() {
  moving_ = homing_ = false;
  SetStatus(map::kStatusBusy, false);
  SetStatus(map::kStatusEnabled, false);
  if (spec_.kind == ControllerKind::kLeds) {
    std::fill(registers_ + map::kLedCurrents, registers_ + map::kLedCurrents + map::kMaxLeds, 0);
    UpdateTemperature();
  }
  if (spec_.kind == ControllerKind::kLinearLight) reg(map::kLinearStripOn) = 0;
}

void ControllerModel::Advance(double seconds) {
  since_heartbeat_s_ += seconds;
  if (reg(map::kWatchdogMs) > 0 && since_heartbeat_s_ * 1000 > reg(map::kWatchdogMs)) {
    GoSafe();
    SetStatus(map::kStatusWatchdogTripped, true);
    reg(map::kWatchdogMs) = 0;
  }
  if (!moving_ || stall_next_move_) return;  // a stalled axis stays busy where it is
  const double step = CountsPerSecond() * seconds;
  const double remaining = target_ - position_;
  if (std::abs(remaining) <= step) {
    position_ = target_;
    moving_ = false;
    SetStatus(map::kStatusBusy, false);
    SetStatus(map::kStatusInPosition, true);
    if (homing_) SetStatus(map::kStatusHomed, true);
    homing_ = false;
  } else {
    position_ += std::copysign(step, remaining);
  }
  Write32(map::kTurntablePosition, static_cast<int32_t>(std::lround(position_)));
}

void ControllerModel::StartMove(double target) {
  if (reg(map::kStatus) & map::kStatusFault) return;
  target_ = target;
  moving_ = true;
  SetStatus(map::kStatusBusy, true);
  SetStatus(map::kStatusInPosition, false);
}

void ControllerModel::Command(uint16_t command) {
  switch (command) {
    case map::kCommandEnable:
      SetStatus(map::kStatusEnabled, true);
      SetStatus(map::kStatusWatchdogTripped, false);
      break;
    case map::kCommandDisable:
      GoSafe();
      break;
    case map::kCommandHome:
      homing_ = true;
      StartMove(0);
      break;
    case map::kCommandMove:
      StartMove(Read32(map::kTurntableTarget));
      break;
    case map::kCommandStop:
      moving_ = homing_ = false;
      stall_next_move_ = false;
      SetStatus(map::kStatusBusy, false);
      break;
    case map::kCommandClearFault:
      SetStatus(map::kStatusFault, false);
      SetStatus(map::kStatusOverTemperature, false);
      reg(map::kFaultCode) = map::kFaultNone;
      UpdateTemperature();
      break;
    default:
      break;
  }
}

void ControllerModel::InjectFault(uint16_t what) {
  switch (what) {
    case map::kInjectStall:
      stall_next_move_ = true;
      break;
    case map::kInjectOverTemperature:
      std::fill(registers_ + map::kLedCurrents, registers_ + map::kLedCurrents + map::kMaxLeds, 0);
      SetStatus(map::kStatusOverTemperature, true);
      Fault(map::kFaultOverTemperature);
      reg(map::kLedTemperature) = 950;
      break;
    case map::kInjectMotorFault:
      Fault(map::kFaultMotorStall);
      break;
    default:
      stall_next_move_ = false;
      break;
  }
}

void ControllerModel::UpdateTemperature() {
  if (spec_.kind != ControllerKind::kLeds) return;
  double total_ma = 0;
  for (int i = 0; i < map::kMaxLeds; ++i) total_ma += reg(map::kLedCurrents + i);
  reg(map::kLedTemperature) = static_cast<uint16_t>(std::lround((30.0 + 0.002 * total_ma) * 10));
}

int ControllerModel::CheckWrite(int address, std::span<const uint16_t> values) const {
  const int count = static_cast<int>(values.size());
  if (address == map::kSimInjectFault && count == 1) return 0;
  if (address == map::kHeartbeat && count == 1) return 0;
  if (address == map::kWatchdogMs && count == 1) {
    return values[0] <= map::kMaxWatchdogMs ? 0 : MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
  }
  const bool writable_common = address == map::kCommand && count == 1;
  if (writable_common) {
    return values[0] >= map::kCommandEnable && values[0] <= map::kCommandClearFault ? 0 : MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
  }
  switch (spec_.kind) {
    case ControllerKind::kTurntable:
      if (address >= map::kTurntableTarget && address + count <= map::kTurntableTarget + 2) {
        return 0;  // the full value is checked when the move starts
      }
      if (address == map::kTurntableSpeed && count == 1) {
        return values[0] > 0 && values[0] <= reg(map::kTurntableMaxSpeed) ? 0 : MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
      }
      break;
    case ControllerKind::kLinearLight:
      if (address >= map::kLinearTarget && address + count <= map::kLinearTarget + 2) return 0;
      if (address == map::kLinearSpeed && count == 1) {
        return values[0] > 0 && values[0] <= reg(map::kLinearMaxSpeed) ? 0 : MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
      }
      if (address >= map::kLinearStripOn && address + count <= map::kLinearStripIntensity + 1) {
        for (int i = 0; i < count; ++i) {
          const int r = address + i;
          if (r == map::kLinearStripOn && values[i] > 1) return MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
          if (r == map::kLinearStripIntensity && values[i] > 1000) return MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
        }
        return 0;
      }
      break;
    case ControllerKind::kLeds:
      if (address == map::kLedCurrentLimit && count == 1) {
        return values[0] <= reg(map::kLedMaxCurrent) ? 0 : MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
      }
      if (address == map::kLedTriggerFire && count == 1) {
        if (values[0] != 1) return MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
        return (reg(map::kStatus) & map::kStatusEnabled) ? 0 : MODBUS_EXCEPTION_SLAVE_OR_SERVER_FAILURE;
      }
      if (address >= map::kLedCurrents && address + count <= map::kLedCurrents + reg(map::kLedCount)) {
        for (uint16_t current : values) {
          if (current == 0) continue;
          if (reg(map::kStatus) & map::kStatusOverTemperature) return MODBUS_EXCEPTION_SLAVE_OR_SERVER_FAILURE;
          if (current > reg(map::kLedCurrentLimit)) return MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
        }
        return 0;
      }
      break;
  }
  return MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS;
}

void ControllerModel::OnWritten(int address, int count) {
  if (Overlaps(address, count, map::kSimInjectFault)) {
    InjectFault(reg(map::kSimInjectFault));
    reg(map::kSimInjectFault) = 0;
  }
  if (Overlaps(address, count, map::kHeartbeat) || Overlaps(address, count, map::kWatchdogMs)) since_heartbeat_s_ = 0;
  if (Overlaps(address, count, map::kWatchdogMs) && reg(map::kWatchdogMs) > 0) {
    SetStatus(map::kStatusWatchdogTripped, false);
  }
  if (Overlaps(address, count, map::kCommand)) Command(reg(map::kCommand));
  if (spec_.kind == ControllerKind::kLeds && address >= map::kLedCurrents) UpdateTemperature();
  if (spec_.kind == ControllerKind::kLeds && Overlaps(address, count, map::kLedTriggerFire)) {
    reg(map::kLedTriggerFire) = 0;
    ++reg(map::kLedTriggerCount);  // wraps at 65536, as the register does
  }
  if (spec_.kind == ControllerKind::kTurntable && Overlaps(address, count, map::kTurntableTarget)) {
    // Targets wrap into [0, 360000) millidegrees like the real controller.
    int32_t target = Read32(map::kTurntableTarget) % 360000;
    if (target < 0) target += 360000;
    Write32(map::kTurntableTarget, target);
  }
  if (spec_.kind == ControllerKind::kLinearLight && Overlaps(address, count, map::kLinearTarget)) {
    Write32(map::kLinearTarget, std::clamp(Read32(map::kLinearTarget), 0, Read32(map::kLinearTravel)));
  }
}

}  // namespace loom::hal::sim
