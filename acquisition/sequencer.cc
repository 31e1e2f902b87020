#include "acquisition/sequencer.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/interrupt.h"
#include "core/log.h"
#include "scan/patterns.h"

namespace loom::acquisition {
namespace {

using Clock = std::chrono::steady_clock;

struct Exposure {
  double us;
  int index;  // capture order
};

}  // namespace

Sequencer::Sequencer(hal::Rig& rig, const scan::Plan& plan, scan::CaptureStore& store, SequencerOptions options)
    : rig_(rig), plan_(plan), store_(store), options_(options) {}

Result<hal::Camera*> Sequencer::FindCamera(const std::string& name) const {
  auto* camera = dynamic_cast<hal::Camera*>(rig_.FindDevice(name));
  if (camera == nullptr) {
    return NotFoundError("camera '" + name + "'", "the plan uses it, rig '" + rig_.name() + "' has no such camera");
  }
  return camera;
}

void Sequencer::Changed(const hal::Device& device, bool switched_on) {
  const double now = rig_.clock().NowS();
  const hal::DeviceTiming timing = rig_.Timing(device);
  double wait = timing.settle_s;
  if (switched_on && warmed_up_.insert(device.name()).second) wait = std::max(wait, timing.warm_up_s);
  changed_at_s_ = now;
  settled_at_s_ = std::max(settled_at_s_, now + wait);
}

Status Sequencer::MoveWheel(hal::FilterWheel& wheel, int slot) {
  LOOM_RETURN_IF_ERROR(wheel.MoveTo(slot));
  const auto known = wheel_slots_.find(wheel.name());
  if (known == wheel_slots_.end() || known->second != slot) Changed(wheel);
  wheel_slots_[wheel.name()] = slot;
  return Status::Ok();
}

Status Sequencer::PlaceWheels(const scan::Step& step) {
  for (const auto& wheel : rig_.filter_wheels()) {
    int slot = 0;
    for (const scan::Step& earlier : plan_.steps) {
      if (earlier.index >= step.index) break;
      if (earlier.filter && earlier.filter->wheel == wheel->name()) slot = earlier.filter->slot;
    }
    LOOM_RETURN_IF_ERROR(MoveWheel(*wheel, slot));
  }
  wheels_placed_ = true;
  return Status::Ok();
}

Status Sequencer::DriveLeds(const scan::Step& step) {
  hal::LedArray* leds = rig_.leds();
  if (leds == nullptr) {
    if (step.leds.empty()) return Status::Ok();
    return FailedPreconditionError("rig '" + rig_.name() + "'", "step " + std::to_string(step.index) + " needs an LED array");
  }
  LOOM_RETURN_IF_ERROR(step.leds.empty() ? leds->AllOff() : leds->Drive(step.leds));
  if (leds_driven_ != step.leds) Changed(*leds, !step.leds.empty());
  leds_driven_ = step.leds;
  return Status::Ok();
}

Status Sequencer::SetLinearLight(const scan::Step& step) {
  hal::LinearLight* strip = rig_.linear_light();
  if (!step.linear_light_mm) {
    if (strip == nullptr || strip_on_ == false) return Status::Ok();
    LOOM_RETURN_IF_ERROR(strip->SetStrip(false, 0));
    strip_on_ = false;
    Changed(*strip);
    return Status::Ok();
  }
  if (strip == nullptr) {
    return FailedPreconditionError("rig '" + rig_.name() + "'", "step " + std::to_string(step.index) + " needs a linear light");
  }
  LOOM_RETURN_IF_ERROR(strip->MoveTo(*step.linear_light_mm));
  if (strip_mm_ != step.linear_light_mm) Changed(*strip);
  strip_mm_ = step.linear_light_mm;
  if (strip_on_ != true) {
    LOOM_RETURN_IF_ERROR(strip->SetStrip(true, 1.0));
    Changed(*strip, true);
  }
  strip_on_ = true;
  return Status::Ok();
}

Status Sequencer::WaitUntilSettled() { return rig_.clock().SleepFor(settled_at_s_ - rig_.clock().NowS()); }

double Sequencer::SettledMs() const { return (rig_.clock().NowS() - changed_at_s_) * 1000; }

Status Sequencer::ApplyStep(const scan::Step& step) {
  const std::string where = "step " + std::to_string(step.index);
  if (hal::Turntable* turntable = rig_.turntable()) {
    LOOM_ASSIGN_OR_RETURN(const double angle, turntable->Angle());
    if (std::abs(angle - step.turntable_deg) > 1e-6) {
      LOOM_RETURN_IF_ERROR(turntable->MoveTo(step.turntable_deg));
      Changed(*turntable);
    }
  } else if (step.turntable_deg != 0) {
    return FailedPreconditionError("rig '" + rig_.name() + "'", where + " needs a turntable");
  }
  if (!wheels_placed_) LOOM_RETURN_IF_ERROR(PlaceWheels(step));
  if (step.filter) {
    hal::FilterWheel* wheel = nullptr;
    for (const auto& candidate : rig_.filter_wheels()) {
      if (candidate->name() == step.filter->wheel) wheel = candidate.get();
    }
    if (wheel == nullptr) return NotFoundError("filter wheel '" + step.filter->wheel + "'", where + " needs it");
    LOOM_RETURN_IF_ERROR(MoveWheel(*wheel, step.filter->slot));
  }
  LOOM_RETURN_IF_ERROR(DriveLeds(step));
  LOOM_RETURN_IF_ERROR(SetLinearLight(step));
  if (!step.projector_pattern.empty()) {
    hal::Projector* projector = rig_.projector();
    if (projector == nullptr) return FailedPreconditionError("rig '" + rig_.name() + "'", where + " needs a projector");
    LOOM_ASSIGN_OR_RETURN(const scan::Pattern pattern, scan::MakePattern(step.projector_pattern, projector->settings().width,
                                                                         projector->settings().height, options_.phase_steps));
    LOOM_RETURN_IF_ERROR(projector->Show(pattern));
    projector_showing_ = true;
    Changed(*projector);
  } else if (rig_.projector() != nullptr && projector_showing_ != false) {
    LOOM_RETURN_IF_ERROR(rig_.projector()->Blank());
    projector_showing_ = false;
    Changed(*rig_.projector());
  }
  return WaitUntilSettled();
}

Status Sequencer::SetExposureAndWindow(hal::Camera& camera, const scan::Step& step, double exposure_us) {
  const auto window = step.windows.find(camera.name());
  const scan::Roi& roi = window != step.windows.end() ? window->second : scan_regions_.at(camera.name());
  if (camera.settings().exposure_us == exposure_us && camera.settings().roi == roi &&
      camera.state() == hal::DeviceState::kRunning) {
    return Status::Ok();
  }
  hal::CameraSettings settings = camera.settings();
  settings.exposure_us = exposure_us;
  settings.roi = roi;
  // A free-running camera would expose while the rig changes: it is triggered by software.
  if (settings.trigger == hal::TriggerMode::kFreeRun) settings.trigger = hal::TriggerMode::kSoftware;
  if (camera.state() == hal::DeviceState::kRunning) LOOM_RETURN_IF_ERROR(camera.Stop());
  LOOM_ASSIGN_OR_RETURN(const hal::ConfigureReport report, camera.Configure(settings));
  LOOM_RETURN_IF_ERROR(report.ToStatus(camera.description()));
  return camera.Start();
}

Result<scan::RawFrame> Sequencer::CaptureWithRetries(hal::Camera& camera, const scan::Step& step) {
  Status last;
  for (int attempt = 0; attempt <= options_.max_retries; ++attempt) {
    if (InterruptRequested()) return CancelledError("scan", "interrupted at step " + std::to_string(step.index));
    Result<scan::RawFrame> frame = rig_.Snap(camera);
    if (frame.ok()) {
      frame->metadata.rig_state.settled_ms = SettledMs();
      return frame;
    }
    last = frame.status();
    const bool transient =
        last.code() == StatusCode::kTimeout || last.code() == StatusCode::kUnavailable || last.code() == StatusCode::kDataLoss;
    if (!transient) break;
    LOOM_LOG(Warning) << last.ToString() << " (attempt " << attempt + 1 << " of " << options_.max_retries + 1 << ")";
  }
  return last.WithContext("step " + std::to_string(step.index));
}

Result<std::vector<scan::RawFrame>> Sequencer::CaptureExposure(const scan::Step& step, double exposure_us, int exposure_index) {
  std::vector<std::optional<scan::RawFrame>> frames(step.cameras.size());
  std::vector<size_t> to_capture;
  for (size_t i = 0; i < step.cameras.size(); ++i) {
    const scan::FrameKey key{step.index, step.cameras[i], exposure_index};
    if (!store_.Has(key)) {
      to_capture.push_back(i);
      continue;
    }
    for (const scan::FrameRecord& record : store_.records()) {  // resumed: what was captured decides as it did then
      if (record.key == key) {
        LOOM_ASSIGN_OR_RETURN(scan::RawFrame frame, store_.ReadFrame(record));
        frames[i] = std::move(frame);
      }
    }
  }
  if (!to_capture.empty()) {
    std::vector<hal::Camera*> cameras;
    for (size_t i : to_capture) {
      LOOM_ASSIGN_OR_RETURN(hal::Camera* const camera, FindCamera(step.cameras[i]));
      LOOM_RETURN_IF_ERROR(SetExposureAndWindow(*camera, step, exposure_us));
      cameras.push_back(camera);
    }
    // The step's cameras are triggered together (one pulse for those on the hardware trigger),
    // then read out; a camera that fails is retried on its own.
    LOOM_ASSIGN_OR_RETURN(scan::RigState state, ReadStateWithRetries(step));
    state.settled_ms = SettledMs();
    const std::vector<Status> triggered = rig_.Trigger(cameras);
    for (size_t c = 0; c < cameras.size(); ++c) {
      Result<scan::RawFrame> frame = triggered[c].ok() ? cameras[c]->WaitFrame() : Result<scan::RawFrame>(triggered[c]);
      if (frame.ok()) {
        frame->metadata.rig_state = state;
      } else if (frame.status().code() == StatusCode::kCancelled) {
        return CancelledError("scan", "interrupted at step " + std::to_string(step.index));
      } else {
        LOOM_LOG(Warning) << frame.status().ToString() << "; retrying " << cameras[c]->name() << " alone";
        frame = CaptureWithRetries(*cameras[c], step);
      }
      if (!frame.ok()) return frame.status();
      const size_t i = to_capture[c];
      LOOM_RETURN_IF_ERROR(store_.Append({step.index, step.cameras[i], exposure_index}, *frame));
      frames[i] = std::move(*frame);
    }
  }
  std::vector<scan::RawFrame> result;
  for (auto& frame : frames) result.push_back(std::move(*frame));
  return result;
}

std::pair<double, double> Sequencer::BlackAndFloor(const std::string& camera) const {
  if (auto it = dark_.find(camera); it != dark_.end()) {
    return {it->second.black_dn, std::max(1.0, options_.noise_floor_sigmas * it->second.noise_dn)};
  }
  return {options_.black_level_dn, options_.noise_floor_dn};
}

Status Sequencer::MeasureDark(const scan::Step& step) {
  LOOM_ASSIGN_OR_RETURN(const std::vector<scan::RawFrame> frames, CaptureExposure(step, step.exposure.probe_us, 0));
  for (const scan::RawFrame& frame : frames) {
    const scan::DarkLevel level = scan::MeasureDarkLevel(frame);
    dark_[frame.metadata.camera] = level;
    LOOM_LOG(Info) << frame.metadata.camera << ": black level " << level.black_dn << " DN, noise " << level.noise_dn << " DN";
  }
  return Status::Ok();
}

Status Sequencer::MeasureDrift(const scan::Step& step) {
  LOOM_ASSIGN_OR_RETURN(const std::vector<scan::RawFrame> frames, CaptureExposure(step, step.exposure.probe_us, 0));
  LOOM_ASSIGN_OR_RETURN(const double output, drift_.Of(step).Add(step.index, step.turntable_deg, frames, dark_));
  const double percent = (output - 1) * 100;
  const char* lights = scan::LightDrift::StripLit(step) ? "the linear light" : "the LEDs";
  if (std::abs(percent) > options_.light_drift_warn_percent) {
    LOOM_LOG(Warning) << lights << " have drifted " << percent << " % since the scan's first drift reference (step " << step.index
                      << "; threshold " << options_.light_drift_warn_percent << " %): reconstruction corrects the images "
                      << lights << " lit for it";
  } else {
    LOOM_LOG(Info) << "output of " << lights << " at step " << step.index << ": " << output << " of the first drift reference's";
  }
  return Status::Ok();
}

Status Sequencer::RetryAfterDeviceFault(const Status& failed, const std::string& where, int attempt) {
  const DeviceFaultPolicy& policy = options_.device_faults;
  const bool transient = failed.code() == StatusCode::kTimeout || failed.code() == StatusCode::kUnavailable;
  if (!transient) return failed;
  if (attempt == policy.retries) {
    return Status(failed.code(), failed.subject(),
                  failed.message() + " " + where + ", after " + std::to_string(attempt + 1) + " attempts");
  }
  LOOM_LOG(Warning) << failed.ToString() << " " << where << " (attempt " << attempt + 1 << " of " << policy.retries + 1
                    << "); setting the step again in " << policy.retry_delay_ms << " ms";
  return rig_.clock().SleepFor(policy.retry_delay_ms / 1000);
}

Status Sequencer::ApplyStepWithRetries(const scan::Step& step) {
  for (int attempt = 0;; ++attempt) {
    const Status applied = ApplyStep(step);
    if (applied.ok()) return applied;
    LOOM_RETURN_IF_ERROR(RetryAfterDeviceFault(applied, "at step " + std::to_string(step.index), attempt));
  }
}

// A device that times out or is unavailable while the rig's state is read may have gone safe
// meanwhile (a controller frozen past its watchdog's timeout): the step is set again and the
// state read again, as often as the device-fault policy allows.
Result<scan::RigState> Sequencer::ReadStateWithRetries(const scan::Step& step) {
  for (int attempt = 0;; ++attempt) {
    Result<scan::RigState> state = rig_.ReadState();
    if (state.ok()) return state;
    LOOM_RETURN_IF_ERROR(
        RetryAfterDeviceFault(state.status(), "reading the rig's state at step " + std::to_string(step.index), attempt));
    LOOM_RETURN_IF_ERROR(ApplyStepWithRetries(step));
  }
}

Status Sequencer::CaptureStep(const scan::Step& step) {
  LOOM_RETURN_IF_ERROR(ApplyStepWithRetries(step));
  if (step.kind == scan::StepKind::kDark || step.kind == scan::StepKind::kDriftReference) {
    LOOM_RETURN_IF_ERROR(step.kind == scan::StepKind::kDark ? MeasureDark(step) : MeasureDrift(step));
    return store_.MarkStepDone(step.index);
  }
  LOOM_ASSIGN_OR_RETURN(hal::Camera* const first, FindCamera(step.cameras.front()));
  const double min_us = first->capabilities().exposure_min_us;
  const double max_us = first->capabilities().exposure_max_us;
  std::vector<Exposure> exposures = {{std::clamp(step.exposure.probe_us, min_us, max_us), 0}};
  LOOM_ASSIGN_OR_RETURN(std::vector<scan::RawFrame> probe, CaptureExposure(step, exposures[0].us, 0));
  std::vector<std::vector<scan::RawFrame>> frames = {std::move(probe)};
  while (static_cast<int>(exposures.size()) < step.exposure.max_exposures) {
    const auto shortest = std::min_element(exposures.begin(), exposures.end(), [](auto& a, auto& b) { return a.us < b.us; });
    const auto longest = std::max_element(exposures.begin(), exposures.end(), [](auto& a, auto& b) { return a.us < b.us; });
    bool saturated = false;
    bool weak = false;
    for (const scan::RawFrame& frame : frames[shortest->index]) {
      const double top = (1 << scan::BitDepth(frame.metadata.pixel_format)) - 1 - options_.saturation_margin_dn;
      saturated |= std::any_of(frame.pixels.begin(), frame.pixels.end(), [&](uint16_t v) { return v >= top; });
    }
    for (const scan::RawFrame& frame : frames[longest->index]) {
      // Lit but weak: some signal above black, less than the noise floor. Unlit pixels (off
      // the sample, in shadow) would never leave the floor: they do not ask for more.
      const auto [black, floor] = BlackAndFloor(frame.metadata.camera);
      // Captured by copy: clang 14 (the sanitized lanes' compiler) cannot capture structured bindings.
      const size_t count = std::count_if(frame.pixels.begin(), frame.pixels.end(), [black = black, floor = floor](uint16_t v) {
        const double signal = v - black;
        return signal > floor / 3 && signal < floor;
      });
      weak |= count > frame.pixels.size() / 100;
    }
    double next = 0;
    if (saturated && shortest->us > min_us) {
      next = std::max(min_us, shortest->us / options_.exposure_factor);
    } else if (weak && longest->us < max_us) {
      next = std::min(max_us, longest->us * options_.exposure_factor);
    } else {
      break;
    }
    const int index = static_cast<int>(exposures.size());
    exposures.push_back({next, index});
    LOOM_ASSIGN_OR_RETURN(std::vector<scan::RawFrame> more, CaptureExposure(step, next, index));
    frames.push_back(std::move(more));
  }
  const auto shortest = std::min_element(exposures.begin(), exposures.end(), [](auto& a, auto& b) { return a.us < b.us; });
  LOOM_RETURN_IF_ERROR(
      CaptureLinearitySeries(step, shortest->us, frames[shortest->index], static_cast<int>(exposures.size()), min_us, max_us));
  return store_.MarkStepDone(step.index);
}

Status Sequencer::CaptureLinearitySeries(const scan::Step& step, double shortest_us, const std::vector<scan::RawFrame>& shortest,
                                         int next_index, double min_us, double max_us) {
  if (step.exposure.linearity_series <= 0) return Status::Ok();
  // The brightest pixels (99.9th percentile: a hot pixel does not count) of any camera.
  double peak = 0, full_scale = 0;
  for (const scan::RawFrame& frame : shortest) {
    std::vector<uint16_t> values = frame.pixels;
    const auto at = values.begin() + static_cast<long>(0.999 * (values.size() - 1));
    std::nth_element(values.begin(), at, values.end());
    const double black = BlackAndFloor(frame.metadata.camera).first;
    if (*at - black > peak) {
      peak = *at - black;
      full_scale = (1 << scan::BitDepth(frame.metadata.pixel_format)) - 1 - black;
    }
  }
  if (peak <= 0) return Status::Ok();  // nothing lit: nothing to measure
  double exposure_us = std::clamp(shortest_us * 0.9 * full_scale / peak, min_us, max_us);
  for (int k = 0; k < step.exposure.linearity_series && exposure_us >= min_us; ++k, exposure_us /= 2) {
    LOOM_RETURN_IF_ERROR(CaptureExposure(step, exposure_us, next_index + k).status());
  }
  return Status::Ok();
}

Status Sequencer::PlaceObject(const scan::Step& step) {
  if (step.object == scan::ScanObject::kNothing || step.object == object_placed_) return Status::Ok();
  if (options_.place_object) {
    if (Status placed = options_.place_object(step.object); !placed.ok()) {
      return placed.WithContext("step " + std::to_string(step.index));
    }
  }
  object_placed_ = step.object;
  return Status::Ok();
}

DeviceFaultPolicy ReadDeviceFaultPolicy(const RigFile& file) {
  DeviceFaultPolicy policy;
  const std::optional<ConfigNode> node = file.Section("device_faults");
  if (!node) return policy;
  node->Optional("retries", &policy.retries);
  node->Optional("retry_delay_ms", &policy.retry_delay_ms);
  for (const auto& [key, problem] : policy.Problems()) node->AddError(key, problem);
  return policy;
}

std::vector<std::pair<std::string, std::string>> DeviceFaultPolicy::Problems() const {
  std::vector<std::pair<std::string, std::string>> problems;
  if (retries < 0 || retries > 100) problems.emplace_back("retries", "must be in [0, 100]");
  if (!(retry_delay_ms >= 0 && retry_delay_ms <= 600000)) problems.emplace_back("retry_delay_ms", "must be in [0, 600000] ms");
  return problems;
}

Status SequencerOptions::Check() const {
  std::vector<std::string> problems;
  if (max_retries < 0) problems.push_back("max_retries must be ≥ 0");
  for (const auto& [key, problem] : device_faults.Problems()) problems.push_back("device_faults." + key + " " + problem);
  if (!(black_level_dn >= 0 && std::isfinite(black_level_dn))) problems.push_back("black_level_dn must be ≥ 0 and finite");
  if (!(noise_floor_dn >= 0 && std::isfinite(noise_floor_dn))) problems.push_back("noise_floor_dn must be ≥ 0 and finite");
  if (!(noise_floor_sigmas > 0 && std::isfinite(noise_floor_sigmas))) {
    problems.push_back("noise_floor_sigmas must be > 0 and finite");
  }
  if (!(saturation_margin_dn >= 0 && std::isfinite(saturation_margin_dn))) {
    problems.push_back("saturation_margin_dn must be ≥ 0 and finite");
  }
  // A bracket needs exposures that grow: a factor of 1 or less would repeat one forever.
  if (!(exposure_factor > 1 && std::isfinite(exposure_factor))) problems.push_back("exposure_factor must be > 1 and finite");
  if (phase_steps < 1) problems.push_back("phase_steps must be ≥ 1 (the patterns' shift is k / phase_steps)");
  if (!(light_drift_warn_percent > 0 && std::isfinite(light_drift_warn_percent))) {
    problems.push_back("light_drift_warn_percent must be > 0 and finite");
  }
  return ProblemsStatus("SequencerOptions", problems);
}

Status Sequencer::Run(const std::function<void(const ScanProgress&)>& progress) {
  LOOM_RETURN_IF_ERROR(options_.Check());
  LOOM_RETURN_IF_ERROR(rig_.OpenAndConfigure());
  for (const auto& camera : rig_.cameras()) scan_regions_[camera->name()] = camera->settings().roi;
  LOOM_RETURN_IF_ERROR(rig_.StartAll());
  const Clock::time_point start = Clock::now();
  const int already = store_.steps_done();
  int done_now = 0;
  for (const scan::Step& step : plan_.steps) {
    if (store_.StepDone(step.index)) {
      // A resumed scan reads its stored dark frames again: the brackets to come depend on them;
      // and its drift references, which the next ones are compared with.
      if (step.kind == scan::StepKind::kDark) LOOM_RETURN_IF_ERROR(MeasureDark(step));
      if (step.kind == scan::StepKind::kDriftReference) LOOM_RETURN_IF_ERROR(MeasureDrift(step));
      continue;
    }
    if (InterruptRequested()) return CancelledError("scan", "interrupted before step " + std::to_string(step.index));
    LOOM_RETURN_IF_ERROR(PlaceObject(step));
    LOOM_RETURN_IF_ERROR(CaptureStep(step));
    ++done_now;
    if (progress) {
      ScanProgress p;
      p.steps_done = already + done_now;
      p.steps_total = static_cast<int>(plan_.steps.size());
      p.frames_stored = static_cast<int>(store_.records().size());
      p.elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
      p.eta_s = p.elapsed_s / done_now * (p.steps_total - p.steps_done);
      progress(p);
    }
  }
  return rig_.MakeSafe();
}

}  // namespace loom::acquisition
