#include "hal/modbus/modbus_backends.h"

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

#include "core/interrupt.h"
#include "core/log.h"
#include "hal/internal/format.h"
#include "hal/modbus/modbus_link.h"
#include "hal/modbus/register_map.h"

namespace loom::hal {
namespace {

namespace map = modbus_map;
using internal::FormatNumber;
using Clock = std::chrono::steady_clock;

constexpr std::chrono::milliseconds kPollInterval(5);

struct ModbusOptions {
  ModbusEndpoint endpoint;
  std::chrono::milliseconds response_timeout{500};
  std::chrono::milliseconds watchdog{0};  // 0: the controller's watchdog stays off
};

Result<ModbusOptions> ReadOptions(const DeviceConfig& config) {
  std::string endpoint;
  int timeout_ms = 500;
  int watchdog_ms = 0;
  config.node.Required("endpoint", &endpoint);
  config.node.Optional("response_timeout_ms", &timeout_ms);
  config.node.Optional("watchdog_ms", &watchdog_ms);
  // A request and its one retry may hold the link for twice the response timeout, and the
  // heartbeat waits behind it: a shorter watchdog would trip while loom is alive.
  if (watchdog_ms != 0 && (watchdog_ms < 3 * timeout_ms || watchdog_ms > map::kMaxWatchdogMs)) {
    return InvalidArgumentError("key '" + config.node.path() + ".watchdog_ms'",
                                std::to_string(watchdog_ms) + " must be 0 (off) or in [3 × response_timeout_ms = " +
                                    std::to_string(3 * timeout_ms) + ", " + std::to_string(map::kMaxWatchdogMs) + "]");
  }
  ModbusOptions options;
  options.response_timeout = std::chrono::milliseconds(timeout_ms);
  options.watchdog = std::chrono::milliseconds(watchdog_ms);
  if (endpoint.empty()) return options;  // the missing key is recorded in the document
  Result<ModbusEndpoint> parsed = ParseModbusEndpoint(endpoint);
  if (!parsed.ok()) {
    return InvalidArgumentError("key '" + config.node.path() + ".endpoint'", parsed.status().ToString());
  }
  options.endpoint = *parsed;
  return options;
}

std::string_view TypeName(uint16_t type) {
  switch (type) {
    case map::kTypeTurntable:
      return "turntable";
    case map::kTypeLeds:
      return "LED controller";
    case map::kTypeLinearLight:
      return "linear light";
    default:
      return "unknown device";
  }
}

std::string_view FaultName(uint16_t code) {
  switch (code) {
    case map::kFaultNone:
      return "none";
    case map::kFaultMotorStall:
      return "motor stall";
    case map::kFaultOverTemperature:
      return "over-temperature";
    case map::kFaultLimitSwitch:
      return "limit switch";
    default:
      return "unknown fault";
  }
}

// Connects, checks the device type and returns the identity from the common block.
Result<DeviceIdentity> OpenController(ModbusLink& link, uint16_t expected_type, const std::string& description) {
  LOOM_RETURN_IF_ERROR(link.Connect());
  LOOM_ASSIGN_OR_RETURN(const std::vector<uint16_t> common, link.Read(0, map::kSerialLow + 1));
  if (common[map::kDeviceType] != expected_type) {
    link.Close();
    return InvalidArgumentError(description, "the controller at " + link.endpoint().ToString() + " is a " +
                                                 std::string(TypeName(common[map::kDeviceType])) + ", not a " +
                                                 std::string(TypeName(expected_type)));
  }
  DeviceIdentity identity;
  identity.vendor = "loom Modbus controller";
  identity.model = std::string(TypeName(expected_type));
  identity.serial = std::to_string((static_cast<uint32_t>(common[map::kSerialHigh]) << 16) | common[map::kSerialLow]);
  identity.firmware =
      std::to_string(common[map::kFirmwareVersion] >> 8) + "." + std::to_string(common[map::kFirmwareVersion] & 0xFF);
  return identity;
}

// The controller's watchdog (register_map.h, kWatchdogMs), armed while the device runs: a thread
// writes a heartbeat every quarter of the timeout. A loom that is killed or hangs stops feeding
// it, and the controller goes safe by itself.
class Watchdog {
 public:
  Watchdog(ModbusLink& link, std::chrono::milliseconds timeout) : link_(link), timeout_(timeout) {}
  ~Watchdog() { StopFeeding(); }
  Watchdog(const Watchdog&) = delete;
  Watchdog& operator=(const Watchdog&) = delete;

