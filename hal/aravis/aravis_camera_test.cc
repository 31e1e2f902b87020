// The aravis backend against Aravis's own fake cameras: (a) the in-process Fake interface with
// test-supplied frame content, (b) a GigE Vision fake camera in this process on 127.0.0.1 (real
// GVCP/GVSP over loopback), including a camera that disappears mid-acquisition.
// Cameras are opened by address or by the Fake interface's id: no discovery broadcast here
// (the GigEVision interface is disabled in (a); (b) opens by IP address, which is unicast).
#include <arv.h>
#include <gtest/gtest.h>

#include "hal/aravis/aravis_backend.h"
#include "hal/aravis/internal/aravis_camera.h"

namespace loom::hal {
namespace {

// Frame content that depends on position and exposure, so a test can check both.
uint16_t ExpectedPixel(int x, int y, uint32_t exposure_us) {
  return static_cast<uint16_t>((x * 7 + y * 13 + exposure_us / 100) & 0xFFF);
}

void FillTestPattern(ArvBuffer* buffer, void*, guint32 exposure_us, guint32, ArvPixelFormat format) {
  const int width = arv_buffer_get_image_width(buffer);
  const int height = arv_buffer_get_image_height(buffer);
  size_t size = 0;
  void* data = const_cast<void*>(arv_buffer_get_data(buffer, &size));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const uint16_t value = ExpectedPixel(x, y, exposure_us);
      if (format == ARV_PIXEL_FORMAT_MONO_8) {
        static_cast<uint8_t*>(data)[y * width + x] = static_cast<uint8_t>(value & 0xFF);
      } else {
        static_cast<uint16_t*>(data)[y * width + x] = value;
      }
    }
  }
}

CameraSettings SmallMono16(double exposure_us) {
  CameraSettings settings;
  settings.pixel_format = scan::PixelFormat::kMono16;
  settings.roi = {0, 0, 64, 48};
  settings.exposure_us = exposure_us;
  settings.trigger = TriggerMode::kSoftware;
  // Generous: the fake, Aravis' stream thread and the rest of the test suite share two cores in
  // CI, where one frame once took longer than 2 s. A frame that never comes still fails.
  settings.frame_timeout_ms = 10000;
  return settings;
}

// What the stream saw, for a failed Snap's message: frames completed, failed and missed.
std::string StreamReport(const AravisCamera& camera) {
  const AravisCamera::StreamStatistics statistics = camera.stream_statistics();
  return " (stream: " + std::to_string(statistics.completed) + " completed, " + std::to_string(statistics.failures) +
         " failed, " + std::to_string(statistics.underruns) + " underruns)";
}

void ExpectTestPattern(const scan::RawFrame& frame, uint32_t exposure_us) {
  ASSERT_EQ(frame.width, 64);
  ASSERT_EQ(frame.height, 48);
  for (int y = 0; y < frame.height; y += 7) {
    for (int x = 0; x < frame.width; x += 5) {
      ASSERT_EQ(frame.at(y, x), ExpectedPixel(x, y, exposure_us)) << x << "," << y;
    }
  }
}

class FakeInterfaceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    arv_enable_interface("Fake");
    arv_disable_interface("GigEVision");
    arv_disable_interface("USB3Vision");
  }
};

TEST_F(FakeInterfaceTest, CapturesTestSuppliedFramesWithMetadata) {
  AravisCamera camera("cam0", {.address = "Fake_1"});
  ASSERT_TRUE(camera.Open().ok());
  ArvFakeCamera* fake = arv_fake_device_get_fake_camera(ARV_FAKE_DEVICE(arv_camera_get_device(camera.native_camera())));
  arv_fake_camera_set_fill_pattern(fake, FillTestPattern, nullptr);
  arv_fake_camera_set_trigger_frequency(fake, 1000.0);  // its software trigger is polled

  EXPECT_EQ(camera.identity().vendor, "Aravis");
  EXPECT_FALSE(camera.identity().serial.empty());
  const Result<ConfigureReport> report = camera.Configure(SmallMono16(5000));
  ASSERT_TRUE(report.ok()) << report.status().ToString();
  EXPECT_NE(report->outcome, Negotiation::kInvalid) << report->ToString();
  ASSERT_TRUE(camera.Start().ok());
  for (int i = 0; i < 5; ++i) {
    const Result<scan::RawFrame> frame = camera.Snap();
    ASSERT_TRUE(frame.ok()) << frame.status().ToString();
    ExpectTestPattern(*frame, 5000);
    EXPECT_EQ(frame->metadata.camera, "cam0");
    EXPECT_EQ(frame->metadata.exposure_us, 5000);
    EXPECT_EQ(frame->metadata.pixel_format, scan::PixelFormat::kMono16);
    EXPECT_GT(frame->metadata.host_timestamp_ns, 0);
  }
  // Reconfiguring needs the camera stopped; the new exposure shows in the content.
  EXPECT_EQ(camera.Configure(SmallMono16(9000)).status().code(), StatusCode::kFailedPrecondition);
  ASSERT_TRUE(camera.Stop().ok());
  ASSERT_TRUE(camera.Configure(SmallMono16(9000)).ok());
  ASSERT_TRUE(camera.Start().ok());
  const Result<scan::RawFrame> frame = camera.Snap();
  ASSERT_TRUE(frame.ok()) << frame.status().ToString();
  ExpectTestPattern(*frame, 9000);
  ASSERT_TRUE(camera.Close().ok());
}

