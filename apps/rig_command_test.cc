// `loom rig` against real peers: loom-modbus-sim controllers on 127.0.0.1, an
// arv-fake-gv-camera-0.8 process on 127.0.0.1 (opened by address: unicast only), and the
// recording projector; and `loom scan` killed against the same controllers.
#include <gtest/gtest.h>
#include <modbus.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <thread>

#include "core/exr_io.h"
#include "core/testing/build_tree.h"
#include "core/testing/subprocess.h"
#include "hal/modbus/register_map.h"

namespace {

namespace fs = std::filesystem;
using loom::testing::Subprocess;
using namespace std::chrono_literals;

using LoomRun = loom::testing::CommandResult;

LoomRun RunLoom(const std::string& arguments) { return loom::testing::RunCommand(loom::testing::LoomBinary() + " " + arguments); }

bool Contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::string Slurp(const fs::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A Modbus TCP client of one controller (endpoint tcp://HOST:PORT), beside whatever loom process
// drives it: the peer serves several connections. Reads do not feed the watchdog.
class ControllerClient {
 public:
  explicit ControllerClient(const std::string& endpoint) {
    const std::string address = endpoint.substr(std::string("tcp://").size());
    const size_t colon = address.rfind(':');
    context_ = modbus_new_tcp(address.substr(0, colon).c_str(), std::stoi(address.substr(colon + 1)));
    connected_ = context_ != nullptr && modbus_connect(context_) == 0;
  }
  ~ControllerClient() {
    if (context_ == nullptr) return;
    modbus_close(context_);
    modbus_free(context_);
  }
  ControllerClient(const ControllerClient&) = delete;
  ControllerClient& operator=(const ControllerClient&) = delete;

  bool connected() const { return connected_; }
  // The holding registers [address, address + count); empty if the read failed.
  std::vector<uint16_t> Read(int address, int count) {
    std::vector<uint16_t> values(count);
    if (modbus_read_registers(context_, address, count, values.data()) != count) return {};
    return values;
  }
  uint16_t Status() {
    const auto status = Read(loom::hal::modbus_map::kStatus, 1);
    return status.empty() ? 0xFFFF : status[0];
  }

 private:
  modbus_t* context_ = nullptr;
  bool connected_ = false;
};

int LitLeds(ControllerClient& leds, int count) {
  const auto currents = leds.Read(loom::hal::modbus_map::kLedCurrents, count);
  return static_cast<int>(std::count_if(currents.begin(), currents.end(), [](uint16_t ma) { return ma > 0; }));
}

class RigCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / "rig_command_test";
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    for (const char* device : {"leds", "turntable", "linear-light"}) {
      auto sim = Subprocess::Start({loom::testing::ModbusSimBinary(), "--device", device, "--tcp", "127.0.0.1:0"});
      ASSERT_TRUE(sim.ok());
      auto line = sim->ReadLine(5s);
      ASSERT_TRUE(line.ok());
      endpoints_.push_back("tcp://" + line->substr(14));
      peers_.push_back(std::move(*sim));
    }
    auto camera = Subprocess::Start({"arv-fake-gv-camera-0.8", "-i", "127.0.0.1", "-s", "LOOMCLI0"});
    ASSERT_TRUE(camera.ok());
    peers_.push_back(std::move(*camera));
    rig_ = WriteRig(endpoints_[0]);
    // The fake camera needs a moment before it answers.
    for (int i = 0; i < 50 && RunLoom("rig status --rig " + rig_.string()).exit_code != 0; ++i) {
      std::this_thread::sleep_for(100ms);
    }
  }

  fs::path WriteRig(const std::string& led_endpoint, const std::string& extra = "") {
    const fs::path path = dir_ / ("rig" + std::to_string(rigs_++) + ".yaml");
    std::ofstream(path) << "schema_version: 1\nname: cli-peers\ndevices:\n"
                        << "  cameras:\n    - {name: cam0, backend: aravis, address: 127.0.0.1,\n"
                        << "       settings: {pixel_format: Mono16, roi: [0, 0, 64, 48], exposure_us: 3000}}\n"
                        << "  leds: {name: leds, backend: modbus, endpoint: \"" << led_endpoint << "\"" << extra << "}\n"
                        << "  turntable: {name: turntable, backend: modbus, endpoint: \"" << endpoints_[1]
                        << "\", settings: {speed_deg_s: 60}}\n"
                        << "  linear_light: {name: strip, backend: modbus, endpoint: \"" << endpoints_[2] << "\"}\n"
                        << "  projector: {name: projector, backend: recording, native_width: 64, native_height: 32}\n";
    return path;
  }

  fs::path dir_;
  fs::path rig_;
  int rigs_ = 0;
  std::vector<std::string> endpoints_;
  std::vector<Subprocess> peers_;
};

TEST_F(RigCommandTest, ListAndStatus) {
  const LoomRun list = RunLoom("rig list --rig " + rig_.string());
  EXPECT_EQ(list.exit_code, 0) << list.output;
  EXPECT_TRUE(Contains(list.output, "rig 'cli-peers'")) << list.output;
  EXPECT_TRUE(Contains(list.output, "turntable")) << list.output;
  const LoomRun status = RunLoom("rig status --rig " + rig_.string());
  EXPECT_EQ(status.exit_code, 0) << status.output;
  EXPECT_TRUE(Contains(status.output, "serial LOOMCLI0")) << status.output;
  EXPECT_TRUE(Contains(status.output, "29 LEDs, 0 lit")) << status.output;
  EXPECT_TRUE(Contains(status.output, "at 0.000 deg")) << status.output;
}

TEST_F(RigCommandTest, MoveSnapAndLeds) {
  const LoomRun move = RunLoom("rig move --rig " + rig_.string() + " --device turntable --to 45");
  EXPECT_EQ(move.exit_code, 0) << move.output;
  EXPECT_TRUE(Contains(move.output, "turntable is at 45 deg")) << move.output;

  const fs::path exr = dir_ / "snap.exr";
  const LoomRun snap = RunLoom("rig snap --rig " + rig_.string() + " --camera cam0 --exposure-us 2000 --out " + exr.string());
  ASSERT_EQ(snap.exit_code, 0) << snap.output;
  const auto image = loom::ReadExr(exr);
  ASSERT_TRUE(image.ok()) << image.status().ToString();
  EXPECT_EQ(image->image.width(), 64);
  EXPECT_EQ(std::get<std::string>(image->attributes.at("loom.cameraSerial")), "LOOMCLI0");
  EXPECT_EQ(std::get<double>(image->attributes.at("loom.exposure_us")), 2000.0);
  EXPECT_EQ(image->attributes.count("loom.turntable_deg"), 1u);  // the rig state is recorded
  const LoomRun png = RunLoom("rig snap --rig " + rig_.string() + " --camera cam0 --out " + (dir_ / "snap.png").string());
  EXPECT_EQ(png.exit_code, 0) << png.output;
  EXPECT_TRUE(fs::file_size(dir_ / "snap.png") > 0);

  const LoomRun leds = RunLoom("rig leds --rig " + rig_.string() + " --on 3:100,7:50 --hold-s 0");
  EXPECT_EQ(leds.exit_code, 0) << leds.output;
  EXPECT_TRUE(Contains(leds.output, "2 LEDs on")) << leds.output;
  const LoomRun after = RunLoom("rig status --rig " + rig_.string());
  EXPECT_TRUE(Contains(after.output, "29 LEDs, 0 lit")) << after.output;  // the guard switched them off
}

TEST_F(RigCommandTest, CtrlCEndsPromptlyWithTheLedsOff) {
  auto loom =
      Subprocess::Start({loom::testing::LoomBinary(), "rig", "leds", "--rig", rig_.string(), "--on", "4:120", "--hold-s", "60"});
  ASSERT_TRUE(loom.ok());
  const auto line = loom->ReadLine(10s);
  ASSERT_TRUE(line.ok()) << line.status().ToString();
  EXPECT_TRUE(Contains(*line, "1 LEDs on")) << *line;
  EXPECT_TRUE(Contains(RunLoom("rig status --rig " + rig_.string()).output, "29 LEDs, 1 lit"));
  const auto sent = std::chrono::steady_clock::now();
  loom->Signal(SIGINT);
  EXPECT_EQ(loom->Wait(), 0);
  EXPECT_LT(std::chrono::steady_clock::now() - sent, 5s);  // not the 60 s hold
  EXPECT_TRUE(Contains(RunLoom("rig status --rig " + rig_.string()).output, "29 LEDs, 0 lit"));
}

// A loom killed with SIGKILL runs no safe-state guard: only the controller can switch its LEDs
// off. With watchdog_ms in the rig YAML it does so within that time; without, the LED stays lit.
TEST_F(RigCommandTest, AKilledLoomLeavesNoLedLitWhenTheControllersWatchdogIsArmed) {
  for (const bool armed : {false, true}) {
    SCOPED_TRACE(armed ? "watchdog armed" : "no watchdog");
    const fs::path rig = armed ? WriteRig(endpoints_[0], ", response_timeout_ms: 100, watchdog_ms: 300") : rig_;
    auto loom =
        Subprocess::Start({loom::testing::LoomBinary(), "rig", "leds", "--rig", rig.string(), "--on", "4:120", "--hold-s", "60"});
    ASSERT_TRUE(loom.ok());
    const auto line = loom->ReadLine(10s);
    ASSERT_TRUE(line.ok()) << line.status().ToString();
    std::this_thread::sleep_for(700ms);  // past the watchdog's time: the heartbeat keeps it lit
    loom->Signal(SIGKILL);
    EXPECT_EQ(loom->Wait(), 128 + SIGKILL);
    std::this_thread::sleep_for(600ms);
    // (loom rig status reads the LEDs, then makes the rig safe: the next round starts dark.)
    const LoomRun after = RunLoom("rig status --rig " + rig_.string());
    EXPECT_TRUE(Contains(after.output, armed ? "29 LEDs, 0 lit" : "29 LEDs, 1 lit")) << after.output;
  }
}

// The same for `loom scan`, killed while a step has an LED lit: the simulated tac7-mini with its
// LED controller, turntable and linear light on the peers (its cameras, wheels and projector
// stay simulated). Armed, every controller has gone safe within its watchdog's time — LEDs and
// strip off, no axis busy, each disabled and flagged as tripped; unarmed, the LED stays lit.
TEST_F(RigCommandTest, AScanKilledMidPlanLeavesEveryControllerSafeWhenTheirWatchdogsAreArmed) {
  namespace map = loom::hal::modbus_map;
  constexpr int kPeerLeds = 29;  // the LED peer's count; tac7-mini drives the first 12
  // Armed first: the unarmed run leaves its LED lit.
  for (const bool armed : {true, false}) {
    SCOPED_TRACE(armed ? "watchdogs armed" : "no watchdogs");
    const std::string watchdog = armed ? ", response_timeout_ms: 100, watchdog_ms: 300" : "";
    std::string yaml = Slurp(fs::path(loom::testing::SourceDir()) / "configs/rig/tac7-mini.yaml");
    const auto replace_line = [&yaml](const std::string& starting, const std::string& by) {
      const size_t at = yaml.find(starting, yaml.find("\ndevices:"));
      ASSERT_NE(at, std::string::npos) << starting;
      yaml.replace(at, yaml.find('\n', at) - at, by);
    };
    replace_line("  leds: {", "  leds: {name: leds, backend: modbus, endpoint: \"" + endpoints_[0] + "\"" + watchdog + "}");
    replace_line("  turntable: {",
                 "  turntable: {name: turntable, backend: modbus, endpoint: \"" + endpoints_[1] + "\"" + watchdog + "}");
    replace_line("  linear_light: {",
                 "  linear_light: {name: linear_light, backend: modbus, endpoint: \"" + endpoints_[2] + "\"" + watchdog + "}");
    const fs::path rig = dir_ / (armed ? "scan-rig-armed.yaml" : "scan-rig.yaml");
    std::ofstream(rig) << yaml;

    ControllerClient leds(endpoints_[0]), turntable(endpoints_[1]), strip(endpoints_[2]);
    ASSERT_TRUE(leds.connected() && turntable.connected() && strip.connected());
    auto loom = Subprocess::Start({loom::testing::LoomBinary(), "scan", "--rig", rig.string(), "--preset", "low", "--object",
                                   "white-tile", "--quiet", "--out", (dir_ / (armed ? "scan-armed" : "scan")).string()});
    ASSERT_TRUE(loom.ok());
    const auto deadline = std::chrono::steady_clock::now() + 60s;
    // (Quiet, the scan writes nothing to stdout before it ends: a line read is its end.)
    bool lit = false;
    while (!(lit = LitLeds(leds, kPeerLeds) > 0) && std::chrono::steady_clock::now() < deadline) {
      if (const auto line = loom->ReadLine(5ms); line.status().code() != loom::StatusCode::kTimeout) break;
    }
    loom->Signal(SIGKILL);
    EXPECT_EQ(loom->Wait(), 128 + SIGKILL) << "the scan ended before an LED was lit";
    ASSERT_TRUE(lit) << "no LED was lit within 60 s: nothing to leave safe";
    std::this_thread::sleep_for(600ms);

    if (!armed) {
      EXPECT_GT(LitLeds(leds, kPeerLeds), 0);  // nobody switched it off
      continue;
    }
    EXPECT_EQ(LitLeds(leds, kPeerLeds), 0);
    EXPECT_EQ(strip.Read(map::kLinearStripOn, 1), std::vector<uint16_t>{0});
    for (ControllerClient* controller : {&leds, &turntable, &strip}) {
      const uint16_t status = controller->Status();
      EXPECT_TRUE(status & map::kStatusWatchdogTripped) << status;
      EXPECT_FALSE(status & map::kStatusEnabled) << status;
      EXPECT_FALSE(status & map::kStatusBusy) << status;
    }
  }
}

TEST_F(RigCommandTest, ErrorsNameTheKeyOrTheDevice) {
  const LoomRun typo = RunLoom("rig status --rig " + WriteRig(endpoints_[0], ", setings: {}").string());
  EXPECT_EQ(typo.exit_code, 1);
  EXPECT_TRUE(Contains(typo.output, "key 'devices.leds.setings'")) << typo.output;
  EXPECT_TRUE(Contains(typo.output, "did you mean 'settings'")) << typo.output;

  const LoomRun unknown = RunLoom("rig move --rig " + rig_.string() + " --device turntabel --to 3");
  EXPECT_EQ(unknown.exit_code, 1);
  EXPECT_TRUE(Contains(unknown.output, "device 'turntabel': not in rig 'cli-peers'")) << unknown.output;

  const LoomRun down = RunLoom("rig status --rig " + WriteRig("tcp://127.0.0.1:1").string());
  EXPECT_EQ(down.exit_code, 1);
  EXPECT_TRUE(Contains(down.output, "FAILED  unavailable: LED array 'leds'")) << down.output;

  EXPECT_EQ(RunLoom("rig").exit_code, 2);
  EXPECT_EQ(RunLoom("rig move --rig x.yaml").exit_code, 2);
  const LoomRun missing = RunLoom("rig status --rig /nonexistent/rig.yaml");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_TRUE(Contains(missing.output, "not found: /nonexistent/rig.yaml")) << missing.output;
}

}  // namespace