  Status Arm() {
    if (timeout_.count() == 0) return Status::Ok();
    StopFeeding();
    LOOM_RETURN_IF_ERROR(link_.Write(map::kWatchdogMs, static_cast<uint16_t>(timeout_.count())));
    stop_ = false;
    feeder_ = std::thread([this] { Feed(); });
    return Status::Ok();
  }

  Status Disarm() {
    if (!feeder_.joinable()) return Status::Ok();
    StopFeeding();
    return link_.Write(map::kWatchdogMs, 0);
  }

 private:
  void Feed() {
    std::unique_lock<std::mutex> lock(mutex_);
    uint16_t beat = 0;
    bool warned = false;
    while (!wake_.wait_for(lock, timeout_ / 4, [this] { return stop_; })) {
      lock.unlock();
      const Status fed = link_.Write(map::kHeartbeat, ++beat);
      if (!fed.ok() && !warned) LOOM_LOG(Warning) << "watchdog heartbeat: " << fed.ToString();
      warned = !fed.ok();
      lock.lock();
    }
  }

  void StopFeeding() {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    if (feeder_.joinable()) feeder_.join();
  }

  ModbusLink& link_;
  std::chrono::milliseconds timeout_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread feeder_;
};

// One controller's connection and watchdog, started, stopped and closed alike by every device.
class Controller {
 public:
  Controller(const std::string& device, const ModbusOptions& options)
      : link(device, options.endpoint, options.response_timeout), watchdog_(link, options.watchdog) {}

  Status Enable() {
    LOOM_RETURN_IF_ERROR(link.Write(map::kCommand, map::kCommandEnable));
    return watchdog_.Arm();
  }
  // Before a command that changes the outputs: a controller that went safe by itself (its
  // watchdog tripped while loom could not reach it: a frozen link or controller) or restarted
  // (its registers back at their power-up values) has the device's settings written again by
  // `restore_settings` and is enabled and armed again, with a warning naming it; its outputs
  // were switched off, so the caller's command sets them anew. One status read: the status as it
  // was read comes back (a restarted axis is no longer homed).
  Result<uint16_t> EnableIfWentSafe(const std::function<Status()>& restore_settings) {
    LOOM_ASSIGN_OR_RETURN(const uint16_t status, link.Read(map::kStatus));
    if (OutputsEnabled(status)) return status;
    LOOM_LOG(Warning) << link.device() << ": the controller had gone safe"
                      << (status & map::kStatusWatchdogTripped ? " (its watchdog tripped: no heartbeat reached it in time)" : "")
                      << "; writing its settings and enabling it again";
    LOOM_RETURN_IF_ERROR(restore_settings());
    LOOM_RETURN_IF_ERROR(Enable());
    return status;
  }
  // Whether a controller of this status drives its outputs: a disabled one lights no LED or
  // strip and moves no motor.
  static bool OutputsEnabled(uint16_t status) { return (status & map::kStatusEnabled) != 0; }
  Status Disable() {
    const Status disarmed = watchdog_.Disarm();
    const Status disabled = link.Write(map::kCommand, map::kCommandDisable);
    return disarmed.ok() ? disabled : disarmed;
  }
  Status Close() {
    const Status disarmed = watchdog_.Disarm();
    link.Close();
    return disarmed;
  }

  ModbusLink link;

 private:
  Watchdog watchdog_;  // after link: stops feeding before the link goes
};

// A Modbus axis (turntable or linear carriage): commands and the wait for a move to finish.
class Axis {
 public:
  Axis(ModbusLink& link, const std::string& description, std::string unit, double counts_per_unit)
      : link_(link), description_(description), unit_(std::move(unit)), counts_per_unit_(counts_per_unit) {}

