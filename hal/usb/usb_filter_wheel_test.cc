// The usb backend (unchanged libusb code) against a stateful filter-wheel model under umockdev.
// Runs only under `umockdev-wrapper` (CTest does that); directly it skips.
#include <gtest/gtest.h>
#include <umockdev.h>

#include <thread>

#include "hal/usb/emulated_filter_wheel.h"
#include "hal/usb/usb_backend.h"

namespace loom::hal {
namespace {

using namespace std::chrono_literals;

class UsbFilterWheelTest : public ::testing::Test {
 protected:
  void SetUp() override {
    testbed_ = umockdev_testbed_new();
    if (!umockdev_in_mock_environment()) GTEST_SKIP() << "run under umockdev-wrapper";
    RegisterUsbBackend(registry_);
  }
  void TearDown() override {
    wheels_.clear();
    g_clear_object(&testbed_);
  }

  testing::EmulatedFilterWheel& AddWheel(const std::string& serial, int slots = 10) {
    wheels_.push_back(
        std::make_unique<testing::EmulatedFilterWheel>(testbed_, static_cast<int>(wheels_.size()) + 2, serial, slots));
    return *wheels_.back();
  }

  std::unique_ptr<FilterWheel> MakeWheel(const std::string& keys) {
    auto doc = ConfigDocument::LoadString("schema_version: 1\nwheel: {name: wheel0, backend: usb" + keys + "}\n", "test.yaml", 1);
    EXPECT_TRUE(doc.ok());
    const ConfigNode node = doc->root().Child("wheel");
    DeviceConfig config{"wheel0", "usb", node};
    node.Required("name", &config.name);
    node.Required("backend", &config.backend);
    Result<std::unique_ptr<FilterWheel>> wheel = registry_.Create<FilterWheel>(config);
    EXPECT_TRUE(wheel.ok()) << wheel.status().ToString();
    EXPECT_TRUE(doc->Finish().ok()) << doc->Finish().ToString();
    return std::move(*wheel);
  }

  static void BringUp(FilterWheel& wheel, int move_timeout_ms = 2000) {
    const Status opened = wheel.Open();
    ASSERT_TRUE(opened.ok()) << opened.ToString();
    ASSERT_TRUE(wheel.Configure({.move_timeout_ms = move_timeout_ms}).ok());
    ASSERT_TRUE(wheel.Start().ok());
  }

  UMockdevTestbed* testbed_ = nullptr;
  BackendRegistry registry_;
  std::vector<std::unique_ptr<testing::EmulatedFilterWheel>> wheels_;
};

TEST_F(UsbFilterWheelTest, MovesThroughEverySlotWithBusyPolling) {
  testing::EmulatedFilterWheel& model = AddWheel("W0-0001");
  auto wheel = MakeWheel("");
  BringUp(*wheel);
  EXPECT_EQ(wheel->slot_count(), 10);
  EXPECT_EQ(wheel->identity().serial, "W0-0001");
  EXPECT_EQ(wheel->identity().model, "loom filter wheel");
  for (int slot : {3, 9, 0, 5}) {
    const Status moved = wheel->MoveTo(slot);
    ASSERT_TRUE(moved.ok()) << moved.ToString();
    EXPECT_EQ(*wheel->Position(), slot);
  }
  EXPECT_GT(model.requests(), 8);  // moves were polled, not assumed
  EXPECT_EQ(wheel->MoveTo(10).code(), StatusCode::kOutOfRange);
}

TEST_F(UsbFilterWheelTest, PicksTheWheelBySerial) {
  AddWheel("W0-0001");
  AddWheel("W3-0042");
  auto wheel = MakeWheel(", serial: W3-0042");
  BringUp(*wheel);
  EXPECT_EQ(wheel->identity().serial, "W3-0042");
  auto missing = MakeWheel(", serial: W9-9999");
  const Status opened = missing->Open();
  EXPECT_EQ(opened.code(), StatusCode::kNotFound);
  EXPECT_NE(opened.ToString().find("filter wheel 'wheel0'"), std::string::npos) << opened.ToString();
  EXPECT_NE(opened.message().find("connected: W0-0001, W3-0042"), std::string::npos) << opened.message();
}

TEST_F(UsbFilterWheelTest, JamIsReportedAndTheStalledRequestIsAClearError) {
  testing::EmulatedFilterWheel& model = AddWheel("W0-0001");
  auto wheel = MakeWheel("");
  BringUp(*wheel);
  model.JamNextMove();
  const Status jammed = wheel->MoveTo(4);
  EXPECT_EQ(jammed.code(), StatusCode::kUnavailable);
  EXPECT_NE(jammed.message().find("error 1 (jammed)"), std::string::npos) << jammed.ToString();
  // In error the wheel refuses moves with a STALL.
  const Status refused = wheel->MoveTo(2);
  EXPECT_EQ(refused.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(refused.message().find("STALL"), std::string::npos) << refused.ToString();
}

TEST_F(UsbFilterWheelTest, UnpluggedMidMoveIsAnErrorNamingTheWheel) {
  testing::EmulatedFilterWheel& model = AddWheel("W0-0001");
  auto wheel = MakeWheel("");
  BringUp(*wheel, 5000);
  std::thread unplug([&model] {
    std::this_thread::sleep_for(15ms);
    model.Unplug();
  });
  const Status moved = wheel->MoveTo(9);  // 9 slots × 5 ms: still turning when unplugged
  unplug.join();
  EXPECT_EQ(moved.code(), StatusCode::kUnavailable) << moved.ToString();
  EXPECT_EQ(moved.subject(), wheel->description());
  EXPECT_NE(moved.message().find("unplugged"), std::string::npos) << moved.ToString();
  EXPECT_TRUE(wheel->Close().ok());
}

TEST_F(UsbFilterWheelTest, NoWheelConnected) {
  auto wheel = MakeWheel("");
  const Status opened = wheel->Open();
  EXPECT_EQ(opened.code(), StatusCode::kNotFound) << opened.ToString();
}

}  // namespace
}  // namespace loom::hal