// Frame content of the pixel's place on the sensor: the buffer's region says where it lies.
void FillSensorPattern(ArvBuffer* buffer, void*, guint32 exposure_us, guint32, ArvPixelFormat) {
  gint x0 = 0, y0 = 0, width = 0, height = 0;
  arv_buffer_get_image_region(buffer, &x0, &y0, &width, &height);
  size_t size = 0;
  auto* data = static_cast<uint16_t*>(const_cast<void*>(arv_buffer_get_data(buffer, &size)));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) data[y * width + x] = ExpectedPixel(x0 + x, y0 + y, exposure_us);
  }
}

// A scan of a crop reads a window of the sensor: GenICam's OffsetX/OffsetY/Width/Height, as the
// camera applied them, in every frame's metadata.
TEST_F(FakeInterfaceTest, ARegionOfInterestReadsThatWindowOfTheSensor) {
  AravisCamera camera("cam0", {.address = "Fake_1"});
  ASSERT_TRUE(camera.Open().ok());
  ArvFakeCamera* fake = arv_fake_device_get_fake_camera(ARV_FAKE_DEVICE(arv_camera_get_device(camera.native_camera())));
  arv_fake_camera_set_fill_pattern(fake, FillSensorPattern, nullptr);
  CameraSettings settings = SmallMono16(4000);
  settings.roi = {128, 64, 64, 48};
  const Result<ConfigureReport> report = camera.Configure(settings);
  ASSERT_TRUE(report.ok()) << report.status().ToString();
  EXPECT_EQ(report->outcome, Negotiation::kValid) << report->ToString();
  ASSERT_TRUE(camera.Start().ok());
  const Result<scan::RawFrame> frame = camera.Snap();
  ASSERT_TRUE(frame.ok()) << frame.status().ToString();
  EXPECT_EQ(frame->metadata.roi, (scan::Roi{128, 64, 64, 48}));
  ASSERT_EQ(frame->width, 64);
  ASSERT_EQ(frame->height, 48);
  for (int y = 0; y < frame->height; y += 5) {
    for (int x = 0; x < frame->width; x += 3) ASSERT_EQ(frame->at(y, x), ExpectedPixel(128 + x, 64 + y, 4000)) << x << "," << y;
  }
  ASSERT_TRUE(camera.Close().ok());
}

TEST_F(FakeInterfaceTest, NegotiatesMono12AndOutOfRangeValues) {
  AravisCamera camera("cam0", {.address = "Fake_1"});
  ASSERT_TRUE(camera.Open().ok());
  CameraSettings settings = SmallMono16(1e12);         // beyond the fake's maximum exposure
  settings.pixel_format = scan::PixelFormat::kMono12;  // the fake offers Mono8 and Mono16 only
  settings.roi = {2000, 0, 100, 100};                  // runs off the 2048-wide sensor
  const Result<ConfigureReport> report = camera.Configure(settings);
  ASSERT_TRUE(report.ok()) << report.status().ToString();
  EXPECT_EQ(report->outcome, Negotiation::kAdjusted) << report->ToString();
  EXPECT_EQ(camera.settings().pixel_format, scan::PixelFormat::kMono16);
  EXPECT_EQ(camera.settings().roi.width, 48);
  EXPECT_LE(camera.settings().exposure_us, camera.capabilities().exposure_max_us);
  settings.roi = {5000, 0, 10, 10};
  const Result<ConfigureReport> invalid = camera.Configure(settings);
  ASSERT_TRUE(invalid.ok());
  EXPECT_EQ(invalid->outcome, Negotiation::kInvalid);
  EXPECT_NE(invalid->ToStatus(camera.description()).ToString().find("camera 'cam0'"), std::string::npos);
}

