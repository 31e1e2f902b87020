#pragma once
// The `recording` backend: a Projector that shows nothing and remembers every pattern it was
// asked to show, in order (name and a checksum of the pixels) — for tests of plans and
// sequencers, and for dry runs of a rig without a projector. With the rig YAML key
// `log: PATH` it also appends one line per pattern to that file ("show NAME CHECKSUM" /
// "blank"), so a test in another process can check the order.

#include <cstdint>
#include <string>
#include <vector>

#include "hal/projector.h"
#include "hal/registry.h"

namespace loom::hal {

struct RecordedPattern {
  std::string name;       // empty for a blank screen
  uint64_t checksum = 0;  // FNV-1a of the pixels
};

class RecordingProjector : public Projector {
 public:
  RecordingProjector(std::string name, int width, int height, std::string log_path);

  const std::vector<RecordedPattern>& history() const { return history_; }

 protected:
  Result<DeviceIdentity> DoOpen() override;
  Status DoConfigure(const ProjectorSettings&) override { return Status::Ok(); }
  Status DoStart() override { return Status::Ok(); }
  Status DoStop() override { return Status::Ok(); }
  Status DoClose() override { return Status::Ok(); }
  Status DoShow(const scan::Pattern& pattern) override;
  Status DoBlank() override;

 private:
  Status Append(const RecordedPattern& entry);

  int width_;
  int height_;
  std::string log_path_;
  std::vector<RecordedPattern> history_;
};

uint64_t PatternChecksum(const scan::Pattern& pattern);

void RegisterRecordingBackend(BackendRegistry& registry);

}  // namespace loom::hal
