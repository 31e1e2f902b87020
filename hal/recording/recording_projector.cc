#include "hal/recording/recording_projector.h"

#include <fstream>

namespace loom::hal {

uint64_t PatternChecksum(const scan::Pattern& pattern) {
  uint64_t hash = 0xcbf29ce484222325ull;
  for (uint8_t value : pattern.pixels) {
    hash ^= value;
    hash *= 0x100000001b3ull;
  }
  return hash;
}

RecordingProjector::RecordingProjector(std::string name, int width, int height, std::string log_path)
    : Projector(std::move(name), "recording", log_path), width_(width), height_(height), log_path_(std::move(log_path)) {}

Result<DeviceIdentity> RecordingProjector::DoOpen() {
  set_native_size(width_, height_);
  return DeviceIdentity{"loom", "recording projector", "", ""};
}

Status RecordingProjector::Append(const RecordedPattern& entry) {
  history_.push_back(entry);
  if (log_path_.empty()) return Status::Ok();
  std::ofstream log(log_path_, std::ios::app);
  if (entry.name.empty()) {
    log << "blank\n";
  } else {
    log << "show " << entry.name << " " << entry.checksum << "\n";
  }
  log.flush();
  return log ? Status::Ok() : Error(StatusCode::kIoError, "cannot append to " + log_path_);
}

Status RecordingProjector::DoShow(const scan::Pattern& pattern) { return Append({pattern.name, PatternChecksum(pattern)}); }

Status RecordingProjector::DoBlank() { return Append({"", 0}); }

void RegisterRecordingBackend(BackendRegistry& registry) {
  registry.Register<Projector>("recording", [](const DeviceConfig& config) -> Result<std::unique_ptr<Projector>> {
    int width = 1920;
    int height = 1080;
    std::string log;
    config.node.Optional("native_width", &width);
    config.node.Optional("native_height", &height);
    config.node.Optional("log", &log);
    return std::unique_ptr<Projector>(std::make_unique<RecordingProjector>(config.name, width, height, log));
  });
}

}  // namespace loom::hal