TEST_F(FakeInterfaceTest, HardwareTriggerTakesFramesFromTheLine) {
  AravisCamera camera("cam4", {.address = "Fake_1"});
  ASSERT_TRUE(camera.Open().ok());
  ArvFakeCamera* fake = arv_fake_device_get_fake_camera(ARV_FAKE_DEVICE(arv_camera_get_device(camera.native_camera())));
  arv_fake_camera_set_fill_pattern(fake, FillTestPattern, nullptr);
  arv_fake_camera_set_trigger_frequency(fake, 50.0);  // the fake pulses its Line0 itself
  CameraSettings settings = SmallMono16(1000);
  settings.trigger = TriggerMode::kHardware;
  ASSERT_TRUE(camera.Configure(settings).ok());
  ASSERT_TRUE(camera.Start().ok());
  EXPECT_EQ(camera.TriggerSoftware().code(), StatusCode::kFailedPrecondition);
  for (int i = 0; i < 3; ++i) {
    const Result<scan::RawFrame> frame = camera.WaitFrame();
    ASSERT_TRUE(frame.ok()) << frame.status().ToString();
    ExpectTestPattern(*frame, 1000);
  }
}

TEST_F(FakeInterfaceTest, WrongStateAndMissingCameraAreErrors) {
  AravisCamera camera("cam9", {.address = "Fake_9"});
  EXPECT_EQ(camera.Snap().status().code(), StatusCode::kFailedPrecondition);
  const Status opened = camera.Open();
  EXPECT_EQ(opened.code(), StatusCode::kUnavailable);
  EXPECT_NE(opened.ToString().find("camera 'cam9' (aravis Fake_9)"), std::string::npos) << opened.ToString();
}

class GigEFakeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    arv_enable_interface("GigEVision");
    arv_disable_interface("Fake");
    arv_disable_interface("USB3Vision");
    StartFake();
  }
  void TearDown() override { g_clear_object(&fake_); }

  void StartFake() {
    fake_ = arv_gv_fake_camera_new("127.0.0.1", "LOOMGV01");
    ASSERT_TRUE(arv_gv_fake_camera_is_running(fake_));
    arv_fake_camera_set_fill_pattern(arv_gv_fake_camera_get_fake_camera(fake_), FillTestPattern, nullptr);
    arv_fake_camera_set_trigger_frequency(arv_gv_fake_camera_get_fake_camera(fake_), 1000.0);
  }

  ArvGvFakeCamera* fake_ = nullptr;
};

TEST_F(GigEFakeTest, CapturesOverLoopbackGigEVision) {
  AravisCamera camera("cam1", {.address = "127.0.0.1"});
  ASSERT_TRUE(camera.Open().ok());
  EXPECT_EQ(camera.identity().serial, "LOOMGV01");
  ASSERT_TRUE(camera.Configure(SmallMono16(2000)).ok());
  ASSERT_TRUE(camera.Start().ok());
  uint64_t last_id = 0;
  for (int i = 0; i < 10; ++i) {
    const Result<scan::RawFrame> frame = camera.Snap();
    ASSERT_TRUE(frame.ok()) << frame.status().ToString() << StreamReport(camera);
    ExpectTestPattern(*frame, 2000);
    EXPECT_EQ(frame->metadata.camera_serial, "LOOMGV01");
    if (i > 0) {
      EXPECT_GT(frame->metadata.frame_id, last_id);
    }
    last_id = frame->metadata.frame_id;
  }
  ASSERT_TRUE(camera.Close().ok());
}

