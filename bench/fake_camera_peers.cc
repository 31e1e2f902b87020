#include "bench/fake_camera_peers.h"

#include <cstdlib>
#include <thread>

namespace loom::bench {

FakeCameraPeers StartFakeCameraPeers(const std::string& serial_prefix, const hal::CameraSettings& settings) {
  FakeCameraPeers peers;
  const char* netns = std::getenv("LOOM_IN_PRIVATE_NETNS");
  if (netns == nullptr || std::string(netns) != "1") {
    peers.error = "run inside hal/aravis/run_in_netns.sh for the camera benchmarks";
    return peers;
  }
  arv_enable_interface("GigEVision");
  arv_disable_interface("Fake");
  for (int i = 0; i < 4; ++i) {
    const std::string address = "127.0.0." + std::to_string(i + 1);
    Result<testing::Subprocess> fake =
        testing::Subprocess::Start({"arv-fake-gv-camera-0.8", "-i", address, "-s", serial_prefix + std::to_string(i)});
    if (!fake.ok()) {
      peers.error = fake.status().ToString();
      return peers;
    }
    peers.fakes.push_back(std::move(*fake));
    auto camera = std::make_unique<hal::AravisCamera>("cam" + std::to_string(i), hal::AravisCameraOptions{address, 1});
    // The fake exits 0 even when it failed to bind, and needs a moment to start: retry.
    Status opened;
    for (int attempt = 0; attempt < 50 && !(opened = camera->Open()).ok(); ++attempt) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    if (!opened.ok() || !camera->Configure(settings).ok() || !camera->Start().ok()) {
      peers.error = "cannot bring up " + address + ": " + opened.ToString();
      return peers;
    }
    peers.cameras.push_back(std::move(camera));
  }
  return peers;
}

}  // namespace loom::bench
