// The HDR merge on brackets from the simulator's sensor model (shot and read noise, dark offset,
// 12-bit quantisation, full-well saturation).
#include "calibration/hdr_merge.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "sim/renderer.h"

namespace loom::calibration {
namespace {

SensorModel TestSensor() {
  SensorModel sensor;  // tac7-mini's
  sensor.sensitivity = 1.3e6;
  sensor.vignetting = 0;
  return sensor;
}

SensorNoise NoiseOf(const SensorModel& sensor) {
  const double e_per_dn = sensor.ElectronsPerDn();
  return {sensor.dark_offset_dn, std::hypot(sensor.read_noise_e / e_per_dn, 1 / std::sqrt(12.0)), e_per_dn,
          static_cast<double>((1 << sensor.adc_bits) - 2), 3};
}

std::vector<scan::RawFrame> Bracket(const Image& radiance, const SensorModel& sensor, const std::vector<double>& exposures_us) {
  std::vector<scan::RawFrame> bracket;
  for (size_t i = 0; i < exposures_us.size(); ++i) {
    scan::RawFrame frame;
    frame.width = radiance.width();
    frame.height = radiance.height();
    frame.pixels = sim::CaptureRaw(radiance, sensor, {exposures_us[i], 0}, 1000 + i);
    frame.metadata.camera = "cam0";
    frame.metadata.exposure_us = exposures_us[i];
    frame.metadata.frame_id = i;
    bracket.push_back(std::move(frame));
  }
  return bracket;
}

// What the merge should give: DN per µs above black.
double TrueDnPerUs(double radiance, const SensorModel& sensor) {
  return radiance * sensor.sensitivity * 1e-6 / sensor.ElectronsPerDn();
}

TEST(HdrMergeTest, LinearWithinHalfAPercentOverTheSensorsRange) {
  // 4.5 decades of radiance, log-spaced, from ~10 DN at the longest exposure to the full well at
  // the shortest: every decade is recorded unsaturated and above the floor by some exposure.
  const SensorModel sensor = TestSensor();
  const int n = 160;
  Image radiance(n, n, {"L"});
  const double low = 10 * sensor.ElectronsPerDn() / (sensor.sensitivity * 12800e-6);
  const double decades = 4.5;
  for (int i = 0; i < n * n; ++i) radiance.data()[i] = static_cast<float>(low * std::pow(10.0, decades * i / (n * n - 1.0)));
  const Result<HdrImage> hdr = MergeBracket(Bracket(radiance, sensor, {50, 200, 800, 3200, 12800}), NoiseOf(sensor));
  ASSERT_TRUE(hdr.ok()) << hdr.status().ToString();
  EXPECT_EQ(hdr->saturated_pixels, 0);
  // Mean of merged / true per half decade: linearity is the mean's deviation from 1.
  const int bins = 9;
  std::vector<double> sum(bins), count(bins), pull(bins);
  for (int i = 0; i < n * n; ++i) {
    const int bin = std::min(bins - 1, static_cast<int>(bins * i / (n * n)));
    const double truth = TrueDnPerUs(radiance.data()[i], sensor);
    sum[bin] += hdr->image.data()[i] / truth;
    pull[bin] += std::pow((hdr->image.data()[i] - truth) / hdr->image.data()[n * n + i], 2);
    count[bin] += 1;
  }
  double worst = 0;
  for (int b = 0; b < bins; ++b) {
    worst = std::max(worst, std::abs(sum[b] / count[b] - 1));
    EXPECT_NEAR(sum[b] / count[b], 1.0, 0.005) << "half decade " << b;
    // The reported sigma is the real spread: the normalised residuals have unit variance.
    EXPECT_NEAR(std::sqrt(pull[b] / count[b]), 1.0, 0.1) << "half decade " << b;
  }
  std::cout << "worst linearity over 4.5 decades: " << 100 * worst << " %\n";
}

TEST(HdrMergeTest, BlackStaysBlackAndAlwaysSaturatedIsUnknown) {
  const SensorModel sensor = TestSensor();
  Image radiance(2, 1, {"L"});
  radiance.at(0, 0, 0) = 0;
  radiance.at(0, 0, 1) = 1e3;  // saturates even the shortest exposure
  const Result<HdrImage> hdr = MergeBracket(Bracket(radiance, sensor, {100, 400}), NoiseOf(sensor));
  ASSERT_TRUE(hdr.ok());
  EXPECT_NEAR(hdr->image.at(0, 0, 0), 0, 3 * hdr->image.at(1, 0, 0));
  EXPECT_TRUE(std::isnan(hdr->image.at(0, 0, 1)));
  EXPECT_EQ(hdr->saturated_pixels, 1);
}

TEST(HdrMergeTest, ABadBracketIsAnErrorNamingTheFrame) {
  const SensorModel sensor = TestSensor();
  Image radiance(4, 4, {"L"});
  std::vector<scan::RawFrame> bracket = Bracket(radiance, sensor, {100, 400});
  EXPECT_FALSE(MergeBracket({}, NoiseOf(sensor)).ok());
  bracket[1].metadata.exposure_us = 0;
  const Result<HdrImage> no_time = MergeBracket(bracket, NoiseOf(sensor));
  ASSERT_FALSE(no_time.ok());
  EXPECT_EQ(no_time.status().subject(), "frame 1 of camera 'cam0'");
  bracket[1].metadata.exposure_us = 400;
  bracket[1].width = 2;
  bracket[1].height = 8;
  EXPECT_EQ(MergeBracket(bracket, NoiseOf(sensor)).status().code(), StatusCode::kInvalidArgument);
}

// A steady grey field over a 4× bracket: the simulator's linear sensor agrees with itself to
// the noise; a sensor whose response sags 6 % towards full scale is caught.
TEST(HdrMergeTest, LinearityOfASteadyScene) {
  const SensorModel sensor = TestSensor();
  Image radiance(64, 64, {"L"});
  const double reading_at_longest = 3000;  // DN above black at 4000 µs
  const auto grey = radiance.channel(0);
  std::fill(grey.begin(), grey.end(),
            static_cast<float>(reading_at_longest * sensor.ElectronsPerDn() / (sensor.sensitivity * 4000e-6)));
  std::vector<scan::RawFrame> bracket = Bracket(radiance, sensor, {250, 1000, 4000});
  const Result<Linearity> linear = MeasureLinearity(bracket, NoiseOf(sensor));
  ASSERT_TRUE(linear.ok()) << linear.status().ToString();
  EXPECT_EQ(linear->pairs, 2);
  EXPECT_NEAR(linear->max_dn, reading_at_longest, 100);
  EXPECT_LT(linear->deviation, 0.005);
  for (scan::RawFrame& frame : bracket) {
    for (uint16_t& v : frame.pixels) {
      const double s = v - sensor.dark_offset_dn;
      v = static_cast<uint16_t>(std::lround(sensor.dark_offset_dn + s * (1 - 0.06 * s / 4031)));
    }
  }
  const Result<Linearity> sagging = MeasureLinearity(bracket, NoiseOf(sensor));
  ASSERT_TRUE(sagging.ok());
  EXPECT_GT(sagging->deviation, 0.03);
  // Nothing read well: not measured.
  EXPECT_EQ(MeasureLinearity(bracket, NoiseOf(sensor), std::vector<uint8_t>(64 * 64, 0))->pairs, 0);
}

}  // namespace
}  // namespace loom::calibration
