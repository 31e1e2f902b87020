#include "hal/projector.h"

namespace loom::hal {

Result<ConfigureReport> Projector::Configure(const ProjectorSettings& requested) {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kOpen, DeviceState::kConfigured}, "Configure"));
  ConfigureReport report;
  ProjectorSettings applied = requested;
  if (requested.width == 0 && requested.height == 0) {
    applied = {native_width_, native_height_};
  } else if (requested.width != native_width_ || requested.height != native_height_) {
    report.Reject("resolution " + std::to_string(requested.width) + "x" + std::to_string(requested.height) +
                  " differs from the native " + std::to_string(native_width_) + "x" + std::to_string(native_height_) +
                  " (patterns are never rescaled: that would blur the stripes)");
    return report;
  }
  LOOM_RETURN_IF_ERROR(DoConfigure(applied));
  settings_ = applied;
  MarkConfigured();
  return report;
}

Status Projector::Show(const scan::Pattern& pattern) {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kRunning}, "Show"));
  if (pattern.width != settings_.width || pattern.height != settings_.height ||
      pattern.pixels.size() != static_cast<size_t>(pattern.width) * pattern.height) {
    return Error(StatusCode::kInvalidArgument, "pattern '" + pattern.name + "' is " + std::to_string(pattern.width) + "x" +
                                                   std::to_string(pattern.height) + " with " +
                                                   std::to_string(pattern.pixels.size()) + " pixels; the projector shows " +
                                                   std::to_string(settings_.width) + "x" + std::to_string(settings_.height));
  }
  LOOM_RETURN_IF_ERROR(DoShow(pattern));
  current_pattern_ = pattern.name;
  return Status::Ok();
}

Status Projector::Blank() {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kOpen, DeviceState::kConfigured, DeviceState::kRunning}, "Blank"));
  LOOM_RETURN_IF_ERROR(DoBlank());
  current_pattern_.clear();
  return Status::Ok();
}

}  // namespace loom::hal
