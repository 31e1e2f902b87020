#include "hal/rig.h"

#include <set>

#include "core/interrupt.h"
#include "core/log.h"

namespace loom::hal {
namespace {

DeviceConfig ReadDeviceHeader(const ConfigNode& node) {
  DeviceConfig config{"", "", node};
  node.Required("name", &config.name);
  node.Required("backend", &config.backend);
  return config;
}

TriggerMode ParseTrigger(const ConfigNode& node, const std::string& text) {
  if (text == "software") return TriggerMode::kSoftware;
  if (text == "hardware") return TriggerMode::kHardware;
  if (text == "free-run") return TriggerMode::kFreeRun;
  node.AddError("trigger", "unknown trigger '" + text + "' (expected software, hardware, free-run)");
  return TriggerMode::kSoftware;
}

CameraSettings ReadCameraSettings(const ConfigNode& node) {
  CameraSettings settings;
  std::string pixel_format(scan::PixelFormatName(settings.pixel_format));
  std::string trigger(TriggerModeName(settings.trigger));
  std::vector<int> roi;
  node.Optional("pixel_format", &pixel_format);
  node.Optional("roi", &roi);
  node.Optional("exposure_us", &settings.exposure_us);
  node.Optional("gain", &settings.gain);
  node.Optional("trigger", &trigger);
  node.Optional("buffer_count", &settings.buffer_count);
  node.Optional("frame_timeout_ms", &settings.frame_timeout_ms);
  node.Optional("packet_size", &settings.packet_size_bytes);
  node.Optional("packet_delay_ns", &settings.packet_delay_ns);
  if (Result<scan::PixelFormat> format = scan::ParsePixelFormat(pixel_format); format.ok()) {
    settings.pixel_format = *format;
  } else {
    node.AddError("pixel_format", format.status().message());
  }
  settings.trigger = ParseTrigger(node, trigger);
  if (!roi.empty()) {
    if (roi.size() == 4) {
      settings.roi = {roi[0], roi[1], roi[2], roi[3]};
    } else {
      node.AddError("roi", "expected [x, y, width, height]");
    }
  }
  return settings;
}

template <typename Settings, typename ReadFn>
Settings ReadSettings(const ConfigNode& device, ReadFn read) {
  Settings settings;
  if (std::optional<ConfigNode> node = device.OptionalChild("settings")) read(*node, &settings);
  return settings;
}

// A wait in ms from `key` of a device's mapping: finite, 0 to 10 minutes.
double ReadWaitS(const ConfigNode& node, const char* key) {
  constexpr double kMaxMs = 600000;
  double ms = 0;
  node.Optional(key, &ms);
  if (!(ms >= 0 && ms <= kMaxMs)) {
    node.AddError(key, "must be between 0 and " + std::to_string(static_cast<int>(kMaxMs)) + " ms");
    return 0;
  }
  return ms / 1000;
}

DeviceTiming ReadTiming(const ConfigNode& node, bool warms_up) {
  return {ReadWaitS(node, "settle_ms"), warms_up ? ReadWaitS(node, "warm_up_ms") : 0.0};
}

TriggerSource ReadTriggerSource(const ConfigNode& devices) {
  const std::optional<ConfigNode> node = devices.OptionalChild("trigger");
  if (!node) return TriggerSource::kNone;
  std::string source;
  node->Required("source", &source);
  if (source == "leds") return TriggerSource::kLedController;
  if (source == "generator") return TriggerSource::kGenerator;
  node->AddError("source", "unknown trigger source '" + source + "' (expected leds, generator)");
  return TriggerSource::kNone;
}

template <typename D>
Result<std::unique_ptr<D>> CreateDevice(const ConfigNode& node, const BackendRegistry& registry) {
  const DeviceConfig config = ReadDeviceHeader(node);
  if (config.name.empty() || config.backend.empty()) {
    return InvalidArgumentError("key '" + node.path() + "'", "a device needs 'name' and 'backend'");
  }
  return registry.Create<D>(config);
}

}  // namespace

Result<std::unique_ptr<Rig>> Rig::Create(const ConfigNode& devices, const BackendRegistry& registry, std::string name) {
  std::unique_ptr<Rig> rig(new Rig());
  rig->name_ = std::move(name);
  for (const ConfigNode& node : devices.OptionalSequence("cameras")) {
    LOOM_ASSIGN_OR_RETURN(std::unique_ptr<Camera> camera, CreateDevice<Camera>(node, registry));
    rig->cameras_.push_back(std::move(camera));
    rig->camera_settings_.push_back(
        ReadSettings<CameraSettings>(node, [](const ConfigNode& n, CameraSettings* s) { *s = ReadCameraSettings(n); }));
  }
  for (const ConfigNode& node : devices.OptionalSequence("filter_wheels")) {
    LOOM_ASSIGN_OR_RETURN(std::unique_ptr<FilterWheel> wheel, CreateDevice<FilterWheel>(node, registry));
    rig->timing_[wheel->name()] = ReadTiming(node, false);
    rig->filter_wheels_.push_back(std::move(wheel));
    rig->filter_wheel_settings_.push_back(ReadSettings<FilterWheelSettings>(
        node, [](const ConfigNode& n, FilterWheelSettings* s) { n.Optional("move_timeout_ms", &s->move_timeout_ms); }));
  }
  if (std::optional<ConfigNode> node = devices.OptionalChild("leds")) {
    LOOM_ASSIGN_OR_RETURN(rig->leds_, CreateDevice<LedArray>(*node, registry));
    rig->timing_[rig->leds_->name()] = ReadTiming(*node, true);
    rig->led_settings_ = ReadSettings<LedArraySettings>(
        *node, [](const ConfigNode& n, LedArraySettings* s) { n.Optional("current_limit_ma", &s->current_limit_ma); });
  }
  if (std::optional<ConfigNode> node = devices.OptionalChild("turntable")) {
    LOOM_ASSIGN_OR_RETURN(rig->turntable_, CreateDevice<Turntable>(*node, registry));
    rig->timing_[rig->turntable_->name()] = ReadTiming(*node, false);
    rig->turntable_settings_ = ReadSettings<TurntableSettings>(*node, [](const ConfigNode& n, TurntableSettings* s) {
      n.Optional("speed_deg_s", &s->speed_deg_s);
      n.Optional("move_timeout_ms", &s->move_timeout_ms);
    });
  }
  if (std::optional<ConfigNode> node = devices.OptionalChild("linear_light")) {
    LOOM_ASSIGN_OR_RETURN(rig->linear_light_, CreateDevice<LinearLight>(*node, registry));
    rig->timing_[rig->linear_light_->name()] = ReadTiming(*node, true);
    rig->linear_light_settings_ = ReadSettings<LinearLightSettings>(*node, [](const ConfigNode& n, LinearLightSettings* s) {
      n.Optional("speed_mm_s", &s->speed_mm_s);
      n.Optional("move_timeout_ms", &s->move_timeout_ms);
    });
  }
  if (std::optional<ConfigNode> node = devices.OptionalChild("projector")) {
    LOOM_ASSIGN_OR_RETURN(rig->projector_, CreateDevice<Projector>(*node, registry));
    rig->timing_[rig->projector_->name()] = ReadTiming(*node, false);
    rig->projector_settings_ = ReadSettings<ProjectorSettings>(*node, [](const ConfigNode& n, ProjectorSettings* s) {
      n.Optional("width", &s->width);
      n.Optional("height", &s->height);
    });
  }
  rig->trigger_source_ = ReadTriggerSource(devices);
  LOOM_RETURN_IF_ERROR(rig->CheckTriggerWiring(devices));
  std::set<std::string> names;
  bool simulated = true;
  for (Device* device : rig->devices()) {
    if (!names.insert(device->name()).second) {
      return InvalidArgumentError("key '" + devices.path() + "'", "two devices are named '" + device->name() + "'");
    }
    simulated = simulated && registry.IsSimulated(device->backend());
  }
  if (simulated) {
    rig->clock_ = std::make_unique<SimClock>();
  } else {
    rig->clock_ = std::make_unique<SteadyClock>();
  }
  return rig;
}

Result<std::unique_ptr<Rig>> Rig::Load(const std::filesystem::path& path, const BackendRegistry& registry) {
  LOOM_ASSIGN_OR_RETURN(const RigFile file, RigFile::Load(path));
  return Load(file, registry);
}

Result<std::unique_ptr<Rig>> Rig::Load(const RigFile& file, const BackendRegistry& registry) {
  // Factories only read their keys (they connect in Open()), so a failure here is a bad value;
  // after one, later keys are unread and Finish() would wrongly call them unknown.
  const std::optional<ConfigNode> devices = file.Section("devices");
  if (!devices) return InvalidArgumentError(file.source(), "has no 'devices:' section");
  Result<std::unique_ptr<Rig>> rig = Create(*devices, registry, file.name());
  if (!rig.ok()) return rig.status().WithContext(file.source());
  LOOM_RETURN_IF_ERROR(file.Finish());
  return rig;
}

std::vector<Device*> Rig::devices() const {
  std::vector<Device*> all;
  for (const auto& camera : cameras_) all.push_back(camera.get());
  if (leds_) all.push_back(leds_.get());
  for (const auto& wheel : filter_wheels_) all.push_back(wheel.get());
  if (turntable_) all.push_back(turntable_.get());
  if (linear_light_) all.push_back(linear_light_.get());
  if (projector_) all.push_back(projector_.get());
  return all;
}

Device* Rig::FindDevice(const std::string& name) const {
  for (Device* device : devices()) {
    if (device->name() == name) return device;
  }
  return nullptr;
}

DeviceTiming Rig::Timing(const Device& device) const {
  const auto it = timing_.find(device.name());
  return it == timing_.end() ? DeviceTiming{} : it->second;
}

Status Rig::SetCameraRegion(const std::string& camera, const scan::Roi& roi) {
  for (size_t i = 0; i < cameras_.size(); ++i) {
    if (cameras_[i]->name() != camera) continue;
    camera_settings_[i].roi = roi;
    return Status::Ok();
  }
  return NotFoundError("camera '" + camera + "'", "not in rig '" + name_ + "'");
}

Status Rig::Configure(Device* device) {
  Result<ConfigureReport> report = InternalError(device->description(), "not a rig device");
  for (size_t i = 0; i < cameras_.size(); ++i) {
    if (cameras_[i].get() == device) report = cameras_[i]->Configure(camera_settings_[i]);
  }
  for (size_t i = 0; i < filter_wheels_.size(); ++i) {
    if (filter_wheels_[i].get() == device) report = filter_wheels_[i]->Configure(filter_wheel_settings_[i]);
  }
  if (device == leds_.get()) report = leds_->Configure(led_settings_);
  if (device == turntable_.get()) report = turntable_->Configure(turntable_settings_);
  if (device == linear_light_.get()) report = linear_light_->Configure(linear_light_settings_);
  if (device == projector_.get()) report = projector_->Configure(projector_settings_);
  if (!report.ok()) return report.status();
  if (report->outcome == Negotiation::kAdjusted) {
    LOOM_LOG(Warning) << device->description() << ": settings adjusted: " << report->ToString();
  }
  return report->ToStatus(device->description());
}

Status Rig::OpenAndConfigure() {
  for (Device* device : devices()) LOOM_RETURN_IF_ERROR(OpenAndConfigure(device));
  return Status::Ok();
}

Status Rig::OpenAndConfigure(Device* device) {
  if (device->state() == DeviceState::kClosed) LOOM_RETURN_IF_ERROR(device->Open());
  return Configure(device);
}

Status Rig::StartAll() {
  for (Device* device : devices()) {
    if (device->state() != DeviceState::kRunning) LOOM_RETURN_IF_ERROR(device->Start());
  }
  return Status::Ok();
}

Status Rig::StopAll() {
  Status first;
  for (Device* device : devices()) {
    if (device->state() != DeviceState::kRunning) continue;
    const Status stopped = device->Stop();
    if (first.ok()) first = stopped;
  }
  return first;
}

Status Rig::MakeSafe() {
  Status first;
  for (Device* device : devices()) {
    const Status safe = device->MakeSafe();
    if (!safe.ok()) LOOM_LOG(Error) << "safe state: " << safe.ToString();
    if (first.ok()) first = safe;
  }
  return first;
}

Status Rig::CloseAll() {
  Status first;
  for (Device* device : devices()) {
    const Status closed = device->Close();
    if (first.ok()) first = closed;
  }
  return first;
}

Result<scan::RigState> Rig::ReadState() {
  scan::RigState state;
  if (leds_ && leds_->state() != DeviceState::kClosed) {
    LOOM_ASSIGN_OR_RETURN(const LedArrayReadback leds, leds_->Read());
    for (size_t i = 0; i < leds.current_ma.size(); ++i) {
      if (leds.current_ma[i] > 0) state.leds_on.push_back({static_cast<int>(i), leds.current_ma[i]});
    }
  }
  for (const auto& wheel : filter_wheels_) {
    if (wheel->state() == DeviceState::kClosed) continue;
    LOOM_ASSIGN_OR_RETURN(state.filter_slots[wheel->name()], wheel->Position());
  }
  if (turntable_ && turntable_->state() != DeviceState::kClosed) {
    LOOM_ASSIGN_OR_RETURN(state.turntable_deg, turntable_->Angle());
  }
  if (linear_light_ && linear_light_->state() != DeviceState::kClosed) {
    LOOM_ASSIGN_OR_RETURN(const LinearLightReadback light, linear_light_->Read());
    state.linear_light_mm = light.position_mm;
    state.linear_light_on = light.on;
    state.linear_light_intensity = light.intensity;
  }
  if (projector_) state.projector_pattern = projector_->current_pattern();
  return state;
}

Status Rig::CheckTriggerWiring(const ConfigNode& devices) const {
  if (trigger_source_ == TriggerSource::kLedController && !leds_) {
    return InvalidArgumentError("key '" + devices.path() + ".trigger.source'", "is leds, but the rig has no LED controller");
  }
  for (size_t i = 0; i < cameras_.size(); ++i) {
    if (camera_settings_[i].trigger == TriggerMode::kHardware && trigger_source_ == TriggerSource::kNone) {
      return InvalidArgumentError(cameras_[i]->description(),
                                  "is set to trigger: hardware, but nothing pulses its line: give the rig's devices "
                                  "'trigger: {source: leds}' (the LED controller's output) or '{source: generator}'");
    }
  }
  return Status::Ok();
}

std::vector<Status> Rig::Trigger(std::span<Camera* const> cameras) {
  std::vector<Status> triggered(cameras.size());
  std::vector<size_t> hardware;
  for (size_t i = 0; i < cameras.size(); ++i) {
    if (cameras[i]->settings().trigger != TriggerMode::kHardware) {
      triggered[i] = cameras[i]->TriggerSoftware();
      continue;
    }
    triggered[i] = cameras[i]->DiscardFrames();
    if (triggered[i].ok()) hardware.push_back(i);
  }
  if (hardware.empty()) return triggered;
  if (trigger_source_ == TriggerSource::kLedController) {
    const Status pulsed = leds_->FireTrigger();
    for (size_t i : hardware) triggered[i] = pulsed;
  } else if (trigger_source_ == TriggerSource::kGenerator) {
    // A free-running generator may have begun a frame before the discard: drop it too.
    for (size_t i : hardware) triggered[i] = cameras[i]->WaitFrame().status();
  } else {
    for (size_t i : hardware) {
      triggered[i] = FailedPreconditionError(cameras[i]->description(), "hardware trigger without a trigger source");
    }
  }
  return triggered;
}

Result<scan::RawFrame> Rig::Snap(Camera& camera) {
  LOOM_ASSIGN_OR_RETURN(scan::RigState state, ReadState());
  Camera* const one[] = {&camera};
  LOOM_RETURN_IF_ERROR(Trigger(one).front());
  LOOM_ASSIGN_OR_RETURN(scan::RawFrame frame, camera.WaitFrame());
  frame.metadata.rig_state = std::move(state);
  return frame;
}

SafeStateGuard::SafeStateGuard(Rig& rig) : rig_(rig) {}

SafeStateGuard::~SafeStateGuard() {
  const Status safe = rig_.MakeSafe();
  if (!safe.ok()) LOOM_LOG(Error) << "rig '" << rig_.name() << "' may not be safe: " << safe.ToString();
}

}  // namespace loom::hal
