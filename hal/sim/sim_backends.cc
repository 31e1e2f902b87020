#include "hal/sim/sim_backends.h"

#include <cmath>
#include <cstring>
#include <deque>
#include <optional>
#include <vector>

#include "core/interrupt.h"

namespace loom::hal {
namespace {

// SplitMix64 finaliser: mixes the fields of a frame into its noise seed.
uint64_t Mix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

uint64_t HashDouble(uint64_t h, double value) {
  uint64_t bits;
  std::memcpy(&bits, &value, sizeof(bits));
  return Mix(h ^ bits);
}

// The noise seed of a frame: what it shows, not when it was taken.
uint64_t FrameSeed(uint64_t world_seed, int camera, const sim::SceneState& state, const CameraSettings& settings) {
  uint64_t h = Mix(world_seed ^ static_cast<uint64_t>(camera));
  for (const sim::LitLed& led : state.leds) h = HashDouble(Mix(h ^ static_cast<uint64_t>(led.led)), led.current_ma);
  for (const auto& [wheel, slot] : state.filter_slots) h = Mix(h ^ (static_cast<uint64_t>(wheel) << 32) ^ slot);
  h = HashDouble(h, state.turntable_deg);
  h = HashDouble(h, settings.exposure_us);
  return HashDouble(h, settings.gain);
}

class SimCamera : public Camera {
 public:
  SimCamera(const DeviceConfig& config, std::shared_ptr<SimWorld> world, std::string model, int supersampling)
      : Camera(config.name, "sim", "virtual " + model),
        world_(std::move(world)),
        model_(std::move(model)),
        supersampling_(supersampling) {}
  ~SimCamera() override { Disarm(); }

 protected:
  Result<DeviceIdentity> DoOpen() override {
    const auto& cameras = world_->scene()->rig().cameras;
    for (size_t i = 0; i < cameras.size(); ++i) {
      if (cameras[i].name == model_) index_ = static_cast<int>(i);
    }
    if (index_ < 0) return Error(StatusCode::kNotFound, "the rig geometry has no camera '" + model_ + "'");
    const CameraModel& camera = cameras[index_];
    CameraCapabilities caps;
    caps.sensor_width = camera.width;
    caps.sensor_height = camera.height;
    caps.pixel_formats = {scan::PixelFormat::kMono12, scan::PixelFormat::kMono16};
    caps.exposure_min_us = 10;
    caps.exposure_max_us = 1e7;
    caps.gain_min = 0;
    caps.gain_max = 24;
    set_capabilities(caps);
    return DeviceIdentity{"loom", "simulated camera", "SIM-" + model_, ""};
  }
  Status DoConfigure(CameraSettings*) override { return Status::Ok(); }
  Status DoStart() override {
    queue_.clear();
    if (settings().trigger == TriggerMode::kHardware) {
      // A frame whose rendering was interrupted is not delivered; the sequencer sees the interrupt.
      armed_ = world_->ArmTrigger([this] {
        if (auto frame = Render(); frame.ok()) queue_.push_back(std::move(*frame));
      });
    }
    return Status::Ok();
  }
  Status DoStop() override {
    Disarm();
    return Status::Ok();
  }
  Status DoClose() override {
    Disarm();
    return Status::Ok();
  }
  Status DoMakeSafe() override { return Status::Ok(); }
  Status DoTriggerSoftware() override {
    LOOM_ASSIGN_OR_RETURN(scan::RawFrame frame, Render());
    queue_.push_back(std::move(frame));
    return Status::Ok();
  }
  Status DoDiscardFrames() override {
    queue_.clear();
    return Status::Ok();
  }
  Result<scan::RawFrame> DoWaitFrame(std::chrono::milliseconds timeout) override {
    if (world_->TakeInjectedFault(world_->camera_failures, name())) {
      queue_.clear();
      return Error(StatusCode::kUnavailable, "camera dropped out (injected by the simulator)");
    }
    if (queue_.empty() && settings().trigger == TriggerMode::kFreeRun) {
      LOOM_ASSIGN_OR_RETURN(scan::RawFrame frame, Render());
      queue_.push_back(std::move(frame));
    }
    if (queue_.empty()) {
      // A hardware-triggered frame that an interrupt stopped was never queued.
      if (InterruptRequested()) return CancelledError(name(), "interrupted while rendering a frame");
      return Error(StatusCode::kTimeout, "no frame within " + std::to_string(timeout.count()) + " ms (not triggered)");
    }
    scan::RawFrame frame = std::move(queue_.front());
    queue_.pop_front();
    return frame;
  }

