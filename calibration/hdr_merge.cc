#include "calibration/hdr_merge.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace loom::calibration {
namespace {

std::string FrameName(const scan::RawFrame& frame) {
  return "frame " + std::to_string(frame.metadata.frame_id) + " of camera '" + frame.metadata.camera + "'";
}

Status CheckBracket(const std::vector<scan::RawFrame>& bracket) {
  if (bracket.empty()) return InvalidArgumentError("HDR merge", "an empty bracket");
  for (const scan::RawFrame& frame : bracket) {
    if (frame.width != bracket[0].width || frame.height != bracket[0].height ||
        frame.pixels.size() != static_cast<size_t>(frame.width) * frame.height) {
      return InvalidArgumentError(FrameName(frame), "is " + std::to_string(frame.width) + "x" + std::to_string(frame.height) +
                                                        ", the bracket's first frame " + std::to_string(bracket[0].width) + "x" +
                                                        std::to_string(bracket[0].height));
    }
    if (!(frame.metadata.exposure_us > 0)) return InvalidArgumentError(FrameName(frame), "has no positive exposure time");
  }
  return Status::Ok();
}

struct Reading {
  double signal_dn;  // above black
  double exposure_us;
};

// One pixel: the inverse-variance mean of the readings that count, and its sigma. Which readings
// count is decided on a first estimate, not on each reading's own value: keeping a reading
// because it came out above the floor (or below saturation) would keep its upward (downward)
// noise, a bias of percents near the limits.
std::pair<double, double> MergePixel(const std::vector<Reading>& readings, const SensorNoise& sensor) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (readings.empty()) return {kNaN, kNaN};
  const double full_scale = sensor.saturation_dn - sensor.black_dn;
  const double floor = sensor.floor_sigmas * sensor.read_noise_dn;
  // First estimate: the longest exposure well clear of saturation (else the shortest).
  const Reading* first = nullptr;
  const Reading* longest = nullptr;
  for (const Reading& r : readings) {
    if (longest == nullptr || r.exposure_us > longest->exposure_us) longest = &r;
    if (r.signal_dn < 0.8 * full_scale && (first == nullptr || r.exposure_us > first->exposure_us)) first = &r;
  }
  if (first == nullptr) {
    for (const Reading& r : readings) {
      if (first == nullptr || r.exposure_us < first->exposure_us) first = &r;
    }
  }
  const double estimate = std::max(first->signal_dn / first->exposure_us, 0.0);
  const double read_var = sensor.read_noise_dn * sensor.read_noise_dn;
  double weighted = 0;
  double weights = 0;
  for (const Reading& r : readings) {
    const double expected = estimate * r.exposure_us;
    const bool too_weak = expected < floor && &r != longest;  // the longest reading measures the dark
    const bool too_close_to_saturation = expected > 0.9 * full_scale && &r != first;
    if (too_weak || too_close_to_saturation) continue;
    const double t = r.exposure_us;
    const double variance = (expected / sensor.electrons_per_dn + read_var) / (t * t);
    weighted += r.signal_dn / t / variance;
    weights += 1 / variance;
  }
  return {weighted / weights, std::sqrt(1 / weights)};
}

}  // namespace

Result<HdrImage> MergeBracket(const std::vector<scan::RawFrame>& bracket, const SensorNoise& sensor) {
  LOOM_RETURN_IF_ERROR(CheckBracket(bracket));
  const int width = bracket[0].width;
  const int height = bracket[0].height;
  HdrImage hdr{Image(width, height, {"L", "L.sigma"}), 0};
  std::vector<Reading> readings;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      readings.clear();
      for (const scan::RawFrame& frame : bracket) {
        const double value = frame.at(y, x);
        if (value >= sensor.saturation_dn) continue;
        readings.push_back({value - sensor.black_dn, frame.metadata.exposure_us});
      }
      const auto [radiance, sigma] = MergePixel(readings, sensor);
      hdr.saturated_pixels += std::isnan(radiance);
      hdr.image.at(0, y, x) = static_cast<float>(radiance);
      hdr.image.at(1, y, x) = static_cast<float>(sigma);
    }
  }
  return hdr;
}

namespace {

// Each pixel's reading averaged with its neighbours (5 × 5, clipped at the edges): what the
// linearity check selects pixels by. Selecting on a pixel's own readings would keep those whose
// noise went one way: near saturation, a bias of tenths of a percent.
std::vector<double> LocalMean(const scan::RawFrame& frame, double black) {
  constexpr int kRadius = 2;
  std::vector<double> mean(frame.pixels.size());
  for (int y = 0; y < frame.height; ++y) {
    for (int x = 0; x < frame.width; ++x) {
      double sum = 0;
      int count = 0;
      for (int v = std::max(0, y - kRadius); v <= std::min(frame.height - 1, y + kRadius); ++v) {
        for (int u = std::max(0, x - kRadius); u <= std::min(frame.width - 1, x + kRadius); ++u) {
          sum += frame.at(v, u) - black;
          ++count;
        }
      }
      mean[static_cast<size_t>(y) * frame.width + x] = sum / count;
    }
  }
  return mean;
}

}  // namespace

Result<Linearity> MeasureLinearity(const std::vector<scan::RawFrame>& bracket, const SensorNoise& sensor,
                                   const std::vector<uint8_t>& mask) {
  LOOM_RETURN_IF_ERROR(CheckBracket(bracket));
  const double low = 10 * sensor.floor_sigmas * sensor.read_noise_dn;
  const double high = 0.9 * (sensor.saturation_dn - sensor.black_dn);
  std::vector<const scan::RawFrame*> frames;
  for (const scan::RawFrame& frame : bracket) frames.push_back(&frame);
  std::sort(frames.begin(), frames.end(), [](auto* a, auto* b) { return a->metadata.exposure_us < b->metadata.exposure_us; });
  Linearity linearity;
  for (size_t i = 0; i + 1 < frames.size(); ++i) {
    const scan::RawFrame& shorter = *frames[i];
    const scan::RawFrame& longer = *frames[i + 1];
    const double gain = longer.metadata.exposure_us / shorter.metadata.exposure_us;
    const std::vector<double> expected = LocalMean(shorter, sensor.black_dn);
    double sum_short = 0, sum_long = 0;
    int pixels = 0;
    for (size_t p = 0; p < shorter.pixels.size(); ++p) {
      if ((!mask.empty() && mask[p] == 0) || expected[p] < low || expected[p] * gain > high) continue;
      if (longer.pixels[p] >= sensor.saturation_dn) continue;  // clipped: where the neighbourhood misleads (an edge)
      sum_short += shorter.pixels[p] - sensor.black_dn;
      sum_long += longer.pixels[p] - sensor.black_dn;
      ++pixels;
    }
    if (pixels == 0) continue;
    const double ratio = (sum_long / longer.metadata.exposure_us) / (sum_short / shorter.metadata.exposure_us);
    linearity.deviation = std::max(linearity.deviation, std::abs(ratio - 1));
    linearity.max_dn = std::max(linearity.max_dn, sum_long / pixels);
    ++linearity.pairs;
  }
  return linearity;
}

}  // namespace loom::calibration