  Result<double> Position() {
    LOOM_ASSIGN_OR_RETURN(const int32_t counts, link_.Read32(map::kTurntablePosition));
    return counts / counts_per_unit_;
  }

  Status MoveTo(double target, int timeout_ms) {
    LOOM_RETURN_IF_ERROR(link_.Write32(map::kTurntableTarget, static_cast<int32_t>(std::lround(target * counts_per_unit_))));
    LOOM_RETURN_IF_ERROR(link_.Write(map::kCommand, map::kCommandMove));
    return WaitUntilSettled("move to " + FormatNumber(target) + " " + unit_, timeout_ms, map::kStatusInPosition);
  }

  Status Home(int timeout_ms) {
    LOOM_RETURN_IF_ERROR(link_.Write(map::kCommand, map::kCommandHome));
    return WaitUntilSettled("homing", timeout_ms, map::kStatusHomed);
  }

  // An axis whose controller does not know its zero (after power-up or a restart: `status`
  // without kStatusHomed) is homed first, so that a target means the same place as before.
  Status HomeIfNotHomed(uint16_t status, int timeout_ms) {
    if (status & map::kStatusHomed) return Status::Ok();
    LOOM_LOG(Info) << description_ << ": not homed (powered up or restarted); homing before it moves";
    return Home(timeout_ms);
  }

  Status Stop() { return link_.Write(map::kCommand, map::kCommandStop); }

 private:
  // Polls the status until the axis is idle with `done_bit` set, a fault, the timeout or Ctrl-C;
  // the last two stop the motion.
  Status WaitUntilSettled(const std::string& what, int timeout_ms, uint16_t done_bit) {
    const Clock::time_point deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
    while (true) {
      LOOM_ASSIGN_OR_RETURN(const std::vector<uint16_t> block, link_.Read(map::kStatus, 2));
      const uint16_t status = block[0];
      if (status & map::kStatusFault) {
        return Status(StatusCode::kUnavailable, description_,
                      what + " failed: the controller reports fault " + std::to_string(block[1]) + " (" +
                          std::string(FaultName(block[1])) + ")");
      }
      if (!(status & map::kStatusBusy) && (status & done_bit)) return Status::Ok();
      if (InterruptRequested() || Clock::now() > deadline) {
        const Status stopped = Stop();
        const Result<double> where = Position();
        const std::string at = where.ok() ? " (stopped at " + FormatNumber(*where) + " " + unit_ + ")" : "";
        if (InterruptRequested()) return Status(StatusCode::kCancelled, description_, what + " interrupted" + at);
        return Status(StatusCode::kTimeout, description_,
                      what + " did not complete within " + std::to_string(timeout_ms) + " ms" + at +
                          (stopped.ok() ? "" : "; stopping failed too: " + stopped.message()));
      }
      std::this_thread::sleep_for(kPollInterval);
    }
  }

  ModbusLink& link_;
  const std::string& description_;
  std::string unit_;
  double counts_per_unit_;
};

static_assert(map::kTurntableTarget == map::kLinearTarget && map::kTurntablePosition == map::kLinearPosition,
              "Axis uses one target/position layout for both axes");

class ModbusTurntable : public Turntable {
 public:
  ModbusTurntable(const DeviceConfig& config, ModbusOptions options)
      : Turntable(config.name, config.backend, options.endpoint.ToString()),
        controller_(description(), options),
        axis_(controller_.link, description(), "deg", 1000.0) {}