// The stream's packet size and inter-packet delay as the rig YAML gives them, read back from the
// camera's GevSCPSPacketSize and GevSCPD; frames arrive whole in the smaller packets. 0 asks
// Aravis to negotiate the size.
TEST_F(GigEFakeTest, PacketSizeAndDelayAreSetOrNegotiated) {
  AravisCamera camera("cam1", {.address = "127.0.0.1"});
  ASSERT_TRUE(camera.Open().ok());
  CameraSettings settings = SmallMono16(2000);
  settings.packet_size_bytes = 1000;
  settings.packet_delay_ns = 20000;
  const Result<ConfigureReport> report = camera.Configure(settings);
  ASSERT_TRUE(report.ok()) << report.status().ToString();
  EXPECT_EQ(report->outcome, Negotiation::kValid) << report->ToString();
  EXPECT_EQ(arv_camera_gv_get_packet_size(camera.native_camera(), nullptr), 1000u);
  EXPECT_EQ(arv_camera_gv_get_packet_delay(camera.native_camera(), nullptr), 20000);
  EXPECT_EQ(camera.settings().packet_delay_ns, 20000);
  ASSERT_TRUE(camera.Start().ok());
  const Result<scan::RawFrame> frame = camera.Snap();
  ASSERT_TRUE(frame.ok()) << frame.status().ToString() << StreamReport(camera);
  ExpectTestPattern(*frame, 2000);
  ASSERT_TRUE(camera.Stop().ok());

  settings.packet_size_bytes = 100000;  // beyond the camera's bounds: its largest
  const Result<ConfigureReport> clamped = camera.Configure(settings);
  ASSERT_TRUE(clamped.ok()) << clamped.status().ToString();
  EXPECT_EQ(clamped->outcome, Negotiation::kAdjusted) << clamped->ToString();
  EXPECT_LT(camera.settings().packet_size_bytes, 100000);
  settings.packet_size_bytes = 0;  // negotiated
  ASSERT_TRUE(camera.Configure(settings).ok());
  EXPECT_GT(arv_camera_gv_get_packet_size(camera.native_camera(), nullptr), 0u);
  settings.packet_delay_ns = -1;
  const Result<ConfigureReport> refused = camera.Configure(settings);
  ASSERT_TRUE(refused.ok());
  EXPECT_EQ(refused->outcome, Negotiation::kInvalid);
  ASSERT_TRUE(camera.Close().ok());
}

TEST_F(GigEFakeTest, CameraThatDropsOutIsAnErrorNamingItNotAHang) {
  AravisCamera camera("cam2", {.address = "127.0.0.1", .reconnect_attempts = 1});
  ASSERT_TRUE(camera.Open().ok());
  CameraSettings settings = SmallMono16(2000);
  settings.frame_timeout_ms = 500;
  ASSERT_TRUE(camera.Configure(settings).ok());
  ASSERT_TRUE(camera.Start().ok());
  ASSERT_TRUE(camera.Snap().ok());
  g_clear_object(&fake_);  // the camera is gone
  const Result<scan::RawFrame> lost = camera.Snap();
  ASSERT_FALSE(lost.ok());
  EXPECT_EQ(lost.status().code(), StatusCode::kUnavailable) << lost.status().ToString();
  EXPECT_EQ(lost.status().subject(), "camera 'cam2' (aravis 127.0.0.1)");
}

TEST_F(GigEFakeTest, CameraThatComesBackIsReconnected) {
  AravisCamera camera("cam3", {.address = "127.0.0.1", .reconnect_attempts = 3});
  ASSERT_TRUE(camera.Open().ok());
  CameraSettings settings = SmallMono16(2000);
  settings.frame_timeout_ms = 500;
  ASSERT_TRUE(camera.Configure(settings).ok());
  ASSERT_TRUE(camera.Start().ok());
  ASSERT_TRUE(camera.Snap().ok());
  g_clear_object(&fake_);
  StartFake();  // power-cycled: a new camera at the same address
  Result<scan::RawFrame> frame = camera.Snap();
  if (!frame.ok()) {
    // The loss was noticed: reported, reconnected; the next capture works.
    EXPECT_EQ(frame.status().code(), StatusCode::kUnavailable) << frame.status().ToString();
    EXPECT_NE(frame.status().message().find("reconnected"), std::string::npos) << frame.status().ToString();
    frame = camera.Snap();
  }
  ASSERT_TRUE(frame.ok()) << frame.status().ToString();
  ExpectTestPattern(*frame, 2000);
}

TEST(AravisCameraOptionsTest, AnEmptyAddressOrNegativeReconnectsAreRefusedNamingTheField) {
  const Status status = AravisCameraOptions{.address = "", .reconnect_attempts = -1}.Check();
  EXPECT_NE(status.ToString().find("address"), std::string::npos) << status.ToString();
  EXPECT_NE(status.ToString().find("reconnect_attempts"), std::string::npos) << status.ToString();
  EXPECT_TRUE((AravisCameraOptions{.address = "127.0.0.1", .reconnect_attempts = 0}.Check().ok()));
}

}  // namespace
}  // namespace loom::hal
