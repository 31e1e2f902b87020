#include "scan/light_drift.h"

#include <algorithm>
#include <cmath>

namespace loom::scan {
namespace {

// A pixel this many dark-noise deviations above black is lit; this close to full scale, saturated.
constexpr double kLitSigmas = 20;
constexpr double kSaturationMarginDn = 2;

double SumAbove(const RawFrame& frame, double black, const std::vector<bool>& lit) {
  double sum = 0;
  for (size_t i = 0; i < frame.pixels.size(); ++i) {
    if (lit[i]) sum += frame.pixels[i] - black;
  }
  return sum;
}

}  // namespace

Result<double> LightDriftTrack::Add(int step, double turntable_deg, const std::vector<RawFrame>& frames,
                                    const std::map<std::string, DarkLevel>& dark) {
  const std::string where = "drift reference (step " + std::to_string(step) + ")";
  const bool new_angle = references_.empty() || turntable_deg != angle_;
  if (new_angle) {
    baselines_.clear();
    angle_ = turntable_deg;
    factor_at_angle_ = references_.empty() ? 1.0 : references_.back().second;
  }
  double ratio_sum = 0;
  int ratios = 0;
  for (const RawFrame& frame : frames) {
    const std::string& camera = frame.metadata.camera;
    const auto level = dark.find(camera);
    const DarkLevel black = level == dark.end() ? DarkLevel{} : level->second;
    auto [it, first] = baselines_.try_emplace(camera);
    Baseline& baseline = it->second;
    if (first) {
      const double top = (1 << BitDepth(frame.metadata.pixel_format)) - 1 - kSaturationMarginDn;
      const double floor = black.black_dn + kLitSigmas * std::max(1.0, black.noise_dn);
      baseline.width = frame.width;
      baseline.height = frame.height;
      baseline.lit.resize(frame.pixels.size());
      for (size_t i = 0; i < frame.pixels.size(); ++i) baseline.lit[i] = frame.pixels[i] > floor && frame.pixels[i] < top;
      baseline.signal = SumAbove(frame, black.black_dn, baseline.lit);
      if (!(baseline.signal > 0)) {
        return FailedPreconditionError(where, "camera '" + camera + "' sees no lit, unsaturated pixel to measure drift on");
      }
      continue;
    }
    if (frame.width != baseline.width || frame.height != baseline.height) {
      return DataLossError(where, "camera '" + camera + "': frame size differs from the first reference's");
    }
    ratio_sum += SumAbove(frame, black.black_dn, baseline.lit) / baseline.signal;
    ++ratios;
  }
  const double factor = ratios == 0 ? factor_at_angle_ : factor_at_angle_ * ratio_sum / ratios;
  references_.emplace_back(step, factor);
  return factor;
}

double LightDriftTrack::FactorAt(int step) const {
  if (references_.empty()) return 1;
  if (step <= references_.front().first) return references_.front().second;
  if (step >= references_.back().first) return references_.back().second;
  const auto after = std::lower_bound(references_.begin(), references_.end(), step,
                                      [](const std::pair<int, double>& r, int s) { return r.first < s; });
  const auto before = after - 1;
  const double t = static_cast<double>(step - before->first) / (after->first - before->first);
  return before->second + t * (after->second - before->second);
}

double LightDriftTrack::MaxDriftPercentOf(const std::vector<std::pair<int, double>>& references) {
  double worst = 0;
  for (const auto& [step, factor] : references) worst = std::max(worst, std::abs(factor - 1) * 100);
  return worst;
}

}  // namespace loom::scan
