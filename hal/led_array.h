#pragma once
// LedArray: the controller of the rig's point lights (29 white LEDs on the hemisphere).
//
// | setting          | unit | notes                                                   |
// |------------------|------|---------------------------------------------------------|
// | current_limit_ma | mA   | no LED is driven above this; adjusted to the controller |
//
// Drive() lights exactly the given LEDs (all others off). A controller fault (over-temperature)
// switches every LED off and is reported by Drive() and Read() as an error naming the device.
// A controller may also have the rig's camera trigger output (FireTrigger()): one pulse on the
// line wired to every camera's trigger input, so that the cameras expose together.

#include <span>
#include <vector>

#include "hal/device.h"
#include "scan/rig_state.h"

namespace loom::hal {

struct LedArraySettings {
  double current_limit_ma = 1000.0;
};

struct LedArrayReadback {
  std::vector<double> current_ma;  // per LED, 0 = off
  double temperature_c = 0;
  bool over_temperature = false;
};

class LedArray : public Device {
 public:
  LedArray(std::string name, std::string backend, std::string address)
      : Device("LED array", std::move(name), std::move(backend), std::move(address)) {}

  int led_count() const { return led_count_; }               // after Open()
  double max_current_ma() const { return max_current_ma_; }  // after Open()
  const LedArraySettings& settings() const { return settings_; }

  Result<ConfigureReport> Configure(const LedArraySettings& requested);
  // Running. Lights exactly these LEDs; an index out of range or a current above the limit is
  // InvalidArgument (nothing changes).
  Status Drive(std::span<const scan::LedDrive> leds);
  // Any open state: every LED off.
  Status AllOff();
  // Any open state.
  Result<LedArrayReadback> Read();
  // Running: one pulse on the camera trigger output. Unimplemented where the controller has none.
  Status FireTrigger();

 protected:
  void set_limits(int led_count, double max_current_ma) {
    led_count_ = led_count;
    max_current_ma_ = max_current_ma;
  }
  virtual Status DoConfigure(const LedArraySettings& applied) = 0;
  virtual Status DoDrive(std::span<const scan::LedDrive> leds) = 0;
  virtual Status DoAllOff() = 0;
  virtual Result<LedArrayReadback> DoRead() = 0;
  virtual Status DoFireTrigger() { return Error(StatusCode::kUnimplemented, "this controller has no camera trigger output"); }
  Status DoMakeSafe() override { return DoAllOff(); }

 private:
  int led_count_ = 0;
  double max_current_ma_ = 0;
  LedArraySettings settings_;
};

}  // namespace loom::hal
