#pragma once
// Motion devices: the turntable, the linear light's carriage and the filter wheels. Moves block
// until the device reports it is in position, the move times out (Timeout error naming the
// device; the motion is stopped), the device reports a fault (an error with its code), or the
// user interrupts (Cancelled; the motion is stopped).
//
// | device      | settings                                  | position unit          |
// |-------------|-------------------------------------------|------------------------|
// | Turntable   | speed_deg_s, move_timeout_ms              | degrees, [0, 360)      |
// | LinearLight | speed_mm_s, move_timeout_ms               | mm along the travel    |
// | FilterWheel | move_timeout_ms                           | slot, 0 .. slots − 1   |

#include <string>

#include "hal/device.h"

namespace loom::hal {

struct TurntableSettings {
  double speed_deg_s = 30.0;
  int move_timeout_ms = 30000;
};

class Turntable : public Device {
 public:
  Turntable(std::string name, std::string backend, std::string address)
      : Device("turntable", std::move(name), std::move(backend), std::move(address)) {}

  const TurntableSettings& settings() const { return settings_; }
  double max_speed_deg_s() const { return max_speed_deg_s_; }  // after Open()

  Result<ConfigureReport> Configure(const TurntableSettings& requested);
  Status Home();                    // running
  Status MoveTo(double angle_deg);  // running; any angle, reduced to [0, 360)
  Result<double> Angle();           // any open state

 protected:
  void set_max_speed(double max_speed_deg_s) { max_speed_deg_s_ = max_speed_deg_s; }
  virtual Status DoConfigure(const TurntableSettings& applied) = 0;
  virtual Status DoHome() = 0;
  virtual Status DoMoveTo(double angle_deg) = 0;
  virtual Result<double> DoAngle() = 0;

 private:
  TurntableSettings settings_;
  double max_speed_deg_s_ = 0;
};

struct LinearLightSettings {
  double speed_mm_s = 50.0;
  int move_timeout_ms = 30000;
};

struct LinearLightReadback {
  double position_mm = 0;
  bool on = false;
  double intensity = 0;  // 0..1
};

class LinearLight : public Device {
 public:
  LinearLight(std::string name, std::string backend, std::string address)
      : Device("linear light", std::move(name), std::move(backend), std::move(address)) {}

  const LinearLightSettings& settings() const { return settings_; }
  double travel_mm() const { return travel_mm_; }            // after Open()
  double max_speed_mm_s() const { return max_speed_mm_s_; }  // after Open()

  Result<ConfigureReport> Configure(const LinearLightSettings& requested);
  Status Home();                               // running
  Status MoveTo(double position_mm);           // running; within [0, travel_mm]
  Status SetStrip(bool on, double intensity);  // running; intensity in [0, 1]
  Result<LinearLightReadback> Read();          // any open state

 protected:
  void set_limits(double travel_mm, double max_speed_mm_s) {
    travel_mm_ = travel_mm;
    max_speed_mm_s_ = max_speed_mm_s;
  }
  virtual Status DoConfigure(const LinearLightSettings& applied) = 0;
  virtual Status DoHome() = 0;
  virtual Status DoMoveTo(double position_mm) = 0;
  virtual Status DoSetStrip(bool on, double intensity) = 0;
  virtual Result<LinearLightReadback> DoRead() = 0;

 private:
  LinearLightSettings settings_;
  double travel_mm_ = 0;
  double max_speed_mm_s_ = 0;
};

struct FilterWheelSettings {
  int move_timeout_ms = 5000;
};

class FilterWheel : public Device {
 public:
  FilterWheel(std::string name, std::string backend, std::string address)
      : Device("filter wheel", std::move(name), std::move(backend), std::move(address)) {}

  const FilterWheelSettings& settings() const { return settings_; }
  int slot_count() const { return slot_count_; }  // after Open()

  Result<ConfigureReport> Configure(const FilterWheelSettings& requested);
  Status MoveTo(int slot);  // running; 0 .. slot_count − 1
  Result<int> Position();   // any open state

 protected:
  void set_slot_count(int slot_count) { slot_count_ = slot_count; }
  virtual Status DoConfigure(const FilterWheelSettings& applied) = 0;
  virtual Status DoMoveTo(int slot) = 0;
  virtual Result<int> DoPosition() = 0;

 private:
  FilterWheelSettings settings_;
  int slot_count_ = 0;
};

}  // namespace loom::hal