 private:
  void Disarm() {
    if (armed_) world_->DisarmTrigger(*armed_);
    armed_.reset();
  }

  // Cancelled if the rig's interrupt handler saw SIGTERM or Ctrl-C while the frame was rendered:
  // a large simulated frame takes seconds to minutes, which a stop must not wait for.
  Result<scan::RawFrame> Render() {
    sim::SceneState state;
    {
      std::lock_guard lock(world_->mutex);
      state = world_->state;
    }
    const std::shared_ptr<const sim::Scene> shown = world_->scene();
    const CameraModel& model = shown->rig().cameras[index_];
    const CameraSettings& s = settings();
    // Only the region of interest is rendered; its noise and vignetting are those of its place
    // on the sensor, so the frame is the full frame's crop.
    const sim::SensorWindow window{s.roi.x, s.roi.y, s.roi.width, s.roi.height};
    const Image* rendered = RadianceOf(shown, state, window);
    if (rendered == nullptr) return CancelledError(name(), "interrupted while rendering a frame");
    const Image& radiance = *rendered;
    // Drifting lights scale the light as a longer exposure would; the noise seed stays the frame's.
    const double output = !state.leds.empty() ? world_->NextLedOutput() : state.linear_light_on ? world_->NextStripOutput() : 1.0;
    const std::vector<uint16_t> raw =
        sim::CaptureRaw(radiance, model.sensor, {s.exposure_us * output, s.gain}, FrameSeed(world_->seed, index_, state, s),
                        window, model.width, model.height);
    const int shift = s.pixel_format == scan::PixelFormat::kMono16 ? 16 - model.sensor.adc_bits : 0;
    scan::RawFrame frame;
    frame.width = s.roi.width;
    frame.height = s.roi.height;
    frame.pixels.resize(raw.size());
    for (size_t i = 0; i < raw.size(); ++i) frame.pixels[i] = static_cast<uint16_t>(raw[i] << shift);
    scan::FrameMetadata& meta = frame.metadata;
    meta.camera = name();
    meta.camera_serial = identity().serial;
    meta.pixel_format = s.pixel_format;
    meta.roi = s.roi;
    meta.exposure_us = s.exposure_us;
    meta.gain = s.gain;
    meta.frame_id = ++frames_;
    meta.host_timestamp_ns =
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
    return frame;
  }

  // The radiance of the last frame is kept: an HDR bracket exposes the same scene several
  // times, and rendering, not exposing, is what costs (2-3 frames per rendering in a scan). So
  // are the camera's rays' hits, which the steps at one turntable angle share. nullptr if
  // interrupted: what was traced or rendered then is incomplete, and neither is kept.
  const Image* RadianceOf(const std::shared_ptr<const sim::Scene>& scene, const sim::SceneState& state,
                          const sim::SensorWindow& window) {
    if (scene != rendered_scene_ || !(state == rendered_state_) || !(window == rendered_window_)) {
      const sim::RenderOptions options{.supersampling = supersampling_, .window = window, .stop_requested = InterruptRequested};
      const CameraModel& camera = scene->rig().cameras[index_];
      if (scene->Dark(state)) {
        rendered_ =
            Image(window.width > 0 ? window.width : camera.width, window.height > 0 ? window.height : camera.height, {"L"});
      } else {
        if (scene != traced_scene_ || !hits_.Serve(index_, state.turntable_deg, options)) {
          hits_ = sim::CameraHits{};  // the old hits freed before the new are traced
          hits_ = scene->TraceCamera(index_, state.turntable_deg, options);
          traced_scene_ = scene;
        }
        if (!InterruptRequested()) rendered_ = scene->RenderRadiance(hits_, state, options);
      }
      if (InterruptRequested()) {
        traced_scene_ = rendered_scene_ = nullptr;
        return nullptr;
      }
      rendered_scene_ = scene;
      rendered_state_ = state;
      rendered_window_ = window;
    }
    return &rendered_;
  }

