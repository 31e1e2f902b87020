#pragma once
// Projector: the structured-light projector, an HDMI display showing 8-bit grey patterns.
//
// | setting | unit   | notes                                        |
// |---------|--------|----------------------------------------------|
// | width   | pixels | must equal the projector's native resolution |
// | height  | pixels |                                              |

#include <cstdint>
#include <string>
#include <vector>

#include "hal/device.h"
#include "scan/pattern.h"

namespace loom::hal {

struct ProjectorSettings {
  int width = 0;
  int height = 0;
};

class Projector : public Device {
 public:
  Projector(std::string name, std::string backend, std::string address)
      : Device("projector", std::move(name), std::move(backend), std::move(address)) {}

  const ProjectorSettings& settings() const { return settings_; }
  int native_width() const { return native_width_; }    // after Open()
  int native_height() const { return native_height_; }  // after Open()
  // Name of the pattern on screen, empty when blank.
  const std::string& current_pattern() const { return current_pattern_; }

  Result<ConfigureReport> Configure(const ProjectorSettings& requested);
  // Running. The pattern must have the configured size.
  Status Show(const scan::Pattern& pattern);
  // Any open state: all black.
  Status Blank();

 protected:
  void set_native_size(int width, int height) {
    native_width_ = width;
    native_height_ = height;
  }
  virtual Status DoConfigure(const ProjectorSettings& applied) = 0;
  virtual Status DoShow(const scan::Pattern& pattern) = 0;
  virtual Status DoBlank() = 0;
  Status DoMakeSafe() override { return Blank(); }

 private:
  ProjectorSettings settings_;
  int native_width_ = 0;
  int native_height_ = 0;
  std::string current_pattern_;
};

}  // namespace loom::hal
