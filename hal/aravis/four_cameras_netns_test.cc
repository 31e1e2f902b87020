// Four `arv-fake-gv-camera-0.8` processes, one per address 127.0.0.1–127.0.0.4, like the
// scanner's four GigE cameras: captured from all at once, one killed mid-acquisition, and found
// by discovery. Runs only inside the private network namespace that run_in_netns.sh creates:
// discovery broadcasts, and there it reaches nothing but this namespace's loopback.
#include <arv.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <sstream>
#include <thread>

#include "core/testing/subprocess.h"
#include "hal/aravis/aravis_backend.h"
#include "hal/aravis/internal/aravis_camera.h"

namespace loom::hal {
namespace {

using loom::testing::Subprocess;
using namespace std::chrono_literals;

constexpr int kCameras = 4;

bool InPrivateNamespace() {
  const char* flag = std::getenv("LOOM_IN_PRIVATE_NETNS");
  return flag != nullptr && std::string(flag) == "1";
}

std::string Address(int i) { return "127.0.0." + std::to_string(i + 1); }
std::string Serial(int i) { return "LOOMCAM0" + std::to_string(i); }

class FourCamerasTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!InPrivateNamespace()) GTEST_SKIP() << "needs run_in_netns.sh (discovery must not leave the machine)";
    arv_enable_interface("GigEVision");
    arv_disable_interface("Fake");
    arv_disable_interface("USB3Vision");
    for (int i = 0; i < kCameras; ++i) {
      Result<Subprocess> fake = Subprocess::Start({"arv-fake-gv-camera-0.8", "-i", Address(i), "-s", Serial(i)});
      ASSERT_TRUE(fake.ok()) << fake.status().ToString();
      fakes_.push_back(std::move(*fake));
    }
    for (int i = 0; i < kCameras; ++i) {
      cameras_.push_back(std::make_unique<AravisCamera>("cam" + std::to_string(i), AravisCameraOptions{Address(i), 1}));
      // The fake exits 0 even when it failed to bind, and needs a moment to start: retry.
      Status opened;
      for (int attempt = 0; attempt < 50; ++attempt) {
        opened = cameras_[i]->Open();
        if (opened.ok()) break;
        std::this_thread::sleep_for(100ms);
      }
      ASSERT_TRUE(opened.ok()) << opened.ToString();
      CameraSettings settings;
      settings.pixel_format = scan::PixelFormat::kMono16;
      settings.roi = {0, 0, 128, 96};
      settings.trigger = TriggerMode::kSoftware;
      settings.frame_timeout_ms = 1000;
      const Result<ConfigureReport> report = cameras_[i]->Configure(settings);
      ASSERT_TRUE(report.ok()) << report.status().ToString();
      ASSERT_TRUE(cameras_[i]->Start().ok());
    }
  }

  // The fake's own pattern is a diagonal ramp: a pixel depends on x + y only.
  static void ExpectDiagonalRamp(const scan::RawFrame& frame) {
    ASSERT_EQ(frame.width, 128);
    ASSERT_EQ(frame.height, 96);
    int nonzero = 0;
    for (int y = 0; y + 1 < frame.height; y += 5) {
      for (int x = 0; x + 1 < frame.width; x += 3) {
        ASSERT_EQ(frame.at(y, x + 1), frame.at(y + 1, x)) << x << "," << y;
        nonzero += frame.at(y, x) != 0;
      }
    }
    EXPECT_GT(nonzero, 0);
  }

  std::vector<Subprocess> fakes_;
  std::vector<std::unique_ptr<AravisCamera>> cameras_;
};

TEST_F(FourCamerasTest, CapturesFromAllFourAtOnce) {
  constexpr int kRounds = 20;
  std::vector<int> frames(kCameras, 0);
  std::vector<uint64_t> last_id(kCameras, 0);
  for (int round = 0; round < kRounds; ++round) {
    for (auto& camera : cameras_) ASSERT_TRUE(camera->TriggerSoftware().ok());
    for (int i = 0; i < kCameras; ++i) {
      const Result<scan::RawFrame> frame = cameras_[i]->WaitFrame();
      ASSERT_TRUE(frame.ok()) << frame.status().ToString();
      ExpectDiagonalRamp(*frame);
      EXPECT_EQ(frame->metadata.camera_serial, Serial(i));
      if (round > 0) {
        EXPECT_GT(frame->metadata.frame_id, last_id[i]);
      }
      last_id[i] = frame->metadata.frame_id;
      ++frames[i];
    }
  }
  EXPECT_EQ(frames, std::vector<int>(kCameras, kRounds));
}

TEST_F(FourCamerasTest, OneKilledMidAcquisitionIsNamedAndTheOthersGoOn) {
  for (auto& camera : cameras_) ASSERT_TRUE(camera->Snap().ok());
  fakes_[2].Kill();
  for (int i = 0; i < kCameras; ++i) {
    const Result<scan::RawFrame> frame = cameras_[i]->Snap();
    if (i == 2) {
      ASSERT_FALSE(frame.ok());
      EXPECT_EQ(frame.status().code(), StatusCode::kUnavailable) << frame.status().ToString();
      EXPECT_EQ(frame.status().subject(), "camera 'cam2' (aravis 127.0.0.3)");
    } else {
      ASSERT_TRUE(frame.ok()) << frame.status().ToString();
      ExpectDiagonalRamp(*frame);
    }
  }
}

TEST_F(FourCamerasTest, DiscoveryFindsAllFourAndListsEachInALine) {
  int found = 0;
  const std::vector<DiscoveredCamera> cameras = DiscoverAravisCameras();
  std::ostringstream out;
  ListDiscoveredCameras(cameras, out);
  const std::string listed = out.str();
  EXPECT_EQ(std::count(listed.begin(), listed.end(), '\n'), static_cast<long>(cameras.size())) << listed;
  for (const DiscoveredCamera& camera : cameras) {
    EXPECT_NE(listed.find(camera.id + "  " + camera.protocol + "  " + camera.address), std::string::npos) << listed;
    if (camera.serial.starts_with("LOOMCAM0")) {
      ++found;
      EXPECT_EQ(camera.protocol, "GigEVision");
      EXPECT_TRUE(camera.address.starts_with("127.0.0.")) << camera.address;
    }
  }
  EXPECT_EQ(found, kCameras);
}

}  // namespace
}  // namespace loom::hal