  std::shared_ptr<SimWorld> world_;
  std::string model_;
  int supersampling_;
  int index_ = -1;
  uint64_t frames_ = 0;
  std::deque<scan::RawFrame> queue_;
  std::optional<int> armed_;  // on the world's trigger line
  std::shared_ptr<const sim::Scene> rendered_scene_;
  sim::SceneState rendered_state_;
  sim::SensorWindow rendered_window_;
  Image rendered_;
  std::shared_ptr<const sim::Scene> traced_scene_;
  sim::CameraHits hits_;
};

class SimLedArray : public LedArray {
 public:
  SimLedArray(const DeviceConfig& config, std::shared_ptr<SimWorld> world)
      : LedArray(config.name, "sim", "virtual"), world_(std::move(world)) {}

 protected:
  Result<DeviceIdentity> DoOpen() override {
    set_limits(static_cast<int>(world_->scene()->rig().leds.size()), 1000);
    return DeviceIdentity{"loom", "simulated LED controller", "SIM-LEDS", ""};
  }
  Status DoConfigure(const LedArraySettings&) override { return Status::Ok(); }
  Status DoStart() override { return Status::Ok(); }
  Status DoStop() override { return DoAllOff(); }
  Status DoClose() override { return Status::Ok(); }
  Status DoDrive(std::span<const scan::LedDrive> leds) override {
    if (world_->InjectedDeviceFault(name())) return Error(StatusCode::kTimeout, "no reply (injected fault)");
    std::lock_guard lock(world_->mutex);
    world_->state.leds.clear();
    for (const scan::LedDrive& drive : leds) {
      if (drive.current_ma > 0) world_->state.leds.push_back({drive.led, drive.current_ma});
    }
    return Status::Ok();
  }
  Status DoAllOff() override {
    std::lock_guard lock(world_->mutex);
    world_->state.leds.clear();
    return Status::Ok();
  }
  Status DoFireTrigger() override {
    world_->FireTrigger();
    return Status::Ok();
  }
  Result<LedArrayReadback> DoRead() override {
    if (world_->TakeInjectedFault(world_->read_failures, name())) return Error(StatusCode::kTimeout, "no reply (injected fault)");
    std::lock_guard lock(world_->mutex);
    LedArrayReadback read;
    read.current_ma.assign(led_count(), 0.0);
    for (const sim::LitLed& led : world_->state.leds) read.current_ma[led.led] = led.current_ma;
    read.temperature_c = 30;
    return read;
  }

 private:
  std::shared_ptr<SimWorld> world_;
};

class SimFilterWheel : public FilterWheel {
 public:
  SimFilterWheel(const DeviceConfig& config, std::shared_ptr<SimWorld> world, std::string model)
      : FilterWheel(config.name, "sim", "virtual " + model), world_(std::move(world)), model_(std::move(model)) {}

 protected:
  Result<DeviceIdentity> DoOpen() override {
    const auto& wheels = world_->scene()->rig().filter_wheels;
    for (size_t i = 0; i < wheels.size(); ++i) {
      if (wheels[i].name == model_) index_ = static_cast<int>(i);
    }
    if (index_ < 0) return Error(StatusCode::kNotFound, "the rig geometry has no filter wheel '" + model_ + "'");
    set_slot_count(static_cast<int>(wheels[index_].filters.size()));
    return DeviceIdentity{"loom", "simulated filter wheel", "SIM-" + model_, ""};
  }
  Status DoConfigure(const FilterWheelSettings&) override { return Status::Ok(); }
  Status DoStart() override { return Status::Ok(); }
  Status DoStop() override { return Status::Ok(); }
  Status DoClose() override { return Status::Ok(); }
  Status DoMakeSafe() override { return Status::Ok(); }
  Status DoMoveTo(int slot) override {
    if (world_->InjectedDeviceFault(name())) return Error(StatusCode::kTimeout, "no reply (injected fault)");
    std::lock_guard lock(world_->mutex);
    world_->state.filter_slots[index_] = slot;
    return Status::Ok();
  }
  Result<int> DoPosition() override {
    std::lock_guard lock(world_->mutex);
    const auto it = world_->state.filter_slots.find(index_);
    return it == world_->state.filter_slots.end() ? 0 : it->second;
  }

 private:
  std::shared_ptr<SimWorld> world_;
  std::string model_;
  int index_ = -1;
};

class SimTurntable : public Turntable {
 public:
  SimTurntable(const DeviceConfig& config, std::shared_ptr<SimWorld> world)
      : Turntable(config.name, "sim", "virtual"), world_(std::move(world)) {}

