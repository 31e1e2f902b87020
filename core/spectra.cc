#include "core/spectra.h"

#include <cmath>

namespace loom {
namespace {

double Gaussian(double x, double mean, double sigma) {
  const double z = (x - mean) / sigma;
  return std::exp(-0.5 * z * z);
}

// White LED: the blue pump and the broad phosphor emission.
double LedSpectrum(double nm) { return 0.9 * Gaussian(nm, 450, 10) + 1.0 * Gaussian(nm, 565, 55); }
// Panchromatic silicon sensor behind a UV/IR cut filter.
double SensorResponse(double nm) { return Gaussian(nm, 560, 110) * (nm > 390 && nm < 710 ? 1.0 : 0.02); }
// Reflectance basis of linear-sRGB albedo (red, green, blue).
double Basis(int channel, double nm) {
  switch (channel) {
    case 0:
      return Gaussian(nm, 610, 45) + 0.35 * Gaussian(nm, 700, 40);
    case 1:
      return Gaussian(nm, 545, 38);
    default:
      return Gaussian(nm, 455, 32);
  }
}

template <typename Transmission>
Eigen::Vector3d Integrate(Transmission transmission) {
  Eigen::Vector3d w = Eigen::Vector3d::Zero();
  for (double nm = 380; nm <= 780; nm += 1) {
    const double light = LedSpectrum(nm) * SensorResponse(nm) * transmission(nm);
    for (int c = 0; c < 3; ++c) w[c] += light * Basis(c, nm);
  }
  return w;
}

double Normaliser() {
  static const double total = Integrate([](double) { return 1.0; }).sum();
  return total;
}

}  // namespace

Eigen::Vector3d PanchromaticWeights() {
  return Integrate([](double) { return 1.0; }) / Normaliser();
}

Eigen::Vector3d FilterWeights(const FilterModel& filter) {
  if (filter.open) return PanchromaticWeights();
  if (filter.measured_weights) return *filter.measured_weights;
  const double sigma = filter.fwhm_nm / (2 * std::sqrt(2 * std::log(2.0)));
  return Integrate([&](double nm) { return filter.peak_transmission * Gaussian(nm, filter.center_nm, sigma); }) / Normaliser();
}

}  // namespace loom
