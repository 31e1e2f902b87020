// The modbus backend against loom-modbus-sim, a real Modbus peer on 127.0.0.1 (TCP) or a pty
// (RTU): moves, LEDs, faults, a frozen and a restarted controller, and the rig's safe state.
#include "hal/modbus/modbus_backends.h"
#include "core/testing/build_tree.h"

#include <gtest/gtest.h>

#include <csignal>
#include <thread>

#include "core/interrupt.h"
#include "core/testing/subprocess.h"
#include "hal/modbus/modbus_link.h"
#include "hal/modbus/register_map.h"
#include "hal/rig.h"

namespace loom::hal {
namespace {

namespace map = modbus_map;
using loom::testing::Subprocess;
using namespace std::chrono_literals;

struct Simulator {
  Subprocess process;
  std::string endpoint;  // for the rig YAML
};

// Starts loom-modbus-sim and waits for its "listening ..." line.
Simulator StartSimulator(const std::string& device, const std::string& where = "tcp:127.0.0.1:0",
                         std::vector<std::string> extra = {}) {
  std::vector<std::string> argv = {loom::testing::ModbusSimBinary(), "--device", device};
  if (where == "rtu") {
    argv.push_back("--rtu");
  } else {
    argv.push_back("--tcp");
    argv.push_back(where.substr(4));
  }
  argv.insert(argv.end(), extra.begin(), extra.end());
  Result<Subprocess> process = Subprocess::Start(argv);
  EXPECT_TRUE(process.ok()) << process.status().ToString();
  Result<std::string> line = process->ReadLine(5s);
  EXPECT_TRUE(line.ok()) << line.status().ToString();
  std::string endpoint;
  if (line->starts_with("listening tcp ")) endpoint = "tcp://" + line->substr(14);
  if (line->starts_with("listening rtu ")) endpoint = "rtu://" + line->substr(14);
  EXPECT_FALSE(endpoint.empty()) << *line;
  return {std::move(*process), endpoint};
}

// `sim` killed and a fresh controller of `device` started on its port: a power cycle.
Simulator PowerCycle(Simulator& sim, const std::string& device, const std::vector<std::string>& extra = {}) {
  const std::string port = sim.endpoint.substr(sim.endpoint.rfind(':') + 1);
  sim.process.Kill();
  return StartSimulator(device, "tcp:127.0.0.1:" + port, extra);
}

// Writes the simulator-only fault-injection register through a second connection.
void InjectFault(const std::string& endpoint, uint16_t fault) {
  ModbusLink link("test injector", *ParseModbusEndpoint(endpoint), 500ms);
  ASSERT_TRUE(link.Connect().ok());
  ASSERT_TRUE(link.Write(map::kSimInjectFault, fault).ok());
}

// A device created through the registry from a YAML snippet, like the rig does it.
template <typename D>
std::unique_ptr<D> MakeDevice(const std::string& yaml) {
  static BackendRegistry registry = [] {
    BackendRegistry r;
    RegisterModbusBackends(r);
    return r;
  }();
  auto doc = ConfigDocument::LoadString("schema_version: 1\ndevice: " + yaml, "test.yaml", 1);
  EXPECT_TRUE(doc.ok()) << doc.status().ToString();
  const ConfigNode node = doc->root().Child("device");
  DeviceConfig config{"", "", node};
  node.Required("name", &config.name);
  node.Required("backend", &config.backend);
  Result<std::unique_ptr<D>> device = registry.Create<D>(config);
  EXPECT_TRUE(device.ok()) << device.status().ToString();
  EXPECT_TRUE(doc->Finish().ok()) << doc->Finish().ToString();
  return std::move(*device);
}

std::string DeviceYaml(const std::string& name, const std::string& endpoint, const std::string& extra = "") {
  return "{name: " + name + ", backend: modbus, endpoint: \"" + endpoint + "\"" + extra + "}";
}

template <typename D, typename Settings>
void Bringup(D& device, const Settings& settings) {
  ASSERT_TRUE(device.Open().ok());
  const Result<ConfigureReport> report = device.Configure(settings);
  ASSERT_TRUE(report.ok()) << report.status().ToString();
  ASSERT_NE(report->outcome, Negotiation::kInvalid) << report->ToString();
  ASSERT_TRUE(device.Start().ok());
}

TEST(ModbusTurntableTest, MovesAndReportsWhereItIs) {
  Simulator sim = StartSimulator("turntable", "tcp:127.0.0.1:0", {"--serial", "4242", "--max-speed", "360"});
  auto turntable = MakeDevice<Turntable>(DeviceYaml("turntable", sim.endpoint));
  EXPECT_EQ(turntable->Home().code(), StatusCode::kFailedPrecondition);  // not open yet
  Bringup(*turntable, TurntableSettings{.speed_deg_s = 360, .move_timeout_ms = 5000});
  EXPECT_EQ(turntable->identity().serial, "4242");
  EXPECT_EQ(turntable->max_speed_deg_s(), 360.0);
  ASSERT_TRUE(turntable->Home().ok());
  ASSERT_TRUE(turntable->MoveTo(90).ok());
  EXPECT_NEAR(*turntable->Angle(), 90.0, 1e-3);
  ASSERT_TRUE(turntable->MoveTo(-30).ok());  // reduced to 330°
  EXPECT_NEAR(*turntable->Angle(), 330.0, 1e-3);
  ASSERT_TRUE(turntable->Stop().ok());
  ASSERT_TRUE(turntable->Close().ok());
}

TEST(ModbusTurntableTest, SpeedAboveMaximumIsAdjusted) {
  Simulator sim = StartSimulator("turntable", "tcp:127.0.0.1:0", {"--max-speed", "60"});
  auto turntable = MakeDevice<Turntable>(DeviceYaml("turntable", sim.endpoint));
  ASSERT_TRUE(turntable->Open().ok());
  const Result<ConfigureReport> report = turntable->Configure({.speed_deg_s = 100});
  ASSERT_TRUE(report.ok());
  EXPECT_EQ(report->outcome, Negotiation::kAdjusted);
  ASSERT_EQ(report->adjustments.size(), 1u);
  EXPECT_EQ(report->adjustments[0].setting, "speed_deg_s");
  EXPECT_EQ(turntable->settings().speed_deg_s, 60.0);
  const Result<ConfigureReport> invalid = turntable->Configure({.speed_deg_s = -1});
  ASSERT_TRUE(invalid.ok());
  EXPECT_EQ(invalid->outcome, Negotiation::kInvalid);
  EXPECT_EQ(turntable->settings().speed_deg_s, 60.0);  // unchanged
}

TEST(ModbusTurntableTest, WrongDeviceAtTheEndpointIsNamed) {
  Simulator sim = StartSimulator("leds");
  auto turntable = MakeDevice<Turntable>(DeviceYaml("turntable", sim.endpoint));
  const Status opened = turntable->Open();
  EXPECT_EQ(opened.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(opened.ToString().find("turntable 'turntable'"), std::string::npos) << opened.ToString();
  EXPECT_NE(opened.ToString().find("is a LED controller, not a turntable"), std::string::npos) << opened.ToString();
}

TEST(ModbusTurntableTest, StalledMoveTimesOutNamingTheDeviceAndStops) {
  Simulator sim = StartSimulator("turntable");
  auto turntable = MakeDevice<Turntable>(DeviceYaml("tt", sim.endpoint));
  Bringup(*turntable, TurntableSettings{.speed_deg_s = 60, .move_timeout_ms = 300});
  ASSERT_TRUE(turntable->MoveTo(0).ok());  // homed: the stall is the move's, not the homing's
  InjectFault(sim.endpoint, map::kInjectStall);
  const Status moved = turntable->MoveTo(45);
  EXPECT_EQ(moved.code(), StatusCode::kTimeout) << moved.ToString();
  EXPECT_EQ(moved.subject(), turntable->description());
  EXPECT_NE(moved.message().find("move to 45 deg did not complete within 300 ms"), std::string::npos) << moved.message();
  // It was stopped: the controller is idle, and the next move works.
  ModbusLink probe("probe", *ParseModbusEndpoint(sim.endpoint), 500ms);
  ASSERT_TRUE(probe.Connect().ok());
  EXPECT_EQ(*probe.Read(map::kStatus) & map::kStatusBusy, 0);
  EXPECT_TRUE(turntable->MoveTo(10).ok());
}

TEST(ModbusTurntableTest, ControllerFaultIsReportedWithItsCode) {
  Simulator sim = StartSimulator("turntable");
  auto turntable = MakeDevice<Turntable>(DeviceYaml("tt", sim.endpoint));
  Bringup(*turntable, TurntableSettings{.speed_deg_s = 60, .move_timeout_ms = 2000});
  InjectFault(sim.endpoint, map::kInjectMotorFault);
  const Status moved = turntable->MoveTo(45);
  EXPECT_EQ(moved.code(), StatusCode::kUnavailable);
  EXPECT_NE(moved.message().find("fault 1 (motor stall)"), std::string::npos) << moved.message();
}

TEST(ModbusTurntableTest, InterruptStopsAMoveWithCancelled) {
  Simulator sim = StartSimulator("turntable");
  auto turntable = MakeDevice<Turntable>(DeviceYaml("tt", sim.endpoint));
  Bringup(*turntable, TurntableSettings{.speed_deg_s = 1, .move_timeout_ms = 60000});
  const InterruptScope scope;
  SetInterruptRequested(false);
  std::thread interrupter([] {
    std::this_thread::sleep_for(100ms);
    std::raise(SIGINT);
  });
  const Status moved = turntable->MoveTo(180);
  interrupter.join();
  SetInterruptRequested(false);
  EXPECT_EQ(moved.code(), StatusCode::kCancelled) << moved.ToString();
  EXPECT_LT(*turntable->Angle(), 10.0);
}

TEST(ModbusLinkTest, FrozenControllerTimesOutThenRecovers) {
  Simulator sim = StartSimulator("turntable");
  auto turntable = MakeDevice<Turntable>(DeviceYaml("tt", sim.endpoint, ", response_timeout_ms: 200"));
  Bringup(*turntable, TurntableSettings{.speed_deg_s = 60, .move_timeout_ms = 2000});
  sim.process.Signal(SIGSTOP);
  const Result<double> frozen = turntable->Angle();
  ASSERT_FALSE(frozen.ok());
  EXPECT_EQ(frozen.status().code(), StatusCode::kTimeout);
  EXPECT_EQ(frozen.status().subject(), "turntable 'tt' (modbus " + sim.endpoint.substr(0) + "?unit=1)");
  sim.process.Signal(SIGCONT);
  // The late replies to the timed-out requests are flushed; the next answers are the right ones.
  for (int i = 0; i < 5; ++i) {
    const Result<double> angle = turntable->Angle();
    ASSERT_TRUE(angle.ok()) << angle.status().ToString();
    EXPECT_NEAR(*angle, 0.0, 1e-9);
  }
  EXPECT_TRUE(turntable->MoveTo(3).ok());
}

TEST(ModbusLinkTest, RestartedControllerIsReconnected) {
  Simulator sim = StartSimulator("turntable");
  const std::string port = sim.endpoint.substr(sim.endpoint.rfind(':') + 1);
  auto turntable = MakeDevice<Turntable>(DeviceYaml("tt", sim.endpoint));
  Bringup(*turntable, TurntableSettings{.speed_deg_s = 60, .move_timeout_ms = 2000});
  ASSERT_TRUE(turntable->MoveTo(5).ok());
  sim.process.Kill();
  // While it is down: a clear error, no hang.
  const Result<double> down = turntable->Angle();
  ASSERT_FALSE(down.ok());
  EXPECT_EQ(down.status().code(), StatusCode::kUnavailable) << down.status().ToString();
  Simulator restarted = StartSimulator("turntable", "tcp:127.0.0.1:" + port);
  const Result<double> angle = turntable->Angle();
  ASSERT_TRUE(angle.ok()) << angle.status().ToString();
  EXPECT_NEAR(*angle, 0.0, 1e-9);  // a fresh controller
  EXPECT_TRUE(turntable->MoveTo(2).ok());
}

// A restarted controller comes back at its power-up values, unhomed: the turntable's next move
// writes its speed again and homes it first, so that its angles mean what they meant.
TEST(ModbusTurntableTest, ARestartedControllerHasItsSpeedBackAndIsHomedBeforeItMoves) {
  Simulator sim = StartSimulator("turntable");
  auto turntable = MakeDevice<Turntable>(DeviceYaml("tt", sim.endpoint));
  Bringup(*turntable, TurntableSettings{.speed_deg_s = 45, .move_timeout_ms = 2000});
  ASSERT_TRUE(turntable->MoveTo(5).ok());
  Simulator restarted = PowerCycle(sim, "turntable");
  ModbusLink observer("test observer", *ParseModbusEndpoint(restarted.endpoint), 500ms);
  ASSERT_TRUE(observer.Connect().ok());
  ASSERT_NE(*observer.Read(map::kTurntableSpeed), 4500);  // the power-up speed: its maximum
  EXPECT_EQ(*observer.Read(map::kStatus) & map::kStatusHomed, 0);
  ASSERT_TRUE(turntable->MoveTo(2).ok());
  EXPECT_EQ(*observer.Read(map::kTurntableSpeed), 4500);
  EXPECT_NE(*observer.Read(map::kStatus) & map::kStatusHomed, 0);
  EXPECT_NEAR(*turntable->Angle(), 2.0, 1e-9);
}

TEST(ModbusLedArrayTest, DrivesReadsBackAndRefusesBadRequests) {
  Simulator sim = StartSimulator("leds", "tcp:127.0.0.1:0", {"--led-count", "29", "--max-current-ma", "800"});
  auto leds = MakeDevice<LedArray>(DeviceYaml("leds", sim.endpoint));
  Bringup(*leds, LedArraySettings{.current_limit_ma = 500});
  EXPECT_EQ(leds->led_count(), 29);
  const scan::LedDrive drive[] = {{3, 250}, {17, 500}};
  ASSERT_TRUE(leds->Drive(drive).ok());
  Result<LedArrayReadback> read = leds->Read();
  ASSERT_TRUE(read.ok());
  EXPECT_EQ(read->current_ma[3], 250);
  EXPECT_EQ(read->current_ma[17], 500);
  EXPECT_EQ(read->current_ma[0], 0);
  EXPECT_GT(read->temperature_c, 30.0);

  const scan::LedDrive too_bright[] = {{3, 501}};
  EXPECT_EQ(leds->Drive(too_bright).code(), StatusCode::kInvalidArgument);
  const scan::LedDrive missing[] = {{29, 10}};
  const Status no_led = leds->Drive(missing);
  EXPECT_EQ(no_led.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(no_led.message().find("LED 29 does not exist"), std::string::npos);

  ASSERT_TRUE(leds->AllOff().ok());
  read = leds->Read();
  for (double current : read->current_ma) EXPECT_EQ(current, 0);
}

TEST(ModbusLedArrayTest, OverTemperatureSwitchesOffAndIsReported) {
  Simulator sim = StartSimulator("leds");
  auto leds = MakeDevice<LedArray>(DeviceYaml("hemisphere", sim.endpoint));
  Bringup(*leds, LedArraySettings{.current_limit_ma = 500});
  const scan::LedDrive drive[] = {{0, 100}};
  ASSERT_TRUE(leds->Drive(drive).ok());
  InjectFault(sim.endpoint, map::kInjectOverTemperature);
  const Status refused = leds->Drive(drive);
  EXPECT_EQ(refused.code(), StatusCode::kUnavailable);
  EXPECT_NE(refused.ToString().find("LED array 'hemisphere'"), std::string::npos) << refused.ToString();
  EXPECT_NE(refused.message().find("over-temperature"), std::string::npos) << refused.message();
  const Result<LedArrayReadback> read = leds->Read();
  ASSERT_TRUE(read.ok());
  EXPECT_TRUE(read->over_temperature);
  EXPECT_EQ(read->current_ma[0], 0);
}

// The controller's own current limit is what loom set, also after the controller restarted (it
// powers up at its maximum): the limit is written again before it is enabled.
TEST(ModbusLedArrayTest, ARestartedControllerHasItsCurrentLimitBack) {
  Simulator sim = StartSimulator("leds", "tcp:127.0.0.1:0", {"--max-current-ma", "800"});
  auto leds = MakeDevice<LedArray>(DeviceYaml("leds", sim.endpoint));
  Bringup(*leds, LedArraySettings{.current_limit_ma = 300});
  const scan::LedDrive drive[] = {{3, 250}};
  ASSERT_TRUE(leds->Drive(drive).ok());
  Simulator restarted = PowerCycle(sim, "leds", {"--max-current-ma", "800"});
  ModbusLink observer("test observer", *ParseModbusEndpoint(restarted.endpoint), 500ms);
  ASSERT_TRUE(observer.Connect().ok());
  ASSERT_EQ(*observer.Read(map::kLedCurrentLimit), 800);
  ASSERT_TRUE(leds->Drive(drive).ok());
  EXPECT_EQ(*observer.Read(map::kLedCurrentLimit), 300);
  EXPECT_EQ(*observer.Read(map::kLedCurrents + 3), 250);
  EXPECT_NE(*observer.Read(map::kStatus) & map::kStatusEnabled, 0);
}

// The camera trigger output: each FireTrigger() is one pulse, counted by the controller; a
// disabled controller refuses it, and the error names the device and the register.
TEST(ModbusLedArrayTest, FiresTheCameraTriggerOncePerCallAndNotWhenDisabled) {
  Simulator sim = StartSimulator("leds");
  auto leds = MakeDevice<LedArray>(DeviceYaml("hemisphere", sim.endpoint));
  Bringup(*leds, LedArraySettings{.current_limit_ma = 500});
  ModbusLink observer("test observer", *ParseModbusEndpoint(sim.endpoint), 500ms);
  ASSERT_TRUE(observer.Connect().ok());
  const uint16_t before = *observer.Read(map::kLedTriggerCount);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(leds->FireTrigger().ok());
  EXPECT_EQ(*observer.Read(map::kLedTriggerCount), before + 3);
  EXPECT_EQ(*observer.Read(map::kLedTriggerFire), 0);

  ASSERT_TRUE(observer.Write(map::kCommand, map::kCommandDisable).ok());
  const Status refused = leds->FireTrigger();
  EXPECT_EQ(refused.code(), StatusCode::kUnavailable);
  EXPECT_NE(refused.ToString().find("LED array 'hemisphere'"), std::string::npos) << refused.ToString();
  EXPECT_NE(refused.message().find("register 14"), std::string::npos) << refused.message();
  EXPECT_EQ(*observer.Read(map::kLedTriggerCount), before + 3);
}

// The controller's watchdog: a device armed with watchdog_ms feeds it while it runs, so its LEDs
// stay lit well past the timeout; a client that stops feeding (as a killed loom does) finds the
// controller dark, disabled and saying why; an orderly stop disarms it.
TEST(ModbusWatchdogTest, ARunningDeviceFeedsItAndASilentClientIsSwitchedOff) {
  Simulator sim = StartSimulator("leds");
  auto leds = MakeDevice<LedArray>(DeviceYaml("leds", sim.endpoint, ", response_timeout_ms: 100, watchdog_ms: 300"));
  Bringup(*leds, LedArraySettings{.current_limit_ma = 500});
  const scan::LedDrive drive[] = {{5, 200}};
  ASSERT_TRUE(leds->Drive(drive).ok());
  std::this_thread::sleep_for(900ms);  // three timeouts: fed by the device's heartbeat thread
  ModbusLink observer("test observer", *ParseModbusEndpoint(sim.endpoint), 500ms);
  ASSERT_TRUE(observer.Connect().ok());
  EXPECT_EQ(*observer.Read(map::kLedCurrents + 5), 200);
  EXPECT_EQ(*observer.Read(map::kWatchdogMs), 300);
  ASSERT_TRUE(leds->Stop().ok());  // an orderly stop disarms it
  EXPECT_EQ(*observer.Read(map::kWatchdogMs), 0);

  // A client that arms it, lights an LED and falls silent.
  ASSERT_TRUE(observer.Write(map::kCommand, map::kCommandEnable).ok());
  ASSERT_TRUE(observer.Write(map::kWatchdogMs, 200).ok());
  ASSERT_TRUE(observer.Write(map::kLedCurrents + 5, 200).ok());
  EXPECT_EQ(*observer.Read(map::kLedCurrents + 5), 200);
  std::this_thread::sleep_for(350ms);
  EXPECT_EQ(*observer.Read(map::kLedCurrents + 5), 0);
  const uint16_t status = *observer.Read(map::kStatus);
  EXPECT_TRUE(status & map::kStatusWatchdogTripped);
  EXPECT_FALSE(status & map::kStatusEnabled);
  EXPECT_EQ(*observer.Read(map::kWatchdogMs), 0);  // disarmed once tripped

  // A watchdog shorter than a request and its retry could trip while loom is alive: refused.
  BackendRegistry registry;
  RegisterModbusBackends(registry);
  auto doc = ConfigDocument::LoadString("schema_version: 1\ndevice: " + DeviceYaml("leds", sim.endpoint, ", watchdog_ms: 1000"),
                                        "test.yaml", 1);
  ASSERT_TRUE(doc.ok());
  const Result<std::unique_ptr<LedArray>> short_watchdog =
      registry.Create<LedArray>({"leds", "modbus", doc->root().Child("device")});
  ASSERT_FALSE(short_watchdog.ok());
  EXPECT_NE(short_watchdog.status().ToString().find("device.watchdog_ms"), std::string::npos)
      << short_watchdog.status().ToString();
}

TEST(ModbusLinearLightTest, MovesWithinItsTravelAndSwitchesTheStrip) {
  Simulator sim = StartSimulator("linear-light", "tcp:127.0.0.1:0", {"--travel-mm", "300", "--max-speed", "500"});
  auto light = MakeDevice<LinearLight>(DeviceYaml("strip", sim.endpoint));
  Bringup(*light, LinearLightSettings{.speed_mm_s = 500, .move_timeout_ms = 5000});
  EXPECT_EQ(light->travel_mm(), 300.0);
  ASSERT_TRUE(light->MoveTo(123.456).ok());
  ASSERT_TRUE(light->SetStrip(true, 0.75).ok());
  const Result<LinearLightReadback> read = light->Read();
  ASSERT_TRUE(read.ok());
  EXPECT_NEAR(read->position_mm, 123.456, 1e-3);
  EXPECT_TRUE(read->on);
  EXPECT_NEAR(read->intensity, 0.75, 1e-3);
  EXPECT_EQ(light->MoveTo(301).code(), StatusCode::kOutOfRange);
  ASSERT_TRUE(light->MakeSafe().ok());
  EXPECT_FALSE(light->Read()->on);
}

// A disabled controller lights nothing, whatever its strip register holds: the read-back says
// off (a frame's metadata must not say lit); the next SetStrip enables it again, lit.
TEST(ModbusLinearLightTest, ADisabledControllersStripReadsBackOffAndTheNextSetStripLightsIt) {
  Simulator sim = StartSimulator("linear-light");
  auto light = MakeDevice<LinearLight>(DeviceYaml("strip", sim.endpoint));
  Bringup(*light, LinearLightSettings{.speed_mm_s = 100, .move_timeout_ms = 5000});
  ASSERT_TRUE(light->SetStrip(true, 0.5).ok());
  ModbusLink observer("test observer", *ParseModbusEndpoint(sim.endpoint), 500ms);
  ASSERT_TRUE(observer.Connect().ok());
  ASSERT_TRUE(observer.Write(map::kCommand, map::kCommandDisable).ok());
  ASSERT_TRUE(observer.Write(map::kLinearStripOn, 1).ok());  // the register says on
  const Result<LinearLightReadback> off = light->Read();
  ASSERT_TRUE(off.ok()) << off.status().ToString();
  EXPECT_FALSE(off->on);
  ASSERT_TRUE(light->SetStrip(true, 0.5).ok());
  EXPECT_TRUE(light->Read()->on);
  EXPECT_NE(*observer.Read(map::kStatus) & map::kStatusEnabled, 0);
}

TEST(ModbusRtuTest, TurntableAndLedsOverAPty) {
  Simulator turntable_sim = StartSimulator("turntable", "rtu");
  Simulator led_sim = StartSimulator("leds", "rtu");
  auto turntable = MakeDevice<Turntable>(DeviceYaml("tt", turntable_sim.endpoint + "?baud=115200&unit=1"));
  Bringup(*turntable, TurntableSettings{.speed_deg_s = 60, .move_timeout_ms = 5000});
  ASSERT_TRUE(turntable->MoveTo(12.5).ok());
  EXPECT_NEAR(*turntable->Angle(), 12.5, 1e-3);
  auto leds = MakeDevice<LedArray>(DeviceYaml("leds", led_sim.endpoint));
  Bringup(*leds, LedArraySettings{.current_limit_ma = 300});
  const scan::LedDrive drive[] = {{28, 300}};
  ASSERT_TRUE(leds->Drive(drive).ok());
  EXPECT_EQ(leds->Read()->current_ma[28], 300);
}

TEST(ModbusRtuTest, FrozenRtuControllerTimesOutThenRecovers) {
  Simulator sim = StartSimulator("turntable", "rtu");
  auto turntable = MakeDevice<Turntable>(DeviceYaml("tt", sim.endpoint, ", response_timeout_ms: 200"));
  Bringup(*turntable, TurntableSettings{.speed_deg_s = 60, .move_timeout_ms = 2000});
  sim.process.Signal(SIGSTOP);
  EXPECT_EQ(turntable->Angle().status().code(), StatusCode::kTimeout);
  sim.process.Signal(SIGCONT);
  for (int i = 0; i < 3; ++i) {
    const Result<double> angle = turntable->Angle();
    ASSERT_TRUE(angle.ok()) << angle.status().ToString();
  }
}

TEST(ModbusEndpointTest, ParsesAndRejects) {
  const Result<ModbusEndpoint> tcp = ParseModbusEndpoint("tcp://10.0.0.5:1502?unit=3");
  ASSERT_TRUE(tcp.ok());
  EXPECT_EQ(tcp->host, "10.0.0.5");
  EXPECT_EQ(tcp->port, 1502);
  EXPECT_EQ(tcp->unit, 3);
  const Result<ModbusEndpoint> rtu = ParseModbusEndpoint("rtu:///dev/ttyUSB0?baud=9600&parity=E");
  ASSERT_TRUE(rtu.ok());
  EXPECT_EQ(rtu->device, "/dev/ttyUSB0");
  EXPECT_EQ(rtu->baud, 9600);
  EXPECT_EQ(rtu->parity, 'E');
  for (const char* bad : {"udp://x:1", "tcp://host", "tcp://h:99999", "rtu://ttyUSB0", "tcp://h:1?baud=fast"}) {
    const Result<ModbusEndpoint> parsed = ParseModbusEndpoint(bad);
    EXPECT_FALSE(parsed.ok()) << bad;
    EXPECT_NE(parsed.status().ToString().find(bad), std::string::npos) << parsed.status().ToString();
  }
}

}  // namespace
}  // namespace loom::hal
