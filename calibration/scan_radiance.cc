#include "calibration/scan_radiance.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "core/parallel.h"

namespace loom::calibration {

using scan::FrameRecord;
using scan::Step;
using scan::StepKind;

namespace {

// Where a frame lies on its camera's sensor: the region of interest its metadata names (a
// region of 0 × 0, as frames may carry from before regions were honoured, is the whole sensor).
scan::Roi WindowOf(const scan::RawFrame& frame, const CameraModel& camera) {
  const scan::Roi& roi = frame.metadata.roi;
  return roi.width == 0 && roi.height == 0 ? scan::Roi{0, 0, camera.width, camera.height} : roi;
}

// A frame is the camera's whole sensor or a region of interest inside it, of the region's size.
Status CheckFrameWindow(const scan::RawFrame& frame, const CameraModel& camera, const std::string& file) {
  const scan::Roi roi = WindowOf(frame, camera);
  const bool inside = roi.x >= 0 && roi.y >= 0 && roi.width > 0 && roi.height > 0 && roi.x + roi.width <= camera.width &&
                      roi.y + roi.height <= camera.height;
  if (inside && frame.width == roi.width && frame.height == roi.height) return Status::Ok();
  return InvalidArgumentError(file, "is " + std::to_string(frame.width) + "x" + std::to_string(frame.height) + " with region " +
                                        std::to_string(roi.width) + "x" + std::to_string(roi.height) + "+" +
                                        std::to_string(roi.x) + "+" + std::to_string(roi.y) + ", camera '" + camera.name +
                                        "' is " + std::to_string(camera.width) + "x" + std::to_string(camera.height));
}

}  // namespace

Result<ScanRadiance> ScanRadiance::Open(const scan::CaptureStore& store, const RigModel& rig) {
  ScanRadiance scan(store, rig);
  for (const Step& step : store.info().plan.steps) {
    for (const std::string& camera : step.cameras) {
      if (rig.FindCamera(camera) == nullptr) {
        return NotFoundError("scan " + store.directory().string(), "step " + std::to_string(step.index) + " uses camera '" +
                                                                       camera + "', which rig '" + rig.name +
                                                                       "' does not describe");
      }
    }
  }
  for (const FrameRecord& record : store.records()) scan.brackets_[{record.key.step, record.key.camera}].push_back(&record);
  for (const Step& step : store.info().plan.steps) {
    if (step.kind != StepKind::kDark) continue;
    for (const std::string& camera : step.cameras) {
      const auto bracket = scan.brackets_.find({step.index, camera});
      if (bracket == scan.brackets_.end()) return NotFoundError(scan.Where(step.index, camera), "the dark frame is missing");
      LOOM_ASSIGN_OR_RETURN(const scan::RawFrame dark, store.ReadFrame(*bracket->second.front()));
      scan.dark_[camera] = scan::MeasureDarkLevel(dark);
    }
    break;
  }
  return scan;
}

Result<scan::LightDrift> ScanRadiance::LightDrift() const {
  scan::LightDrift drift;
  for (const Step& step : plan().steps) {
    if (step.kind != StepKind::kDriftReference) continue;
    std::vector<scan::RawFrame> frames;
    for (const std::string& camera : step.cameras) {
      LOOM_ASSIGN_OR_RETURN(std::vector<scan::RawFrame> bracket, Bracket(step.index, camera));
      frames.push_back(std::move(bracket.front()));
    }
    const Result<double> added = drift.Of(step).Add(step.index, step.turntable_deg, frames, dark_);
    if (!added.ok()) return added.status().WithContext("scan " + directory().string());
  }
  return drift;
}

std::string ScanRadiance::Where(int step, const std::string& camera) const {
  return "scan " + store_->directory().string() + ", step " + std::to_string(step) + ", camera '" + camera + "'";
}

Result<std::vector<scan::RawFrame>> ScanRadiance::Bracket(int step, const std::string& camera_name) const {
  if (!store_->StepDone(step)) {
    return FailedPreconditionError(Where(step, camera_name),
                                   "the step was not captured to the end (resume the scan: loom scan --resume)");
  }
  const auto bracket = brackets_.find({step, camera_name});
  if (bracket == brackets_.end()) return NotFoundError(Where(step, camera_name), "no frames recorded");
  const CameraModel& camera = *rig_->FindCamera(camera_name);
  std::vector<scan::RawFrame> frames;
  for (const FrameRecord* record : bracket->second) {
    LOOM_ASSIGN_OR_RETURN(scan::RawFrame frame, store_->ReadFrame(*record));
    const std::string file = store_->directory().string() + "/" + record->file;
    LOOM_RETURN_IF_ERROR(CheckFrameWindow(frame, camera, file));
    if (!frames.empty() && !(WindowOf(frame, camera) == WindowOf(frames.front(), camera))) {
      return InvalidArgumentError(file, "has another region of interest than the bracket's first frame");
    }
    frames.push_back(std::move(frame));
  }
  return frames;
}

SensorNoise ScanRadiance::NoiseOf(const std::string& camera_name, double gain_db) const {
  const SensorModel& sensor = rig_->FindCamera(camera_name)->sensor;
  SensorNoise noise;
  const auto dark = dark_.find(camera_name);
  noise.black_dn = dark != dark_.end() ? dark->second.black_dn : sensor.dark_offset_dn;
  noise.read_noise_dn = dark != dark_.end() ? dark->second.noise_dn : sensor.read_noise_e / sensor.ElectronsPerDn();
  noise.electrons_per_dn = sensor.ElectronsPerDn() / std::pow(10.0, gain_db / 20);
  noise.saturation_dn = (1 << sensor.adc_bits) - 1;
  return noise;
}

Result<RadianceView> ScanRadiance::View(int step, const std::string& camera_name) const {
  LOOM_ASSIGN_OR_RETURN(const std::vector<scan::RawFrame> frames, Bracket(step, camera_name));
  const CameraModel& camera = *rig_->FindCamera(camera_name);
  const SensorModel& sensor = camera.sensor;
  const SensorNoise noise = NoiseOf(camera_name, frames.front().metadata.gain);
  Result<HdrImage> merged = MergeBracket(frames, noise);
  if (!merged.ok()) {
    return Status(merged.status().code(), Where(step, camera_name), merged.status().subject() + ": " + merged.status().message());
  }
  RadianceView view;
  view.camera = static_cast<int>(&camera - rig_->cameras.data());
  view.state = frames.front().metadata.rig_state;
  view.saturated_pixels = merged->saturated_pixels;
  // The whole sensor, NaN (not seen) outside the frames' region of interest, so that every
  // reader projects into the camera as calibrated.
  view.radiance = Image(camera.width, camera.height, {"L"});
  std::fill(view.radiance.channel(0).begin(), view.radiance.channel(0).end(), std::numeric_limits<float>::quiet_NaN());
  const scan::Roi window = WindowOf(frames.front(), camera);
  view.window = window;
  const double scale = noise.electrons_per_dn / (sensor.sensitivity * 1e-6);
  for (int y = 0; y < window.height; ++y) {
    for (int x = 0; x < window.width; ++x) {
      const int sensor_x = window.x + x, sensor_y = window.y + y;
      view.radiance.at(0, sensor_y, sensor_x) = static_cast<float>(
          merged->image.at(0, y, x) * scale / sensor.RelativeResponse(sensor_x, sensor_y, camera.width, camera.height));
    }
  }
  return view;
}

Result<std::vector<RadianceView>> ScanRadiance::Views(const std::vector<scan::ViewId>& ids) const {
  std::vector<std::optional<Result<RadianceView>>> read(ids.size());
  ParallelFor(static_cast<int>(ids.size()), 0, [&](int k) { read[k] = View(ids[k].step, ids[k].camera); });
  std::vector<RadianceView> views;
  for (std::optional<Result<RadianceView>>& view : read) {
    LOOM_ASSIGN_OR_RETURN(RadianceView merged, std::move(*view));
    views.push_back(std::move(merged));
  }
  return views;
}

Result<std::vector<LitView>> ScanRadiance::LitViews(StepKind kind) const {
  std::vector<scan::ViewId> ids;
  for (const Step& step : plan().steps) {
    if (step.kind != kind) continue;
    for (const std::string& camera : step.cameras) ids.push_back({step.index, camera});
  }
  LOOM_ASSIGN_OR_RETURN(std::vector<RadianceView> read, Views(ids));
  std::vector<LitView> views;
  for (size_t k = 0; k < ids.size(); ++k) {
    RadianceView& view = read[k];
    const std::string source = Where(ids[k].step, ids[k].camera) + " (" + std::string(StepKindName(kind)) + ")";
    LOOM_ASSIGN_OR_RETURN(LightingState lighting, LightingOf(*rig_, view.state, source));
    views.push_back({view.camera, std::move(lighting), std::move(view.radiance), source, ids[k].step, view.window});
  }
  return views;
}

SeenPixels SeenPixelsOf(const LitView& view) {
  const scan::Roi& w = view.window;
  if (w.width == 0 || w.height == 0) return {0, 0, view.radiance.width(), view.radiance.height()};
  return {std::max(0, w.x), std::max(0, w.y), std::min(view.radiance.width(), w.x + w.width),
          std::min(view.radiance.height(), w.y + w.height)};
}

// The lights of a view as the rig model names them; only the wheels in front of lit LEDs count.
Result<LightingState> LightingOf(const RigModel& rig, const scan::RigState& state, const std::string& where) {
  LightingState lighting;
  lighting.turntable_deg = state.turntable_deg;
  for (const scan::LedDrive& led : state.leds_on) {
    lighting.leds.emplace_back(led.led, led.current_ma);
    for (size_t w = 0; w < rig.filter_wheels.size(); ++w) {
      const FilterWheelModel& wheel = rig.filter_wheels[w];
      if (wheel.led != led.led) continue;
      const auto slot = state.filter_slots.find(wheel.name);
      if (slot == state.filter_slots.end()) {
        return NotFoundError(where, "LED " + std::to_string(led.led) + " is lit but the position of its filter wheel '" +
                                        wheel.name + "' was not recorded");
      }
      lighting.filter_slots[static_cast<int>(w)] = slot->second;
    }
  }
  lighting.linear_light_on = state.linear_light_on;
  lighting.linear_light_mm = state.linear_light_mm;
  lighting.linear_light_intensity = state.linear_light_intensity;
  return lighting;
}

}  // namespace loom::calibration
