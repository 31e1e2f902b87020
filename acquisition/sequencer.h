#pragma once
// Sequencer: runs a plan on a rig into a capture store. For every step it sets the rig (turntable,
// filter wheel, LEDs, linear light, projector pattern), triggers the step's cameras together and
// brackets the exposure: starting from the plan's probe, it adds shorter exposures while pixels
// saturate at the shortest and longer ones while lit pixels stay under the noise floor at the
// longest, up to the plan's bound — so that every lit pixel is recorded unsaturated and above
// the noise floor at least once. Raw frames are stored; merging is calibration's job. Black level
// and noise floor come from the plan's dark step (each camera's median and robust spread with
// the lights off); a plan without one falls back to the options' values.
//
// Triggering: cameras set to `trigger: hardware` in the rig YAML expose on one pulse of the rig's
// trigger source (hal/rig.h) after the rig has settled, the others on a software trigger each
// (free-run cameras are switched to software: they would expose while the rig changes).
//
// Drift: a drift reference step (plan.h) is one exposure of every camera; the lights' output
// relative to the first reference (scan/light_drift.h) is logged, with a warning when it is
// further than the options' threshold. Reconstruction corrects for it.
//
// Settling: after changing devices for a step the sequencer waits, on the rig's clock, the
// longest settle time (and a light's warm-up the first time it comes on) the rig YAML gives what
// changed (hal/rig.h); each frame records how long the rig had been still (RigState::settled_ms).
//
// Resume: steps marked done are skipped; in an unfinished step, frames already stored are read
// back instead of captured, so the bracket takes the same decisions and the scan ends identical
// to an uninterrupted one. A camera that fails (timeout, dropped out) is retried, then the scan
// stops with an error naming it and the step; Ctrl-C stops between frames. Either way the
// caller's SafeStateGuard leaves the rig safe, and the store holds only complete frames.

#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/rig_file.h"
#include "hal/rig.h"
#include "scan/capture_store.h"
#include "scan/dark_level.h"
#include "scan/light_drift.h"
#include "scan/plan.h"

namespace loom::acquisition {

// What a scan does when a device other than a camera (turntable, filter wheel, LED or strip
// controller, projector) times out or is unavailable: the step's settings are applied again,
// `retries` times, each after `retry_delay_ms` on the rig's clock; any other error, or a fault
// that outlasts the retries, stops the scan with an error naming the device and the step (the
// scan resumes from there). The rig YAML's `device_faults: {retries: 2, retry_delay_ms: 500}`.
struct DeviceFaultPolicy {
  int retries = 2;
  double retry_delay_ms = 500;
  // (key, what it must be) for each value out of range.
  std::vector<std::pair<std::string, std::string>> Problems() const;
};
// The rig file's `device_faults:`, or the defaults; problems are recorded in its document.
DeviceFaultPolicy ReadDeviceFaultPolicy(const RigFile& file);

struct SequencerOptions {
  int max_retries = 2;  // per camera capture, after a timeout or drop-out
  DeviceFaultPolicy device_faults;
  double black_level_dn = 64;           // without a dark step: the cameras' dark offset (in their bit depth)
  double noise_floor_dn = 24;           // without a dark step: above black, a weaker reading is too noisy
  double noise_floor_sigmas = 10;       // with a dark step: the floor in dark-frame standard deviations
  double saturation_margin_dn = 1;      // within this of the top a reading is saturated
  double exposure_factor = 4;           // between bracket exposures
  int phase_steps = 4;                  // of the structured-light phase patterns
  double light_drift_warn_percent = 1;  // a drift reference further from the first warns (rig YAML's light_drift)
  // Called before the first step run and whenever a step needs another object on the turntable
  // than the one before (steps needing none, ScanObject::kNothing, do not count): an operator is
  // asked to place it, a simulated rig swaps its scene. An error stops the scan before that step.
  std::function<Status(scan::ScanObject object)> place_object;
  Status Check() const;  // every problem, naming the field (NaN fails every check)
};

struct ScanProgress {
  int steps_done = 0;
  int steps_total = 0;
  int frames_stored = 0;
  double elapsed_s = 0;
  double eta_s = 0;
};

class Sequencer {
 public:
  Sequencer(hal::Rig& rig, const scan::Plan& plan, scan::CaptureStore& store, SequencerOptions options = {});
  // Brings the rig up (open, configure, start) and runs every step not yet done.
  Status Run(const std::function<void(const ScanProgress&)>& progress = nullptr);
  // Each camera's dark level from the plan's dark step (empty before it, or without one).
  const std::map<std::string, scan::DarkLevel>& dark_levels() const { return dark_; }