 protected:
  Result<DeviceIdentity> DoOpen() override {
    LOOM_ASSIGN_OR_RETURN(DeviceIdentity identity, OpenController(link_, map::kTypeTurntable, description()));
    LOOM_ASSIGN_OR_RETURN(const uint16_t max_speed, link_.Read(map::kTurntableMaxSpeed));
    set_max_speed(max_speed / 100.0);
    return identity;
  }
  Status DoConfigure(const TurntableSettings& applied) override {
    return link_.Write(map::kTurntableSpeed, static_cast<uint16_t>(std::lround(applied.speed_deg_s * 100)));
  }
  Status DoStart() override { return controller_.Enable(); }
  Status DoStop() override { return controller_.Disable(); }
  Status DoClose() override { return controller_.Close(); }
  Status DoMakeSafe() override { return axis_.Stop(); }
  Status DoHome() override { return axis_.Home(settings().move_timeout_ms); }
  Status DoMoveTo(double angle_deg) override {
    LOOM_ASSIGN_OR_RETURN(const uint16_t status, controller_.EnableIfWentSafe([this] { return DoConfigure(settings()); }));
    LOOM_RETURN_IF_ERROR(axis_.HomeIfNotHomed(status, settings().move_timeout_ms));
    return axis_.MoveTo(angle_deg, settings().move_timeout_ms);
  }
  Result<double> DoAngle() override { return axis_.Position(); }

 private:
  Controller controller_;
  ModbusLink& link_ = controller_.link;
  Axis axis_;
};

class ModbusLinearLight : public LinearLight {
 public:
  ModbusLinearLight(const DeviceConfig& config, ModbusOptions options)
      : LinearLight(config.name, config.backend, options.endpoint.ToString()),
        controller_(description(), options),
        axis_(controller_.link, description(), "mm", 1000.0) {}

 protected:
  Result<DeviceIdentity> DoOpen() override {
    LOOM_ASSIGN_OR_RETURN(DeviceIdentity identity, OpenController(link_, map::kTypeLinearLight, description()));
    LOOM_ASSIGN_OR_RETURN(const uint16_t max_speed, link_.Read(map::kLinearMaxSpeed));
    LOOM_ASSIGN_OR_RETURN(const int32_t travel_um, link_.Read32(map::kLinearTravel));
    set_limits(travel_um / 1000.0, max_speed / 10.0);
    return identity;
  }
  Status DoConfigure(const LinearLightSettings& applied) override {
    return link_.Write(map::kLinearSpeed, static_cast<uint16_t>(std::lround(applied.speed_mm_s * 10)));
  }
  Status DoStart() override { return controller_.Enable(); }
  Status DoStop() override { return controller_.Disable(); }
  Status DoClose() override { return controller_.Close(); }
  Status DoMakeSafe() override {
    const Status stopped = axis_.Stop();
    const Status dark = link_.Write(map::kLinearStripOn, 0);
    return stopped.ok() ? dark : stopped;
  }
  Status DoHome() override { return axis_.Home(settings().move_timeout_ms); }
  Status DoMoveTo(double position_mm) override {
    LOOM_ASSIGN_OR_RETURN(const uint16_t status, controller_.EnableIfWentSafe([this] { return DoConfigure(settings()); }));
    LOOM_RETURN_IF_ERROR(axis_.HomeIfNotHomed(status, settings().move_timeout_ms));
    return axis_.MoveTo(position_mm, settings().move_timeout_ms);
  }
  Status DoSetStrip(bool on, double intensity) override {
    LOOM_RETURN_IF_ERROR(controller_.EnableIfWentSafe([this] { return DoConfigure(settings()); }).status());
    const uint16_t values[2] = {static_cast<uint16_t>(on ? 1 : 0), static_cast<uint16_t>(std::lround(intensity * 1000))};
    return link_.Write(map::kLinearStripOn, values);
  }
  Result<LinearLightReadback> DoRead() override {
    LOOM_ASSIGN_OR_RETURN(const double position, axis_.Position());
    LOOM_ASSIGN_OR_RETURN(const std::vector<uint16_t> strip, link_.Read(map::kLinearStripOn, 2));
    LOOM_ASSIGN_OR_RETURN(const uint16_t status, link_.Read(map::kStatus));
    return LinearLightReadback{position, Controller::OutputsEnabled(status) && strip[0] != 0, strip[1] / 1000.0};
  }

 private:
  Controller controller_;
  ModbusLink& link_ = controller_.link;
  Axis axis_;
};

class ModbusLedArray : public LedArray {
 public:
  ModbusLedArray(const DeviceConfig& config, ModbusOptions options)
      : LedArray(config.name, config.backend, options.endpoint.ToString()), controller_(description(), options) {}

