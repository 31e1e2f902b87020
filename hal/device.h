#pragma once
// The lifecycle every loom device shares, and how configuration is negotiated.
//
//   Open() → Configure(settings) → Start() → act (move, trigger, drive LEDs, ...) → Stop() → Close()
//
// | state       | reached by            | allowed next                                        |
// |-------------|-----------------------|-----------------------------------------------------|
// | kClosed     | construction, Close() | Open()                                              |
// | kOpen       | Open()                | Configure(), Close()                                |
// | kConfigured | Configure(), Stop()   | Configure(), Start(), Close()                       |
// | kRunning    | Start()               | acts, Stop(), Close()                               |
//
// A call in the wrong state returns FailedPrecondition naming the device, its state and the call.
// MakeSafe() (LEDs off, motion stopped) is allowed in every state and is what the rig's
// safe-state guard calls on every exit path.
//
// Configure negotiates (libcamera's pattern): a request the device can honour exactly is kValid;
// one it can honour after changing values (exposure rounded to the sensor's step, ROI aligned)
// is kAdjusted and the report lists each change — the adjusted values are what gets applied and
// recorded; one it cannot honour is kInvalid, with the reasons, and changes nothing.
//
// The public methods check the state and call the backend's Do* hooks, so no backend can skip
// the checks. Thread-safety: a device is used from one thread at a time.

#include <string>
#include <string_view>
#include <vector>

#include "core/status.h"

namespace loom::hal {

enum class DeviceState { kClosed, kOpen, kConfigured, kRunning };
std::string_view DeviceStateName(DeviceState state);

enum class Negotiation { kValid, kAdjusted, kInvalid };
std::string_view NegotiationName(Negotiation negotiation);

struct Adjustment {
  std::string setting;    // "exposure_us"
  std::string requested;  // "1234.5"
  std::string applied;    // "1234"
  std::string reason;     // "sensor step is 1 µs"
};

struct ConfigureReport {
  Negotiation outcome = Negotiation::kValid;
  std::vector<Adjustment> adjustments;  // kAdjusted: every change made
  std::vector<std::string> problems;    // kInvalid: every reason

  void Adjust(std::string setting, std::string requested, std::string applied, std::string reason);
  void Reject(std::string problem);
  // One line per adjustment or problem.
  std::string ToString() const;
  // OK unless kInvalid; then InvalidArgument naming `device` and listing the problems.
  Status ToStatus(const std::string& device) const;
};

// Who a device is, as far as its backend knows after Open().
struct DeviceIdentity {
  std::string vendor;
  std::string model;
  std::string serial;
  std::string firmware;
};

class Device {
 public:
  // `name` is the device's name in the rig YAML ("cam0"); `backend` its backend key ("aravis");
  // `address` where it is reached ("127.0.0.1", "tcp://127.0.0.1:1502", "usb:1d6b:0104").
  Device(std::string kind, std::string name, std::string backend, std::string address);
  virtual ~Device() = default;
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

  const std::string& kind() const { return kind_; }
  const std::string& name() const { return name_; }
  const std::string& backend() const { return backend_; }
  const std::string& address() const { return address_; }
  DeviceState state() const { return state_; }
  // "camera 'cam0' (aravis 127.0.0.1)": the subject of every status this device returns.
  const std::string& description() const { return description_; }
  // Filled by Open(); empty fields where the device does not say.
  const DeviceIdentity& identity() const { return identity_; }

  Status Open();
  Status Start();
  Status Stop();
  // Always ends in kClosed; returns the first error met on the way (the device may be gone).
  Status Close();
  // LEDs off, motion stopped, acquisition stopped; in any state, best effort, idempotent.
  Status MakeSafe();

 protected:
  // FailedPrecondition unless the state is one of `allowed`.
  Status ExpectState(std::initializer_list<DeviceState> allowed, std::string_view call) const;
  // After a successful Configure.
  void MarkConfigured() { state_ = DeviceState::kConfigured; }
  // A status about this device: Error(StatusCode::kTimeout, "no frame within 2000 ms").
  Status Error(StatusCode code, std::string message) const;

  virtual Result<DeviceIdentity> DoOpen() = 0;
  virtual Status DoStart() = 0;
  virtual Status DoStop() = 0;
  virtual Status DoClose() = 0;
  // Called only when the device is open (any state but kClosed).
  virtual Status DoMakeSafe() = 0;

 private:
  std::string kind_;
  std::string name_;
  std::string backend_;
  std::string address_;
  std::string description_;
  DeviceIdentity identity_;
  DeviceState state_ = DeviceState::kClosed;
};

}  // namespace loom::hal