 protected:
  Result<DeviceIdentity> DoOpen() override {
    set_max_speed(360);
    return DeviceIdentity{"loom", "simulated turntable", "SIM-TT", ""};
  }
  Status DoConfigure(const TurntableSettings&) override { return Status::Ok(); }
  Status DoStart() override { return Status::Ok(); }
  Status DoStop() override { return Status::Ok(); }
  Status DoClose() override { return Status::Ok(); }
  Status DoMakeSafe() override { return Status::Ok(); }
  Status DoHome() override { return DoMoveTo(0); }
  Status DoMoveTo(double angle_deg) override {
    if (world_->InjectedDeviceFault(name())) return Error(StatusCode::kTimeout, "no reply (injected fault)");
    std::lock_guard lock(world_->mutex);
    world_->state.turntable_deg = angle_deg;
    return Status::Ok();
  }
  Result<double> DoAngle() override {
    std::lock_guard lock(world_->mutex);
    return world_->state.turntable_deg;
  }

 private:
  std::shared_ptr<SimWorld> world_;
};

class SimLinearLight : public LinearLight {
 public:
  SimLinearLight(const DeviceConfig& config, std::shared_ptr<SimWorld> world, double travel_mm)
      : LinearLight(config.name, "sim", "virtual"), world_(std::move(world)), travel_mm_(travel_mm) {}

 protected:
  Result<DeviceIdentity> DoOpen() override {
    set_limits(travel_mm_, 500);
    return DeviceIdentity{"loom", "simulated linear light", "SIM-LL", ""};
  }
  Status DoConfigure(const LinearLightSettings&) override { return Status::Ok(); }
  Status DoStart() override { return Status::Ok(); }
  Status DoStop() override { return Status::Ok(); }
  Status DoClose() override { return Status::Ok(); }
  Status DoMakeSafe() override { return SwitchStrip(false, 0); }
  Status DoHome() override { return DoMoveTo(0); }
  Status DoMoveTo(double position_mm) override {
    if (world_->InjectedDeviceFault(name())) return Error(StatusCode::kTimeout, "no reply (injected fault)");
    std::lock_guard lock(world_->mutex);
    world_->state.linear_light_mm = position_mm;
    return Status::Ok();
  }
  Status DoSetStrip(bool on, double intensity) override {
    if (world_->InjectedDeviceFault(name())) return Error(StatusCode::kTimeout, "no reply (injected fault)");
    return SwitchStrip(on, intensity);
  }
  Result<LinearLightReadback> DoRead() override {
    std::lock_guard lock(world_->mutex);
    const sim::SceneState& s = world_->state;
    return LinearLightReadback{s.linear_light_mm, s.linear_light_on, s.linear_light_intensity};
  }

 private:
  Status SwitchStrip(bool on, double intensity) {
    std::lock_guard lock(world_->mutex);
    world_->state.linear_light_on = on;
    world_->state.linear_light_intensity = intensity;
    return Status::Ok();
  }

  std::shared_ptr<SimWorld> world_;
  double travel_mm_;
};

class SimProjector : public Projector {
 public:
  SimProjector(const DeviceConfig& config, std::shared_ptr<SimWorld> world, int width, int height)
      : Projector(config.name, "sim", "virtual"), world_(std::move(world)), width_(width), height_(height) {}

 protected:
  Result<DeviceIdentity> DoOpen() override {
    set_native_size(width_, height_);
    return DeviceIdentity{"loom", "simulated projector", "SIM-PROJ", ""};
  }
  Status DoConfigure(const ProjectorSettings&) override { return Status::Ok(); }
  Status DoStart() override { return Status::Ok(); }
  Status DoStop() override { return Status::Ok(); }
  Status DoClose() override { return Status::Ok(); }
  Status DoShow(const scan::Pattern& pattern) override {
    if (world_->InjectedDeviceFault(name())) return Error(StatusCode::kTimeout, "no reply (injected fault)");
    auto image = std::make_shared<sim::ProjectedImage>(sim::ProjectedImage{pattern.width, pattern.height, pattern.pixels});
    std::lock_guard lock(world_->mutex);
    world_->state.projector_image = std::move(image);
    return Status::Ok();
  }
  Status DoBlank() override {
    std::lock_guard lock(world_->mutex);
    world_->state.projector_image.reset();
    return Status::Ok();
  }

