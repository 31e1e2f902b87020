#pragma once
// loom's USB protocol for a filter wheel (documented for firmware authors in
// docs/hardware/filter-wheel-usb.md): vendor control requests on endpoint 0 of interface 0.
// The contract between hal/usb's backend and a wheel's firmware (and the test's device model).

#include <cstdint>

namespace loom::hal::usb_wheel {

inline constexpr uint16_t kDefaultVendorId = 0x1209;   // pid.codes (open-source hardware)
inline constexpr uint16_t kDefaultProductId = 0x4C57;  // "LW": loom wheel

inline constexpr uint8_t kRequestTypeIn = 0xC0;   // device-to-host | vendor | device
inline constexpr uint8_t kRequestTypeOut = 0x40;  // host-to-device | vendor | device

// IN, wLength 4: [slot (0xFF while moving), busy (0/1), error code, slot count]
inline constexpr uint8_t kGetStatus = 0x01;
// OUT, wValue = slot, no data. STALL if the slot does not exist or the wheel is in error.
inline constexpr uint8_t kMove = 0x02;
// OUT: turn to the index mark (slot 0).
inline constexpr uint8_t kHome = 0x03;
// OUT: clear the error code.
inline constexpr uint8_t kClearError = 0x04;

inline constexpr uint8_t kSlotMoving = 0xFF;
inline constexpr uint8_t kErrorNone = 0;
inline constexpr uint8_t kErrorJammed = 1;  // the wheel did not reach the slot

// String descriptor indices.
inline constexpr uint8_t kManufacturerString = 1;
inline constexpr uint8_t kProductString = 2;
inline constexpr uint8_t kSerialString = 3;

}  // namespace loom::hal::usb_wheel
