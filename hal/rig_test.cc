// The Rig against real peers: built from a rig YAML, brought up, and put in its safe state on
// every exit path.
#include "hal/rig.h"
#include "core/testing/build_tree.h"

#include <gtest/gtest.h>

#include <fstream>

#include "core/testing/subprocess.h"
#include "hal/modbus/modbus_backends.h"
#include "hal/modbus/modbus_link.h"
#include "hal/modbus/register_map.h"

namespace loom::hal {
namespace {

namespace map = modbus_map;
using loom::testing::Subprocess;
using namespace std::chrono_literals;

class RigTest : public ::testing::Test {
 protected:
  void SetUp() override {
    RegisterModbusBackends(registry_);
    for (const char* device : {"leds", "turntable", "linear-light"}) {
      Result<Subprocess> sim = Subprocess::Start({loom::testing::ModbusSimBinary(), "--device", device, "--tcp", "127.0.0.1:0"});
      ASSERT_TRUE(sim.ok());
      Result<std::string> line = sim->ReadLine(5s);
      ASSERT_TRUE(line.ok());
      endpoints_.push_back("tcp://" + line->substr(14));
      sims_.push_back(std::move(*sim));
    }
    // One directory per test: ctest runs them as parallel processes, which wrote each other's rig.yaml.
    dir_ = std::filesystem::path(::testing::TempDir()) /
           ("rig_test_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    std::filesystem::create_directories(dir_);
  }

  std::filesystem::path WriteRig(const std::string& extra_device_keys = "") {
    const std::filesystem::path path = dir_ / "rig.yaml";
    std::ofstream(path) << "schema_version: 1\nname: peer-test\ndevices:\n"
                        << "  leds: {name: leds, backend: modbus, endpoint: \"" << endpoints_[0]
                        << "\", settings: {current_limit_ma: 400}" << extra_device_keys << "}\n"
                        << "  turntable: {name: turntable, backend: modbus, endpoint: \"" << endpoints_[1]
                        << "\", settings: {speed_deg_s: 60, move_timeout_ms: 5000}}\n"
                        << "  linear_light: {name: linear_light, backend: modbus, endpoint: \"" << endpoints_[2] << "\"}\n";
    return path;
  }

  std::vector<uint16_t> LedCurrents() {
    ModbusLink probe("probe", *ParseModbusEndpoint(endpoints_[0]), 500ms);
    EXPECT_TRUE(probe.Connect().ok());
    return *probe.Read(map::kLedCurrents, 29);
  }

  BackendRegistry registry_;
  std::vector<Subprocess> sims_;
  std::vector<std::string> endpoints_;
  std::filesystem::path dir_;
};

TEST_F(RigTest, LoadsBringsUpAndReadsState) {
  Result<std::unique_ptr<Rig>> rig = Rig::Load(WriteRig(), registry_);
  ASSERT_TRUE(rig.ok()) << rig.status().ToString();
  Rig& r = **rig;
  EXPECT_EQ(r.name(), "peer-test");
  EXPECT_EQ(r.devices().size(), 3u);
  ASSERT_TRUE(r.OpenAndConfigure().ok());
  ASSERT_TRUE(r.StartAll().ok());
  EXPECT_EQ(r.leds()->settings().current_limit_ma, 400);
  const scan::LedDrive drive[] = {{5, 200}};
  ASSERT_TRUE(r.leds()->Drive(drive).ok());
  ASSERT_TRUE(r.turntable()->MoveTo(30).ok());
  ASSERT_TRUE(r.linear_light()->MoveTo(100).ok());
  const Result<scan::RigState> state = r.ReadState();
  ASSERT_TRUE(state.ok());
  EXPECT_EQ(state->leds_on, (std::vector<scan::LedDrive>{{5, 200}}));
  EXPECT_NEAR(state->turntable_deg, 30, 1e-3);
  EXPECT_NEAR(state->linear_light_mm, 100, 1e-3);
  ASSERT_TRUE(r.CloseAll().ok());
}

TEST_F(RigTest, GuardMakesTheRigSafeOnReturnAndOnException) {
  Result<std::unique_ptr<Rig>> rig = Rig::Load(WriteRig(), registry_);
  ASSERT_TRUE(rig.ok()) << rig.status().ToString();
  const scan::LedDrive drive[] = {{1, 100}, {2, 100}};
  {
    SafeStateGuard guard(**rig);
    ASSERT_TRUE((*rig)->OpenAndConfigure().ok());
    ASSERT_TRUE((*rig)->StartAll().ok());
    ASSERT_TRUE((*rig)->leds()->Drive(drive).ok());
    EXPECT_EQ(LedCurrents()[1], 100);
  }
  EXPECT_EQ(LedCurrents()[1], 0);
  try {
    SafeStateGuard guard(**rig);
    ASSERT_TRUE((*rig)->leds()->Drive(drive).ok());
    throw std::runtime_error("a failure mid-scan");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(LedCurrents()[2], 0);
}

TEST_F(RigTest, ErrorsNameTheKeyOrTheDevice) {
  const Result<std::unique_ptr<Rig>> typo = Rig::Load(WriteRig(", curent_limit: 3"), registry_);
  ASSERT_FALSE(typo.ok());
  EXPECT_NE(typo.status().ToString().find("key 'devices.leds.curent_limit'"), std::string::npos) << typo.status().ToString();

  const std::filesystem::path path = dir_ / "bad_backend.yaml";
  std::ofstream(path)
      << "schema_version: 1\nname: x\ndevices:\n  turntable: {name: tt, backend: modbuss, endpoint: \"tcp://127.0.0.1:1\"}\n";
  const Result<std::unique_ptr<Rig>> backend = Rig::Load(path, registry_);
  ASSERT_FALSE(backend.ok());
  EXPECT_NE(backend.status().ToString().find("key 'devices.turntable.backend'"), std::string::npos)
      << backend.status().ToString();
  EXPECT_NE(backend.status().ToString().find("no backend 'modbuss' (known: modbus)"), std::string::npos);

  std::ofstream(path)
      << "schema_version: 1\nname: x\ndevices:\n  turntable: {name: tt, backend: modbus, endpoint: \"tcp://127.0.0.1\"}\n";
  const Result<std::unique_ptr<Rig>> endpoint = Rig::Load(path, registry_);
  ASSERT_FALSE(endpoint.ok());
  EXPECT_NE(endpoint.status().ToString().find("devices.turntable.endpoint"), std::string::npos) << endpoint.status().ToString();

  // A controller that is not there: Open() fails naming the device, nothing hangs.
  std::ofstream(path)
      << "schema_version: 1\nname: x\ndevices:\n  turntable: {name: tt, backend: modbus, endpoint: \"tcp://127.0.0.1:1\"}\n";
  Result<std::unique_ptr<Rig>> absent = Rig::Load(path, registry_);
  ASSERT_TRUE(absent.ok());
  const Status opened = (*absent)->OpenAndConfigure();
  EXPECT_EQ(opened.code(), StatusCode::kUnavailable);
  EXPECT_NE(opened.ToString().find("turntable 'tt'"), std::string::npos) << opened.ToString();
}

// Settle and warm-up times come from each device's mapping, checked; a rig of real devices
// waits wall time.
TEST_F(RigTest, SettleTimesComeFromTheYamlAndARealRigWaitsWallTime) {
  const Result<std::unique_ptr<Rig>> rig = Rig::Load(WriteRig(", settle_ms: 30, warm_up_ms: 1500"), registry_);
  ASSERT_TRUE(rig.ok()) << rig.status().ToString();
  const DeviceTiming leds = (*rig)->Timing(*(*rig)->leds());
  EXPECT_DOUBLE_EQ(leds.settle_s, 0.03);
  EXPECT_DOUBLE_EQ(leds.warm_up_s, 1.5);
  EXPECT_DOUBLE_EQ((*rig)->Timing(*(*rig)->turntable()).settle_s, 0);  // none given
  EXPECT_NE(dynamic_cast<SteadyClock*>(&(*rig)->clock()), nullptr);

  for (const char* bad : {", settle_ms: -5", ", settle_ms: .nan", ", warm_up_ms: 1e9"}) {
    const Result<std::unique_ptr<Rig>> refused = Rig::Load(WriteRig(bad), registry_);
    ASSERT_FALSE(refused.ok()) << bad;
    EXPECT_NE(refused.status().ToString().find("devices.leds."), std::string::npos) << refused.status().ToString();
    EXPECT_NE(refused.status().ToString().find("_ms"), std::string::npos) << refused.status().ToString();
  }
}

}  // namespace
}  // namespace loom::hal
