#pragma once
// Four arv-fake-gv-camera-0.8 processes on 127.0.0.1–4, opened, configured and started through
// loom's AravisCamera: the camera peers of the hardware benchmarks. Only inside the private
// network namespace of hal/aravis/run_in_netns.sh (else `error` says so).

#include <memory>
#include <string>
#include <vector>

#include "core/testing/subprocess.h"
#include "hal/aravis/internal/aravis_camera.h"

namespace loom::bench {

struct FakeCameraPeers {
  std::vector<testing::Subprocess> fakes;
  std::vector<std::unique_ptr<hal::AravisCamera>> cameras;
  std::string error;  // empty when all four are running
};

FakeCameraPeers StartFakeCameraPeers(const std::string& serial_prefix, const hal::CameraSettings& settings);

}  // namespace loom::bench