 private:
  Status PlaceObject(const scan::Step& step);
  // Sets the rig as `step` has it and waits until what changed has settled.
  Status ApplyStep(const scan::Step& step);
  // After `failed` (`where`: what was being done, e.g. "at step 3") on try `attempt` (0-based):
  // Ok once the policy's delay has passed when a retry is due (a device's timeout or absence,
  // retries left; logged as a warning); else the error to stop with — `failed` itself, or it
  // naming the attempts when they ran out (SequencerOptions::device_faults).
  Status RetryAfterDeviceFault(const Status& failed, const std::string& where, int attempt);
  // ApplyStep, again after a device's timeout (SequencerOptions::device_faults).
  Status ApplyStepWithRetries(const scan::Step& step);
  // The rig's state for a capture; after a device's timeout while reading it, the step set again
  // and the state read again (device_faults).
  Result<scan::RigState> ReadStateWithRetries(const scan::Step& step);
  Status MoveWheel(hal::FilterWheel& wheel, int slot);
  Status DriveLeds(const scan::Step& step);
  Status SetLinearLight(const scan::Step& step);
  // `device` changed now: the rig settles no sooner than its settle time (its warm-up instead,
  // when `switched_on` is its first switching on in this run) from now.
  void Changed(const hal::Device& device, bool switched_on = false);
  Status WaitUntilSettled();
  // Since the last change, on the rig's clock.
  double SettledMs() const;
  // Every filter wheel to the slot the plan last gave it before `step` (slot 0 when none has):
  // what an uninterrupted scan would have it in, whatever a killed process left.
  Status PlaceWheels(const scan::Step& step);
  Status CaptureStep(const scan::Step& step);
  // A dark step's one exposure (no bracket), captured or read back from the store: sets the
  // cameras' black levels and noise floors.
  Status MeasureDark(const scan::Step& step);
  // A drift reference's one exposure, captured or read back: the lights' drift so far, with a
  // warning beyond the options' threshold.
  Status MeasureDrift(const scan::Step& step);
  // Black level and, above it, the weakest usable reading of `camera`.
  std::pair<double, double> BlackAndFloor(const std::string& camera) const;
  // One frame of every camera of `step` at `exposure_us`: read back when stored, else captured.
  Result<std::vector<scan::RawFrame>> CaptureExposure(const scan::Step& step, double exposure_us, int exposure_index);
  // The step's linearity series (plan.h), after its bracket: `shortest` is the bracket's
  // shortest exposure and its frames; series frames take indices from `next_index` on.
  Status CaptureLinearitySeries(const scan::Step& step, double shortest_us, const std::vector<scan::RawFrame>& shortest,
                                int next_index, double min_us, double max_us);
  Result<scan::RawFrame> CaptureWithRetries(hal::Camera& camera, const scan::Step& step);
  // The camera at `exposure_us`, reading the step's window for it (Step::windows) or the scan's
  // own region; reconfigured only where either changes.
  Status SetExposureAndWindow(hal::Camera& camera, const scan::Step& step, double exposure_us);
  Result<hal::Camera*> FindCamera(const std::string& name) const;

  hal::Rig& rig_;
  const scan::Plan& plan_;
  scan::CaptureStore& store_;
  SequencerOptions options_;
  std::map<std::string, scan::DarkLevel> dark_;    // by camera
  std::map<std::string, scan::Roi> scan_regions_;  // by camera: as configured when the run began
  scan::LightDrift drift_;
  // What the sequencer knows the strip and projector are doing. Unknown (nullopt) until its first
  // step sets them: a resumed scan finds the rig as a killed process left it (the strip on, a
  // pattern showing, a wheel in a filter).
  std::optional<bool> strip_on_;
  std::optional<bool> projector_showing_;
  bool wheels_placed_ = false;                              // every wheel set where the plan has it at the first step
  std::map<std::string, int> wheel_slots_;                  // as the sequencer last set them
  std::optional<std::vector<scan::LedDrive>> leds_driven_;  // as last driven
  std::optional<double> strip_mm_;                          // where the strip was last moved
  double changed_at_s_ = 0;                                 // rig clock: the last change
  double settled_at_s_ = 0;                                 // rig clock: when everything has settled
  std::set<std::string> warmed_up_;                         // lights switched on in this run
  std::optional<scan::ScanObject> object_placed_;
};

}  // namespace loom::acquisition
