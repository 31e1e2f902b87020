#pragma once
// AravisCamera: the Camera on Aravis 0.8. Private to hal/aravis and its tests (which reach the
// underlying ArvCamera to set an Aravis fake camera's frame content).

#include <arv.h>

#include "hal/camera.h"

namespace loom::hal {

struct AravisCameraOptions {
  std::string address;         // IP address or Aravis device id
  int reconnect_attempts = 2;  // after a dropped camera
  Status Check() const;        // every problem, naming the field
};

class AravisCamera : public Camera {
 public:
  AravisCamera(std::string name, AravisCameraOptions options);
  ~AravisCamera() override;

  // The open ArvCamera (nullptr when closed). For tests of fake cameras.
  ArvCamera* native_camera() const { return camera_; }

  struct StreamStatistics {
    uint64_t completed = 0;  // frames delivered
    uint64_t failures = 0;   // frames that arrived incomplete
    uint64_t underruns = 0;  // frames dropped because no buffer was free
  };
  // Of the current acquisition (zeros when not running).
  StreamStatistics stream_statistics() const;

 protected:
  Result<DeviceIdentity> DoOpen() override;
  Status DoConfigure(CameraSettings* applied) override;
  Status DoStart() override;
  Status DoStop() override;
  Status DoClose() override;
  Status DoMakeSafe() override;
  Status DoTriggerSoftware() override;
  Result<scan::RawFrame> DoWaitFrame(std::chrono::milliseconds timeout) override;
  Status DoDiscardFrames() override;

 private:
  Status Connect();
  Status ApplySettings(CameraSettings* applied);
  // GigE Vision only: packet size (negotiated or set) and inter-packet delay.
  Status ApplyStreamSettings(CameraSettings* applied);
  Status StartStream();
  void StopStream();
  // The camera still answers on its control channel.
  bool Answers();
  // The camera still has the settings loom applied (a restarted one has its defaults).
  bool KeepsSettings();
  // After a lost camera: reopen, reconfigure and restart acquisition.
  Status Reconnect();
  Result<scan::RawFrame> ToRawFrame(ArvBuffer* buffer) const;
  // The next filled buffer within `timeout`, or nullptr.
  ArvBuffer* PopFrameBuffer(std::chrono::milliseconds timeout);
  // A status naming this camera from an Aravis GError (which it frees); OK if none.
  Status FromGError(GError* error, const std::string& what, StatusCode code = StatusCode::kUnavailable) const;

  AravisCameraOptions options_;
  ArvCamera* camera_ = nullptr;
  ArvStream* stream_ = nullptr;
};

}  // namespace loom::hal