 protected:
  Result<DeviceIdentity> DoOpen() override {
    LOOM_ASSIGN_OR_RETURN(DeviceIdentity identity, OpenController(link_, map::kTypeLeds, description()));
    LOOM_ASSIGN_OR_RETURN(const std::vector<uint16_t> limits, link_.Read(map::kLedCount, 2));
    set_limits(std::min<int>(limits[0], map::kMaxLeds), limits[1]);
    return identity;
  }
  Status DoConfigure(const LedArraySettings& applied) override {
    return link_.Write(map::kLedCurrentLimit, static_cast<uint16_t>(std::lround(applied.current_limit_ma)));
  }
  Status DoStart() override { return controller_.Enable(); }
  Status DoStop() override {
    const Status dark = DoAllOff();
    const Status disabled = controller_.Disable();
    return dark.ok() ? disabled : dark;
  }
  Status DoClose() override { return controller_.Close(); }
  Status DoDrive(std::span<const scan::LedDrive> leds) override {
    LOOM_RETURN_IF_ERROR(controller_.EnableIfWentSafe([this] { return DoConfigure(settings()); }).status());
    std::vector<uint16_t> currents(led_count(), 0);
    for (const scan::LedDrive& drive : leds) currents[drive.led] = static_cast<uint16_t>(std::lround(drive.current_ma));
    const Status written = link_.Write(map::kLedCurrents, currents);
    if (written.ok() || written.code() != StatusCode::kUnavailable) return written;
    // A refused write: say why if the controller knows.
    const Result<uint16_t> status = link_.Read(map::kStatus);
    if (status.ok() && (*status & map::kStatusOverTemperature)) {
      return Error(StatusCode::kUnavailable, "over-temperature: the controller switched every LED off");
    }
    return written;
  }
  Status DoAllOff() override {
    const std::vector<uint16_t> zeros(led_count(), 0);
    return link_.Write(map::kLedCurrents, zeros);
  }
  Status DoFireTrigger() override {
    const Status fired = link_.Write(map::kLedTriggerFire, 1);
    if (fired.ok() || fired.code() != StatusCode::kUnavailable) return fired;
    return Error(StatusCode::kUnavailable, "camera trigger refused (register " + std::to_string(map::kLedTriggerFire) +
                                               "): the controller is disabled or has no trigger output (" + fired.message() +
                                               ")");
  }
  Result<LedArrayReadback> DoRead() override {
    LOOM_ASSIGN_OR_RETURN(const std::vector<uint16_t> currents, link_.Read(map::kLedCurrents, led_count()));
    LOOM_ASSIGN_OR_RETURN(const uint16_t status, link_.Read(map::kStatus));
    LOOM_ASSIGN_OR_RETURN(const uint16_t temperature, link_.Read(map::kLedTemperature));
    LedArrayReadback readback;
    readback.current_ma.assign(currents.begin(), currents.end());
    // Outputs disabled (stopped, or gone safe by itself): no LED is lit, whatever the currents.
    if (!Controller::OutputsEnabled(status)) std::fill(readback.current_ma.begin(), readback.current_ma.end(), 0.0);
    readback.temperature_c = temperature / 10.0;
    readback.over_temperature = (status & map::kStatusOverTemperature) != 0;
    return readback;
  }

 private:
  Controller controller_;
  ModbusLink& link_ = controller_.link;
};

template <typename Base, typename Concrete>
DeviceFactory<Base> Factory() {
  return [](const DeviceConfig& config) -> Result<std::unique_ptr<Base>> {
    LOOM_ASSIGN_OR_RETURN(ModbusOptions options, ReadOptions(config));
    return std::unique_ptr<Base>(std::make_unique<Concrete>(config, std::move(options)));
  };
}

}  // namespace

void RegisterModbusBackends(BackendRegistry& registry) {
  registry.Register<Turntable>("modbus", Factory<Turntable, ModbusTurntable>());
  registry.Register<LinearLight>("modbus", Factory<LinearLight, ModbusLinearLight>());
  registry.Register<LedArray>("modbus", Factory<LedArray, ModbusLedArray>());
}

}  // namespace loom::hal
