#include "core/spectra.h"

#include <gtest/gtest.h>

namespace loom {
namespace {

TEST(SpectraTest, FiltersSeeColour) {
  const Eigen::Vector3d pan = PanchromaticWeights();
  EXPECT_NEAR(pan.sum(), 1.0, 1e-12);
  const Eigen::Vector3d red(0.7, 0.05, 0.05);
  const Eigen::Vector3d blue(0.05, 0.05, 0.7);
  const FilterModel long_pass = FilterModel::BandPass(650, 30);
  const FilterModel short_pass = FilterModel::BandPass(450, 30);
  EXPECT_GT(FilterWeights(long_pass).dot(red), 5 * FilterWeights(long_pass).dot(blue));
  EXPECT_GT(FilterWeights(short_pass).dot(blue), 5 * FilterWeights(short_pass).dot(red));
  EXPECT_LT(FilterWeights(long_pass).sum(), 0.3);  // a band-pass filter lets a fraction through
}

}  // namespace
}  // namespace loom
