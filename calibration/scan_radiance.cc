#include "calibration/scan_radiance.h"

#include <cmath>
#include <limits>

#include "calibration/hdr_merge.h"

namespace loom::calibration {

using acquisition::FrameRecord;
using acquisition::Step;
using acquisition::StepKind;

Result<ScanRadiance> ScanRadiance::Open(const acquisition::CaptureStore& store, const RigModel& rig) {
  ScanRadiance scan(store, rig);
  for (const Step& step : store.info().plan.steps) {
    for (const std::string& camera : step.cameras) {
      if (rig.FindCamera(camera) == nullptr) {
        return NotFoundError("scan " + store.directory().string(),
                             "step " + std::to_string(step.index) + " uses camera '" + camera + "', which rig '" + rig.name +
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
      LOOM_ASSIGN_OR_RETURN(const hal::RawFrame dark, store.ReadFrame(*bracket->second.front()));
      scan.dark_[camera] = acquisition::MeasureDarkLevel(dark);
    }
    break;
  }
  return scan;
}

std::string ScanRadiance::Where(int step, const std::string& camera) const {
  return "scan " + store_->directory().string() + ", step " + std::to_string(step) + ", camera '" + camera + "'";
}

Result<RadianceView> ScanRadiance::View(int step, const std::string& camera_name) const {
  if (!store_->StepDone(step)) {
    return FailedPreconditionError(Where(step, camera_name), "the step was not captured to the end (resume the scan: loom scan --resume)");
  }
  const auto bracket = brackets_.find({step, camera_name});
  if (bracket == brackets_.end()) return NotFoundError(Where(step, camera_name), "no frames recorded");
  const CameraModel& camera = *rig_->FindCamera(camera_name);
  std::vector<hal::RawFrame> frames;
  for (const FrameRecord* record : bracket->second) {
    LOOM_ASSIGN_OR_RETURN(hal::RawFrame frame, store_->ReadFrame(*record));
    if (frame.width != camera.width || frame.height != camera.height) {
      return InvalidArgumentError(store_->directory().string() + "/" + record->file,
                                  "is " + std::to_string(frame.width) + "x" + std::to_string(frame.height) + ", camera '" +
                                      camera_name + "' is " + std::to_string(camera.width) + "x" + std::to_string(camera.height));
    }
    frames.push_back(std::move(frame));
  }
  const SensorModel& sensor = camera.sensor;
  const double gain = std::pow(10.0, frames.front().metadata.gain / 20);
  calibration::SensorNoise noise;
  const auto dark = dark_.find(camera_name);
  noise.black_dn = dark != dark_.end() ? dark->second.black_dn : sensor.dark_offset_dn;
  noise.read_noise_dn = dark != dark_.end() ? dark->second.noise_dn : sensor.read_noise_e / sensor.ElectronsPerDn();
  noise.electrons_per_dn = sensor.ElectronsPerDn() / gain;
  noise.saturation_dn = (1 << sensor.adc_bits) - 1;
  Result<calibration::HdrImage> merged = calibration::MergeBracket(frames, noise);
  if (!merged.ok()) {
    return Status(merged.status().code(), Where(step, camera_name), merged.status().subject() + ": " + merged.status().message());
  }
  RadianceView view;
  view.camera = static_cast<int>(&camera - rig_->cameras.data());
  view.state = frames.front().metadata.rig_state;
  view.saturated_pixels = merged->saturated_pixels;
  view.radiance = Image(camera.width, camera.height, {"L"});
  const double scale = noise.electrons_per_dn / (sensor.sensitivity * 1e-6);
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      view.radiance.at(0, y, x) =
          static_cast<float>(merged->image.at(0, y, x) * scale / sensor.RelativeResponse(x, y, camera.width, camera.height));
    }
  }
  return view;
}

}  // namespace loom::calibration