 private:
  std::shared_ptr<SimWorld> world_;
  int width_;
  int height_;
};

}  // namespace

int SimWorld::ArmTrigger(std::function<void()> on_pulse) {
  std::lock_guard lock(mutex);
  armed_[next_handle_] = std::move(on_pulse);
  return next_handle_++;
}

void SimWorld::DisarmTrigger(int handle) {
  std::lock_guard lock(mutex);
  armed_.erase(handle);
}

double SimWorld::NextLedOutput() {
  std::lock_guard lock(mutex);
  return led_drift_.Next();
}

double SimWorld::NextStripOutput() {
  std::lock_guard lock(mutex);
  return strip_drift_.Next();
}

void SimWorld::FireTrigger() {
  std::vector<std::function<void()>> cameras;
  {
    std::lock_guard lock(mutex);
    ++pulses_;
    for (const auto& [handle, on_pulse] : armed_) cameras.push_back(on_pulse);
  }
  for (const auto& expose : cameras) expose();
}

namespace {

// A simulated light's drift from its device entry (output_drift_percent, output_drift_frames).
Status SetDriftFromConfig(const DeviceConfig& config, const std::string& kind, const std::function<void(double, double)>& set) {
  if (!config.node.Has("output_drift_percent") && !config.node.Has("output_drift_frames")) return Status::Ok();
  double drift_percent = 0, drift_frames = 100;
  config.node.Optional("output_drift_percent", &drift_percent);
  config.node.Optional("output_drift_frames", &drift_frames);
  if (!(std::abs(drift_percent) < 100 && drift_frames >= 1 && drift_frames < 1e9)) {
    return InvalidArgumentError(kind + " '" + config.name + "'",
                                "output_drift_percent must be within ±100 and output_drift_frames in [1, 1e9)");
  }
  set(drift_percent, drift_frames);
  return Status::Ok();
}

}  // namespace

void RegisterSimBackends(BackendRegistry& registry, std::shared_ptr<SimWorld> world) {
  registry.MarkSimulated("sim");
  registry.Register<Camera>("sim", [world](const DeviceConfig& config) -> Result<std::unique_ptr<Camera>> {
    std::string model = config.name;
    int supersampling = 2;
    config.node.Optional("model", &model);
    config.node.Optional("supersampling", &supersampling);
    return std::unique_ptr<Camera>(std::make_unique<SimCamera>(config, world, model, supersampling));
  });
  registry.Register<LedArray>("sim", [world](const DeviceConfig& config) -> Result<std::unique_ptr<LedArray>> {
    LOOM_RETURN_IF_ERROR(SetDriftFromConfig(config, "LED array", [&](double p, double f) { world->set_led_drift(p, f); }));
    return std::unique_ptr<LedArray>(std::make_unique<SimLedArray>(config, world));
  });
  registry.Register<FilterWheel>("sim", [world](const DeviceConfig& config) -> Result<std::unique_ptr<FilterWheel>> {
    std::string model = config.name;
    config.node.Optional("model", &model);
    return std::unique_ptr<FilterWheel>(std::make_unique<SimFilterWheel>(config, world, model));
  });
  registry.Register<Turntable>("sim", [world](const DeviceConfig& config) -> Result<std::unique_ptr<Turntable>> {
    return std::unique_ptr<Turntable>(std::make_unique<SimTurntable>(config, world));
  });
  registry.Register<LinearLight>("sim", [world](const DeviceConfig& config) -> Result<std::unique_ptr<LinearLight>> {
    const auto& geometry = world->scene()->rig().linear_light;
    double travel_mm = geometry ? geometry->travel_mm : 400;
    config.node.Optional("travel_mm", &travel_mm);
    LOOM_RETURN_IF_ERROR(SetDriftFromConfig(config, "linear light", [&](double p, double f) { world->set_strip_drift(p, f); }));
    return std::unique_ptr<LinearLight>(std::make_unique<SimLinearLight>(config, world, travel_mm));
  });
  registry.Register<Projector>("sim", [world](const DeviceConfig& config) -> Result<std::unique_ptr<Projector>> {
    const auto& geometry = world->scene()->rig().projector;
    int width = geometry ? geometry->width : 1280;
    int height = geometry ? geometry->height : 800;
    config.node.Optional("native_width", &width);
    config.node.Optional("native_height", &height);
    return std::unique_ptr<Projector>(std::make_unique<SimProjector>(config, world, width, height));
  });
}

}  // namespace loom::hal
