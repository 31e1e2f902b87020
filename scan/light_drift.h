#pragma once
// The lights' drift through a scan, from its drift references (plan.h): the same LED, the same
// exposure, every camera, repeated through the scan. A reference's light relative to the first
// reference at the same turntable angle is the ratio of their sums above black over the pixels
// that were lit and unsaturated in that first one (thousands of pixels: the sensor noise
// averages out); the two references on either side of a turntable move, taken moments apart,
// carry the chain from one angle to the next. Cameras are averaged.
//
// The correction assumes that every LED drifts as the reference LED does (they share a driver
// and a heat sink). The linear light has its own references in a plan that sweeps it (the strip
// alone at the middle of its travel, right after each LED reference), and its own track.

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/status.h"
#include "scan/dark_level.h"
#include "scan/frame.h"
#include "scan/plan.h"

namespace loom::scan {

class LightDriftTrack {
 public:
  // Adds a reference step's frames (one per camera), in capture order; returns the light's output
  // there relative to the scan's first reference. An error names the step when a camera has no
  // lit, unsaturated pixel to compare, or a frame whose size differs from its first reference's.
  Result<double> Add(int step, double turntable_deg, const std::vector<RawFrame>& frames,
                     const std::map<std::string, DarkLevel>& dark);
  // The output at `step`: linear in the step index between references, the nearest reference's
  // outside them, 1 without references.
  double FactorAt(int step) const;
  // (step, output) of every reference so far.
  const std::vector<std::pair<int, double>>& references() const { return references_; }
  // The largest |output − 1| over the references, in percent.
  double MaxDriftPercent() const { return MaxDriftPercentOf(references_); }
  static double MaxDriftPercentOf(const std::vector<std::pair<int, double>>& references);

 private:
  struct Baseline {
    std::vector<bool> lit;  // pixels lit and unsaturated in the first reference at this angle
    double signal = 0;      // their sum above black there
    int width = 0, height = 0;
  };
  std::map<std::string, Baseline> baselines_;  // by camera, at the current angle
  double angle_ = 0;
  double factor_at_angle_ = 1;  // the output when the current angle's baselines were taken
  std::vector<std::pair<int, double>> references_;
};

// The LEDs' and the linear light's drift, each from its own references.
struct LightDrift {
  LightDriftTrack leds;
  LightDriftTrack strip;
  // The track a drift reference, or an observation, belongs to: the strip's when the strip
  // alone lit its step.
  static bool StripLit(const Step& step) { return step.leds.empty() && step.linear_light_mm.has_value(); }
  LightDriftTrack& Of(const Step& step) { return StripLit(step) ? strip : leds; }
  const LightDriftTrack& Of(const Step& step) const { return StripLit(step) ? strip : leds; }
};

}  // namespace loom::scan
