#pragma once
// EmulatedFilterWheel: a stateful model of a loom filter wheel behind umockdev, for tests of the
// usb backend. It answers the usbdevfs ioctls that libusb issues (submit/reap of control URBs,
// capabilities, claim/release) following docs/hardware/filter-wheel-usb.md, so the unchanged
// libusb code runs against it. The test binary must run under `umockdev-wrapper`.
// Moves take `ms_per_slot` per slot of distance. Thread-safe: umockdev calls the model from its
// own thread while the test thread jams or unplugs it.

#include <umockdev.h>

#include <chrono>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

namespace loom::hal::testing {

class EmulatedFilterWheel {
 public:
  EmulatedFilterWheel(UMockdevTestbed* testbed, int device_number, std::string serial, int slots = 10, int ms_per_slot = 5);
  ~EmulatedFilterWheel();

  // The next move stops short with error "jammed"; later moves STALL until the error is cleared.
  void JamNextMove();
  // From now on every request fails as if the cable was pulled.
  void Unplug();
  int requests() const;

 private:
  struct PendingUrb {
    UMockdevIoctlData* urb;
    std::vector<uint8_t> in_data;
    int status;  // 0 or -EPIPE (STALL)
  };
  static gboolean OnIoctl(UMockdevIoctlBase* handler, UMockdevIoctlClient* client, gpointer self);
  bool HandleIoctl(UMockdevIoctlClient* client);
  // Answers one control request: IN data, or a STALL (returns false).
  bool Answer(const uint8_t* setup, std::vector<uint8_t>* in_data);
  void AdvanceMotion();

  UMockdevIoctlBase* handler_ = nullptr;
  std::string serial_;
  int slots_;
  std::chrono::milliseconds per_slot_;

  mutable std::mutex mutex_;
  std::deque<PendingUrb> completed_;
  int slot_ = 0;
  int target_ = 0;
  std::chrono::steady_clock::time_point move_end_{};
  bool moving_ = false;
  bool jam_next_ = false;
  int error_ = 0;
  bool unplugged_ = false;
  int requests_ = 0;
};

}  // namespace loom::hal::testing
